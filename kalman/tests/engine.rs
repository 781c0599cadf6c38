//! Integration tests of the filter engine (one binary; topics in `tests/engine/`).
#![allow(non_snake_case)]

mod engine {
    pub mod agreement;
    pub mod reference;
}
