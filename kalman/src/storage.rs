//! The two storage paths: [`DynDims`] (heap buffers sized at construction) and [`FixedDims`]
//! (const-generic inline arrays sized by N, M and P). Kernels see only slices.

use core::fmt::Debug;

/// The dimensions of a filter problem and the storage that goes with them: n states,
/// m measurements, p control inputs. Implemented by [`DynDims`] and [`FixedDims`] only (sealed).
pub trait Dims: Copy + Debug + Send + Sync + sealed::Storage + 'static {
    /// Number of states.
    fn n(&self) -> usize;
    /// Number of measurements.
    fn m(&self) -> usize;
    /// Number of control inputs.
    fn p(&self) -> usize;
    /// Length of a stored state: n for a vector state; more than n for a state on a
    /// manifold stored redundantly (a unit quaternion: 4 stored, 3 in its tangent space),
    /// where n is the tangent dimension (of P, Q and the Jacobians). Only the nonlinear
    /// filters hold such states.
    fn stored(&self) -> usize {
        self.n()
    }
    /// Whether this is the fixed-size path (dimensions limited to [`FIXED_MAX`]; products
    /// always in the crate's own loops).
    fn is_fixed(&self) -> bool {
        false
    }
}

/// The buffers behind [`Dims`], out of the public API: the crate names them as `D::Nn`,
/// `D::Mi`, …; users never need to.
pub(crate) mod sealed {
    use core::fmt::Debug;

    /// An element of a buffer.
    pub trait Elem: Copy + Default + Debug + Send + Sync + 'static {}
    impl Elem for f64 {}
    impl Elem for bool {}
    impl Elem for usize {}
    impl Elem for Option<usize> {}

    /// A column-major buffer (a `Vec` on the dynamic path, an inline array on the fixed one).
    pub trait Buf<T: Elem>: Clone + Debug + Send + Sync {
        /// A buffer of `len` default entries (fixed buffers ignore `len`: their size is the
        /// type's).
        fn zeros(len: usize) -> Self;
        /// The entries.
        fn as_slice(&self) -> &[T];
        /// The entries, mutable.
        fn as_mut_slice(&mut self) -> &mut [T];
    }

    impl<T: Elem> Buf<T> for Vec<T> {
        fn zeros(len: usize) -> Self {
            vec![T::default(); len]
        }
        fn as_slice(&self) -> &[T] {
            self
        }
        fn as_mut_slice(&mut self) -> &mut [T] {
            self
        }
    }

    /// An inline `R`×`C` column-major array (the fixed path's buffer).
    #[derive(Clone, Copy, Debug)]
    pub struct Arr<T, const R: usize, const C: usize>([[T; R]; C]);

    impl<T: Elem, const R: usize, const C: usize> Buf<T> for Arr<T, R, C> {
        fn zeros(_len: usize) -> Self {
            Arr([[T::default(); R]; C])
        }
        fn as_slice(&self) -> &[T] {
            self.0.as_flattened()
        }
        fn as_mut_slice(&mut self) -> &mut [T] {
            self.0.as_flattened_mut()
        }
    }

    /// The buffer types of a storage path.
    pub trait Storage {
        /// n×n buffers (F, Q, P).
        type Nn: Buf<f64>;
        /// n×m buffers (K, S).
        type Nm: Buf<f64>;
        /// m×n buffers (H).
        type Mn: Buf<f64>;
        /// m×m buffers (R, innovation covariance).
        type Mm: Buf<f64>;
        /// n×p buffers (B).
        type Np: Buf<f64>;
        /// n-vectors.
        type Nv: Buf<f64>;
        /// m-vectors.
        type Mv: Buf<f64>;
        /// Per-measurement flags (the observation mask).
        type Mb: Buf<bool>;
        /// Per-measurement indices (a row's pivot column; a pivot's row).
        type Mi: Buf<usize>;
        /// Per-measurement optional indices (pivot columns, `None` for a dependent row).
        type Mo: Buf<Option<usize>>;
        /// Per-state optional indices.
        type No: Buf<Option<usize>>;
        /// The same dimensions with `p` control inputs, where the path can change p after
        /// construction (the dynamic one); `None` where p is part of the type.
        fn with_inputs(self, _p: usize) -> Option<Self>
        where
            Self: Sized,
        {
            None
        }
    }

    impl Storage for super::DynDims {
        type Nn = Vec<f64>;
        type Nm = Vec<f64>;
        type Mn = Vec<f64>;
        type Mm = Vec<f64>;
        type Np = Vec<f64>;
        type Nv = Vec<f64>;
        type Mv = Vec<f64>;
        type Mb = Vec<bool>;
        type Mi = Vec<usize>;
        type Mo = Vec<Option<usize>>;
        type No = Vec<Option<usize>>;
        fn with_inputs(self, p: usize) -> Option<Self> {
            Some(super::DynDims { p, ..self })
        }
    }

