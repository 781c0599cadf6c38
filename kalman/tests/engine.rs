//! Integration tests of the filter engine (one binary; topics in `tests/engine/`).
#![allow(non_snake_case)]

mod engine {
    pub mod agreement;
    pub mod alloc;
    pub mod correlated;
    pub mod errors;
    pub mod fuel;
    pub mod misc;
    pub mod nis;
    pub mod props;
    pub mod reference;
}
