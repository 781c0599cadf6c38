//! Integration tests of the steady-state, continuous-time, smoothing and Monte Carlo parts
//! (issue 5): one binary, topics in `tests/steady/`.
#![allow(non_snake_case)]

mod steady {
    pub mod alloc;
    pub mod common;
    pub mod continuous;
    pub mod riccati;
    pub mod schedule;
    pub mod smoother;
}
