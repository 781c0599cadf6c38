//! The `model` crate (being built).
#![deny(missing_docs)]
