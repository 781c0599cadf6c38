//! Criterion benches of one filter step (update + predict, Joseph form) at
//! (n, m) = (2, 1), (7, 2), (50, 10), (200, 20), (1000, 50), against nalgebra baselines in the
//! same group: a straightforward fixed-size nalgebra Joseph filter at the two small sizes
//! (`baseline_nalgebra_fixed`), nalgebra `DMatrix` with preallocated matrices at the large
//! ones (`baseline_nalgebra_dyn`). The problem is deterministic (no RNG needed) and identical
//! to the one `benches/kalman/filterpy_step.py` builds, so the FilterPy timing is comparable.
#![allow(non_snake_case, missing_docs, clippy::unwrap_used)]

mod common;

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use faer::Mat;
use kalman::{CovarianceForm, Dims, DynDims, Filter, FixedDims};
use nalgebra::{DMatrix, DVector, SMatrix, SVector};

use common::{Problem, model, problem};

fn engine<D: Dims>(p: &Problem, dims: D) -> Filter<D> {
    let n = dims.n();
    Filter::new(
        model(p, dims),
        &vec![0.0; n],
        &Mat::<f64>::identity(n, n),
        CovarianceForm::Joseph,
    )
    .unwrap()
}

/// The straightforward nalgebra fixed-size Joseph filter.
struct NaFixed<const N: usize, const M: usize> {
    F: SMatrix<f64, N, N>,
    H: SMatrix<f64, M, N>,
    Q: SMatrix<f64, N, N>,
    R: SMatrix<f64, M, M>,
    x: SVector<f64, N>,
    P: SMatrix<f64, N, N>,
}

impl<const N: usize, const M: usize> NaFixed<N, M> {
    fn new(p: &Problem) -> Self {
        NaFixed {
            F: SMatrix::from_fn(|i, j| p.F[(i, j)]),
            H: SMatrix::from_fn(|i, j| p.H[(i, j)]),
            Q: SMatrix::from_fn(|i, j| p.Q[(i, j)]),
            R: SMatrix::from_fn(|i, j| p.R[(i, j)]),
            x: SVector::zeros(),
            P: SMatrix::identity(),
        }
    }
    fn step(&mut self, z: &SVector<f64, M>) {
        let e = z - self.H * self.x;
        let S = self.H * self.P * self.H.transpose() + self.R;
        let chol = S.cholesky().unwrap();
        let K = chol.solve(&(self.H * self.P)).transpose();
        self.x += K * e;
        let A = SMatrix::<f64, N, N>::identity() - K * self.H;
        self.P = A * self.P * A.transpose() + K * self.R * K.transpose();
        self.x = self.F * self.x;
        self.P = self.F * self.P * self.F.transpose() + self.Q;
    }
}

/// nalgebra `DMatrix` Joseph filter with every matrix preallocated.
struct NaDyn {
    F: DMatrix<f64>,
    Ft: DMatrix<f64>,
    H: DMatrix<f64>,
    Ht: DMatrix<f64>,
    Q: DMatrix<f64>,
    R: DMatrix<f64>,
    x: DVector<f64>,
    xt: DVector<f64>,
    e: DVector<f64>,
    P: DMatrix<f64>,
    hp: DMatrix<f64>,
    sig: DMatrix<f64>,
    K: DMatrix<f64>,
    Kt: DMatrix<f64>,
    kr: DMatrix<f64>,
    A: DMatrix<f64>,
    At: DMatrix<f64>,
    T: DMatrix<f64>,
}