    impl<const N: usize, const M: usize, const P: usize, const S: usize> Storage
        for super::FixedDims<N, M, P, S>
    {
        type Nn = Arr<f64, N, N>;
        type Nm = Arr<f64, N, M>;
        type Mn = Arr<f64, M, N>;
        type Mm = Arr<f64, M, M>;
        type Np = Arr<f64, N, P>;
        type Nv = Arr<f64, N, 1>;
        type Mv = Arr<f64, M, 1>;
        type Mb = Arr<bool, M, 1>;
        type Mi = Arr<usize, M, 1>;
        type Mo = Arr<Option<usize>, M, 1>;
        type No = Arr<Option<usize>, N, 1>;
    }
}

pub(crate) use sealed::Buf;

/// Dynamic dimensions (the default path): heap buffers allocated once at construction;
/// products of at least [`crate::FAER_THRESHOLD`] multiply-adds go to faer's GEMM.
///
/// # Example
/// ```
/// use kalman::{DynDims, Error};
///
/// let dims = DynDims::new(7, 2, 0)?; // n = 7 states, m = 2 measurements, no input
/// assert!(matches!(DynDims::new(0, 1, 0), Err(Error::Dimension { name: "n", .. })));
/// # let _ = dims;
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DynDims {
    n: usize,
    m: usize,
    p: usize,
    /// Stored length of a state (n unless set by [`DynDims::with_stored`]).
    s: usize,
}

impl DynDims {
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
        Ok(DynDims { n, m, p, s: n })
    }

    /// The same dimensions for a state on a manifold stored in `stored` ≥ n numbers, n
    /// being its tangent dimension (a unit quaternion and a gyro bias: n = 6, stored = 7).
    /// For the nonlinear filters with a model that declares its manifold (a
    /// `NonlinearModel` whose `manifold_dims` is not `None`).
    ///
    /// ```
    /// use kalman::{Dims, DynDims};
    /// let d = DynDims::new(6, 3, 3)?.with_stored(7)?;
    /// assert_eq!((d.n(), d.stored()), (6, 7));
    /// assert!(DynDims::new(6, 3, 3)?.with_stored(5).is_err());
    /// # Ok::<(), kalman::Error>(())
    /// ```
    ///
    /// # Errors
    /// [`crate::Error::Dimension`] if `stored` < n.
    pub fn with_stored(self, stored: usize) -> Result<Self, crate::Error> {
        if stored < self.n {
            return Err(crate::Error::Dimension {
                name: "stored",
                value: stored,
                rule: "a stored state holds at least its n tangent dimensions",
            });
        }
        Ok(DynDims { s: stored, ..self })
    }
}

impl Dims for DynDims {
    #[inline(always)]
    fn n(&self) -> usize {
        self.n
    }
    #[inline(always)]
    fn m(&self) -> usize {
        self.m
    }
    #[inline(always)]
    fn p(&self) -> usize {
        self.p
    }
    #[inline(always)]
    fn stored(&self) -> usize {
        self.s
    }
}

/// Fixed dimensions known at compile time (n = `N` ≤ 16, m = `M` ≤ 16, p = `P` ≤ 16
/// control inputs, and `S` numbers per stored state, `N` ≤ `S` ≤ 32: `S` = `N` unless the
/// state lives on a manifold, see [`Dims::stored`]): every buffer is an inline array of exactly its size (a
/// `FixedFilter<2, 1>` is a few hundred bytes), loops are unrolled by the compiler. Same
/// API and results as [`DynDims`]. The one heap buffer is the square-root form's
/// (m + 2n)² pre-array, allocated when such a filter is built (stable Rust cannot size an
/// inline array by `M + 2N`); no form allocates in a step.
///
/// # Example
/// ```
/// use kalman::{CovarianceForm, Filter, FixedDims, Model};
///
/// // The same random walk on the fixed-size path: storage inline, n = m = 1.
/// let model = Model::new(FixedDims::<1, 1>::new(), &[[1.0]], &[[1.0]], &[[0.5]], &[[1.0]])?;
/// let mut filter = Filter::new(model, &[0.0], &[[1.0]], CovarianceForm::Joseph)?;
/// filter.step(&[2.0], None)?;
/// assert!((filter.state()[0] - 1.0).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FixedDims<const N: usize, const M: usize, const P: usize = 0, const S: usize = N>(());

/// Largest n and m of the fixed-size path.
pub const FIXED_MAX: usize = 16;

impl<const N: usize, const M: usize, const P: usize, const S: usize> FixedDims<N, M, P, S> {
    /// The fixed dimensions (checked at compile time: 1 ≤ N, M ≤ 16, P ≤ 16, N ≤ S ≤ 32).
    pub const fn new() -> Self {
        const {
            assert!(N >= 1 && N <= FIXED_MAX, "FixedDims: N must be in 1..=16");
            assert!(M >= 1 && M <= FIXED_MAX, "FixedDims: M must be in 1..=16");
            assert!(P <= FIXED_MAX, "FixedDims: P must be at most 16");
            assert!(
                S >= N && S <= 2 * FIXED_MAX,
                "FixedDims: S must be in N..=32"
            );
        }
        FixedDims(())
    }
}

impl<const N: usize, const M: usize, const P: usize, const S: usize> Dims
    for FixedDims<N, M, P, S>
{
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
    #[inline(always)]
    fn stored(&self) -> usize {
        S
    }
    #[inline(always)]
    fn is_fixed(&self) -> bool {
        true
    }
}
