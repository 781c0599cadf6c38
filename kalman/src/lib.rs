//! The `kalman` crate (being built).
#![deny(missing_docs)]
