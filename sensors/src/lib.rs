//! The `sensors` crate (being built).
#![deny(missing_docs)]
