//! The two storage paths: [`Dyn`] (heap buffers, faer GEMM for large products) and
//! [`Fixed`] (const-generic inline arrays for n, m ≤ 16). Kernels see only slices.

use core::fmt::Debug;

use crate::kernels;

/// A column-major buffer of `f64` (a `Vec` on the dynamic path, an inline array on the fixed
/// path). Sealed: implemented only by this crate's buffer types.
pub trait Buf: Clone + Debug + Send + Sync + private::Sealed {
    /// A zero buffer able to hold `len` entries (fixed buffers ignore `len`; their size is
    /// checked by [`Dims`]).
    fn zeros(len: usize) -> Self;
    /// The entries.
    fn as_slice(&self) -> &[f64];
    /// The entries, mutable.
    fn as_mut_slice(&mut self) -> &mut [f64];
}

impl Buf for Vec<f64> {
    fn zeros(len: usize) -> Self {
        vec![0.0; len]
    }
    fn as_slice(&self) -> &[f64] {
        self
    }
    fn as_mut_slice(&mut self) -> &mut [f64] {
        self
    }
}

/// An inline `R`×`C` column-major array (the fixed path's buffer).
#[derive(Clone, Copy, Debug)]
pub struct Arr<const R: usize, const C: usize>(pub [[f64; R]; C]);

impl<const R: usize, const C: usize> Buf for Arr<R, C> {
    fn zeros(_len: usize) -> Self {
        Arr([[0.0; R]; C])
    }
    fn as_slice(&self) -> &[f64] {
        self.0.as_flattened()
    }
    fn as_mut_slice(&mut self) -> &mut [f64] {
        self.0.as_flattened_mut()
    }
}

mod private {
    pub trait Sealed {}
    impl Sealed for Vec<f64> {}
    impl<const R: usize, const C: usize> Sealed for super::Arr<R, C> {}
    impl Sealed for super::Dyn {}
    impl<const N: usize, const M: usize, const P: usize> Sealed for super::Fixed<N, M, P> {}
}

/// The dimensions of a filter problem and the storage that goes with them: n states,
/// m measurements, p control inputs. Implemented by [`Dyn`] and [`Fixed`] only.
pub trait Dims: Copy + Debug + Send + Sync + private::Sealed + 'static {
    /// n×n buffers (F, Q, P).
    type Nn: Buf;
    /// n×m buffers (K, S).
    type Nm: Buf;
    /// m×n buffers (H).
    type Mn: Buf;
    /// m×m buffers (R, innovation covariance).
    type Mm: Buf;
    /// n×p buffers (B).
    type Np: Buf;
    /// n-vectors.
    type Nv: Buf;
    /// m-vectors.
    type Mv: Buf;
    /// (n+m)×(n+m) buffers (the joint noise factor).
    type Joint: Buf;
    /// (m+2n)×(m+2n) buffers (the square-root pre-array).
    type Array: Buf;
    /// Number of states.
    fn n(&self) -> usize;
    /// Number of measurements.
    fn m(&self) -> usize;
    /// Number of control inputs.
    fn p(&self) -> usize;
    /// Whether this is the fixed-size path (dimensions limited to [`FIXED_MAX`]).
    fn is_fixed(&self) -> bool {
        false
    }
    /// `C = beta·C + alpha·op(A)·op(B)` on column-major slices (`C` is `rows`×`cols`, the
    /// inner dimension `inner`); only the lower triangle of `C` when `lower` (for
    /// symmetric results). The dynamic path hands large products to faer.
    #[doc(hidden)]
    #[inline(always)]
    fn gemm(&self, g: kernels::Gemm<'_>, c: &mut [f64]) {
        kernels::gemm(g, c);
    }
}

/// Dynamic dimensions (the default path): heap buffers allocated once at construction,
/// products at or above [`FAER_THRESHOLD`] multiply-adds go to faer's GEMM with `Par::Seq`
/// (or Rayon with the `parallel` feature and [`PARALLEL_THRESHOLD`]).
///
/// # Example
/// ```
/// use kalman::{Dyn, Error};
///
/// let dims = Dyn::new(7, 2, 0)?; // n = 7 states, m = 2 measurements, no input
/// assert!(matches!(Dyn::new(0, 1, 0), Err(Error::Dimension { name: "n", .. })));
/// # let _ = dims;
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Dyn {
    n: usize,
    m: usize,
    p: usize,
}

