//! predict (in progress).
