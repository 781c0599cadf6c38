//! The `wls` crate (being built).
#![deny(missing_docs)]