impl NaDyn {
    fn new(p: &Problem) -> Self {
        let (n, m) = (p.F.nrows(), p.H.nrows());
        let F = DMatrix::from_fn(n, n, |i, j| p.F[(i, j)]);
        let H = DMatrix::from_fn(m, n, |i, j| p.H[(i, j)]);
        NaDyn {
            Ft: F.transpose(),
            Ht: H.transpose(),
            F,
            H,
            Q: DMatrix::from_fn(n, n, |i, j| p.Q[(i, j)]),
            R: DMatrix::from_fn(m, m, |i, j| p.R[(i, j)]),
            x: DVector::zeros(n),
            xt: DVector::zeros(n),
            e: DVector::zeros(m),
            P: DMatrix::identity(n, n),
            hp: DMatrix::zeros(m, n),
            sig: DMatrix::zeros(m, m),
            K: DMatrix::zeros(n, m),
            Kt: DMatrix::zeros(m, n),
            kr: DMatrix::zeros(n, m),
            A: DMatrix::zeros(n, n),
            At: DMatrix::zeros(n, n),
            T: DMatrix::zeros(n, n),
        }
    }
    fn step(&mut self, z: &[f64]) {
        let n = self.x.len();
        self.e.copy_from_slice(z);
        self.e.gemv(-1.0, &self.H, &self.x, 1.0);
        self.hp.gemm(1.0, &self.H, &self.P, 0.0);
        self.sig.gemm(1.0, &self.hp, &self.Ht, 0.0);
        self.sig += &self.R;
        let sig = std::mem::replace(&mut self.sig, DMatrix::zeros(0, 0));
        let chol = sig.cholesky().unwrap();
        self.Kt.copy_from(&self.hp);
        chol.solve_mut(&mut self.Kt);
        self.sig = chol.unpack();
        self.Kt.transpose_to(&mut self.K);
        self.x.gemv(1.0, &self.K, &self.e, 1.0);
        self.A.gemm(-1.0, &self.K, &self.H, 0.0);
        for i in 0..n {
            self.A[(i, i)] += 1.0;
        }
        self.A.transpose_to(&mut self.At);
        self.T.gemm(1.0, &self.A, &self.P, 0.0);
        self.P.gemm(1.0, &self.T, &self.At, 0.0);
        self.kr.gemm(1.0, &self.K, &self.R, 0.0);
        self.P.gemm(1.0, &self.kr, &self.Kt, 1.0);
        self.xt.gemv(1.0, &self.F, &self.x, 0.0);
        std::mem::swap(&mut self.x, &mut self.xt);
        self.T.gemm(1.0, &self.F, &self.P, 0.0);
        self.P.gemm(1.0, &self.T, &self.Ft, 0.0);
        self.P += &self.Q;
    }
}

fn small<const N: usize, const M: usize>(
    c: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
) {
    let p = problem(N, M);
    let label = format!("({N},{M})");
    let zs: Vec<SVector<f64, M>> = p.z.iter().map(|z| SVector::from_column_slice(z)).collect();
    let mut na = NaFixed::<N, M>::new(&p);
    let mut k = 0;
    c.bench_function(BenchmarkId::new("baseline_nalgebra_fixed", &label), |b| {
        b.iter(|| {
            k = (k + 1) % zs.len();
            na.step(black_box(&zs[k]));
        })
    });
    let mut fixed = engine(&p, FixedDims::<N, M, 0>::new());
    c.bench_function(BenchmarkId::new("kalman_fixed", &label), |b| {
        b.iter(|| {
            k = (k + 1) % p.z.len();
            black_box(fixed.step(black_box(&p.z[k]), None).unwrap());
        })
    });
    let mut dynf = engine(&p, DynDims::new(N, M, 0).unwrap());
    c.bench_function(BenchmarkId::new("kalman_dyn", &label), |b| {
        b.iter(|| {
            k = (k + 1) % p.z.len();
            black_box(dynf.step(black_box(&p.z[k]), None).unwrap());
        })
    });
}

fn large(
    c: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    n: usize,
    m: usize,
) {
    let p = problem(n, m);
    let label = format!("({n},{m})");
    let mut na = NaDyn::new(&p);
    let mut k = 0;
    c.bench_function(BenchmarkId::new("baseline_nalgebra_dyn", &label), |b| {
        b.iter(|| {
            k = (k + 1) % p.z.len();
            na.step(black_box(&p.z[k]));
        })
    });
    let mut dynf = engine(&p, DynDims::new(n, m, 0).unwrap());
    c.bench_function(BenchmarkId::new("kalman_dyn", &label), |b| {
        b.iter(|| {
            k = (k + 1) % p.z.len();
            black_box(dynf.step(black_box(&p.z[k]), None).unwrap());
        })
    });
}

fn step(c: &mut Criterion) {
    let mut g = c.benchmark_group("step");
    small::<2, 1>(&mut g);
    small::<7, 2>(&mut g);
    large(&mut g, 50, 10);
    large(&mut g, 200, 20);
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(4));
    large(&mut g, 1000, 50);
    g.finish();
}

criterion_group!(benches, step);
criterion_main!(benches);
