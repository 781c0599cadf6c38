//! The `model` crate's integration tests: one binary, one submodule per area.

#![allow(non_snake_case)]

mod model {
    pub mod analysis;
    pub mod bridge;
    pub mod compose;
    pub mod discretization;
    pub mod errors;
    pub mod fuel;
    pub mod serde_roundtrip;
    pub mod shaping;
    pub mod shaping_default;
    pub mod support;
}