/// Products with `rows·cols·inner` below this many multiply-adds use the crate's own loops
/// on the dynamic path. Chosen from faer's per-call overhead (20–75 ns a call, measured
/// with faer 0.24), about the cost of this many multiply-adds in plain loops; not
/// tuned further.
pub const FAER_THRESHOLD: usize = 8 * 8 * 8;

/// With the `parallel` feature, products of at least this many multiply-adds run on Rayon
/// (faer's own default of 32 768 was 3.6× slower at n = 50 on a 2-core machine; Rayon paid
/// off only near n = 1000). On a loaded machine Rayon can lose even
/// there: the feature is off by default.
pub const PARALLEL_THRESHOLD: usize = 400 * 400 * 400;

impl Dyn {
    /// Dimensions n (states, ≥ 1), m (measurements, ≥ 1), p (control inputs, may be 0).
    ///
    /// # Errors
    /// [`crate::Error::Dimension`] if n or m is 0.
    pub fn new(n: usize, m: usize, p: usize) -> Result<Self, crate::Error> {
        if n == 0 {
            return Err(crate::Error::Dimension {
                name: "n",
                value: n,
                rule: "at least one state",
            });
        }
        if m == 0 {
            return Err(crate::Error::Dimension {
                name: "m",
                value: m,
                rule: "at least one measurement",
            });
        }
        Ok(Dyn { n, m, p })
    }
}

impl Dims for Dyn {
    type Nn = Vec<f64>;
    type Nm = Vec<f64>;
    type Mn = Vec<f64>;
    type Mm = Vec<f64>;
    type Np = Vec<f64>;
    type Nv = Vec<f64>;
    type Mv = Vec<f64>;
    type Joint = Vec<f64>;
    type Array = Vec<f64>;
    fn n(&self) -> usize {
        self.n
    }
    fn m(&self) -> usize {
        self.m
    }
    fn p(&self) -> usize {
        self.p
    }
    #[inline]
    fn gemm(&self, g: kernels::Gemm<'_>, c: &mut [f64]) {
        if g.rows * g.cols * g.inner < FAER_THRESHOLD {
            kernels::gemm(g, c);
        } else {
            kernels::gemm_faer(g, c);
        }
    }
}

/// Fixed dimensions known at compile time (n = `N` ≤ 16, m = `M` ≤ 16, p = `P` ≤ 16
/// control inputs): all buffers inline, loops unrolled by the compiler. Same API and
/// results as [`Dyn`].
///
/// # Example
/// ```
/// use kalman::{CovarianceForm, Filter, Fixed, Model};
///
/// // The same random walk on the fixed-size path: storage inline, n = m = 1.
/// let model = Model::new(Fixed::<1, 1>::new(), &[[1.0]], &[[1.0]], &[[0.5]], &[[1.0]])?;
/// let mut filter = Filter::new(model, &[0.0], &[[1.0]], CovarianceForm::Joseph)?;
/// filter.step(&[2.0], None)?;
/// assert!((filter.state()[0] - 1.0).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Fixed<const N: usize, const M: usize, const P: usize = 0>(());

/// Largest n and m of the fixed-size path.
pub const FIXED_MAX: usize = 16;

impl<const N: usize, const M: usize, const P: usize> Fixed<N, M, P> {
    /// The fixed dimensions (checked at compile time: 1 ≤ N, M ≤ 16, P ≤ 16).
    pub const fn new() -> Self {
        const {
            assert!(N >= 1 && N <= FIXED_MAX, "Fixed: N must be in 1..=16");
            assert!(M >= 1 && M <= FIXED_MAX, "Fixed: M must be in 1..=16");
            assert!(P <= FIXED_MAX, "Fixed: P must be at most 16");
        }
        Fixed(())
    }
}

impl<const N: usize, const M: usize, const P: usize> Dims for Fixed<N, M, P> {
    type Nn = Arr<N, N>;
    type Nm = Arr<N, M>;
    type Mn = Arr<M, N>;
    type Mm = Arr<M, M>;
    type Np = Arr<N, P>;
    type Nv = Arr<N, 1>;
    type Mv = Arr<M, 1>;
    // (n+m)² ≤ 32², (m+2n)² ≤ 48²: no generic const expressions on stable Rust, so these
    // two are sized for the largest fixed model and used with a leading dimension.
    type Joint = Arr<32, 32>;
    type Array = Arr<48, 48>;
    #[inline(always)]
    fn n(&self) -> usize {
        N
    }
    #[inline(always)]
    fn m(&self) -> usize {
        M
    }
    #[inline(always)]
    fn p(&self) -> usize {
        P
    }
    fn is_fixed(&self) -> bool {
        true
    }
}
