//! dynotraj-edge: the firmware loop.
#![no_std]
