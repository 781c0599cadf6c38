//! Integration tests of the `kalman` crate, one binary: the filter engine
//! in `engine/`, steady state, continuous time, smoothing and the Monte Carlo mode in
//! `steady/`, the nonlinear filters in `nonlinear/`, and the counting global allocator both use in `common/`.
#![allow(non_snake_case)]

/// The three covariance forms, for tests that must hold in each.
const FORMS: [kalman::CovarianceForm; 3] = [
    kalman::CovarianceForm::Joseph,
    kalman::CovarianceForm::Standard,
    kalman::CovarianceForm::SquareRoot,
];

mod common {
    pub mod counting;
}

mod engine {
    pub mod agreement;
    pub mod alloc;
    pub mod batch;
    pub mod correlated;
    pub mod diverge;
    pub mod errors;
    pub mod fuel;
    pub mod misc;
    pub mod nis;
    pub mod props;
    pub mod reference;
}

mod nonlinear {
    pub mod alloc;
    pub mod attitude;
    pub mod common;
    pub mod continuous;
    pub mod errors;
    pub mod fixed_lag;
    pub mod golden;
    pub mod jacobians;
    pub mod linear;
    pub mod models;
    pub mod nis;
    pub mod sigma_sets;
    pub mod sqrt;
    pub mod symmetry;
}

mod fit {
    pub mod common;
    pub mod coverage;
    pub mod diffuse;
    pub mod entries;
    pub mod estimators;
    pub mod filter_error;
    pub mod free_names;
    pub mod golden;
    pub mod honest;
    pub mod likelihood;
    pub mod output_error;
    pub mod pendulum;
    pub mod records;
    pub mod sampled;
}

mod steady {
    pub mod benchmarks;
    pub mod common;
    pub mod continuous;
    pub mod riccati;
    pub mod schedule;
    pub mod smoother;
}

mod imm {
    pub mod golden;
    pub mod manoeuvre;
    pub mod modes;
    pub mod smoother;
}

mod particle {
    pub mod common;
    pub mod determinism;
    pub mod linear;
    pub mod resampling;
}
