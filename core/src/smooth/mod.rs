//! smooth (in progress).
