"""launch_estimation: the estimation engine from Python.

Notation: n states, m measurements, p control inputs;
x[k+1] = F x[k] + B u[k] + w[k],  z[k] = H x[k] + v[k],
cov(w) = Q, cov(v) = R, E[w[k] v[k]^T] = S (the engine's cross-covariance).
The continuous-discrete functions (filter_continuous, smooth_continuous) take
dx/dt = A x + B u + w, E[w(t) w(s)^T] = W delta(t - s), measured at time stamps t[k]:
z[k] = C x(t[k]) + v[k], cov(v[k]) = R.

FilterPy's ``M`` (``KalmanFilter.update_correlated``) is a different quantity: the
cross-covariance of the *prior state error* x[k] - x[k|k-1] with v[k]. When the prior comes
from a prediction with correlated noise, x[k] - x[k|k-1] = F e[k-1] + w[k-1], so M[k] is the
engine's S of the previous step's noise pair, E[w[k-1] v[k]^T] — the two models shift the
index: the engine's S couples w[k] with v[k] and enters the *prediction*; FilterPy's M enters
the *update*. A model with E[w[k-1] v[k]^T] = S is run in FilterPy with M = S, and in the
engine by re-indexing the process noise.

All inputs are NumPy arrays (integer and float32 arrays are converted to float64; R of
dare/dlqr/care may be a number for one channel); lists, other dtypes and non-finite values
are refused with a one-line TypeError/ValueError naming the argument. A size that does not
fit in memory raises MemoryError; Ctrl-C inside a long call raises KeyboardInterrupt.
"""

from typing import Any, Callable, Final, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]
MatrixLike = Union[npt.NDArray[Any], float]
_Series = Union[Sequence[Any], npt.NDArray[Any]]
_Measurement = Union[None, float, Sequence[float], npt.NDArray[Any]]
# One matrix per step: a sequence of len(zs) matrices (each an array, a scalar s for s*I
# where square (not B), or None for the filter's own), or an array (len(zs), rows, cols).
_PerStep = Union[Sequence[Optional[MatrixLike]], npt.NDArray[Any]]

class KalmanFilter:
    """FilterPy's ``KalmanFilter`` (predict/update, correlated update, batch filter, RTS
    smoother) with its state in Rust.

    ``from filterpy.kalman import KalmanFilter`` -> ``from launch_estimation import
    KalmanFilter`` runs a FilterPy script unchanged for the attributes and methods below,
    with FilterPy's shapes: x is (dim_x, 1) (or (dim_x,) if set so), P, F, Q (dim_x, dim_x),
    H (dim_z, dim_x), R (dim_z, dim_z), B (dim_x, dim_u) or None, M and K (dim_x, dim_z),
    y (dim_z, 1), S (dim_z, dim_z).

    Differences from FilterPy, and why:

    - Attributes are checked when set (shape, finiteness; P, Q, R symmetric positive
      semi-definite): a bad value raises at once instead of producing NaNs later. A list is
      refused for a matrix (TypeError); FilterPy silently keeps it.
    - A scalar assigned to P, Q, R or F means that multiple of the identity; FilterPy adds
      it to every entry by broadcasting (the same when the matrix is 1x1).
    - NaN entries of z skip their rows (FilterPy has no partial update); K, y, S have zeros
      in the rows/columns of the missing entries; log_likelihood and mahalanobis use the
      present rows. ``z = None`` skips the update as in FilterPy.
    - K is computed by solving with a Cholesky factor of S (LU if S is not positive
      definite) rather than with inv(S); SI is computed from the factor when read. A
      singular S raises ValueError (FilterPy raises LinAlgError). ``kf.inv`` is not used.
    - ``z`` after a skipped update holds NaN (FilterPy: an object array of None).
    - batch_filter and rts_smoother take FilterPy's per-step ``Fs, Qs, Hs, Rs, Bs`` (and
      ``Fs, Qs``) but check them first: a list of another length than zs (FilterPy's zip
      silently stops at the shorter), a step of another shape, a non-finite entry or a Q/R
      that is not symmetric PSD raises ValueError naming the argument and the step
      (``Qs[3]``). A None item of rts_smoother's Fs/Qs is the filter's own (FilterPy fails
      on it). An ``inv`` other than numpy.linalg.inv raises TypeError (the smoother
      solves rather than inverts). With a ``saver``, batch_filter runs FilterPy's loop
      step by step (predict, update, saver.save()); without one, in one call into Rust.
    - Arrays read from the filter are kept until the filter changes them, so ``kf.x is
      kf.x`` and in-place edits (``kf.x[0] = 1``, ``kf.P *= 10``) reach the filter, as in
      FilterPy; arrays read before a predict/update are snapshots (``xs.append(kf.x)``).
      An array assigned to an input (x, P, F, Q, H, R, B, M) is kept as it is, of any real
      dtype (integer and float32 arrays are read converted), so its later in-place edits
      are used too, as in FilterPy.
    - copy.copy, copy.deepcopy and pickle give an independent filter with every attribute
      (FilterPy's copy.copy shares the arrays with the original). ``__dict__`` is a new
      dict of the attributes (and of log_likelihood, likelihood, mahalanobis), which is
      what FilterPy's Saver deep-copies; writing into it changes nothing.
    - Dimensions may be NumPy integer scalars or 0-d integer arrays; x and z may be 0-d
      arrays when their dimension is 1; z may also be a (1, dim_z) row, as in FilterPy.
    - Not provided: predict_steadystate, update_steadystate, get_prediction, get_update,
      residual_of, measurement_of_state, log_likelihood_of.
    """

    def __init__(self, dim_x: int, dim_z: int, dim_u: int = 0) -> None: ...
    # Read-only attributes are Final (assigning one raises AttributeError); the last-step
    # quantities change with every predict/update.
    dim_x: Final[int]
    dim_z: Final[int]
    dim_u: Final[int]
    x: Array
    P: Array
    F: Array
    Q: Array
    H: Array
    R: Array
    B: Optional[Array]
    M: Array
    alpha: float
    K: Final[Array]
    y: Final[Array]
    S: Final[Array]
    SI: Final[Array]
    z: Final[Array]
    x_prior: Final[Array]
    P_prior: Final[Array]
    x_post: Final[Array]
    P_post: Final[Array]
    log_likelihood: Final[float]
    """log N(y; 0, S) of the last update."""
    likelihood: Final[float]
    """exp(log_likelihood), at least the smallest positive normal float."""
    mahalanobis: Final[float]
    """sqrt(y^T S^-1 y) of the last update."""
    def predict(
        self, u: Optional[MatrixLike] = None, B: Optional[Array] = None,
        F: Optional[MatrixLike] = None, Q: Optional[MatrixLike] = None,
    ) -> None:
        """x <- F x + B u (when B and u are given), P <- alpha^2 F P F^T + Q."""
    def update(self, z: _Measurement, R: Optional[MatrixLike] = None, H: Optional[Array] = None) -> None:
        """y = z - H x, S = H P H^T + R, K = P H^T S^-1, x <- x + K y,
        P <- (I - K H) P (I - K H)^T + K R K^T (Joseph form). None skips; NaN rows skip."""
    def update_correlated(
        self, z: _Measurement, R: Optional[MatrixLike] = None, H: Optional[Array] = None
    ) -> None:
        """S = H P H^T + H M + M^T H^T + R, K = (P H^T + M) S^-1, x <- x + K y,
        P <- P - K (H P + M^T)."""
    def batch_filter(
        self, zs: _Series, Fs: Optional[_PerStep] = None, Qs: Optional[_PerStep] = None,
        Hs: Optional[_PerStep] = None, Rs: Optional[_PerStep] = None,
        Bs: Optional[_PerStep] = None, us: Optional[_Series] = None,
        update_first: bool = False, saver: Any = None,
    ) -> Tuple[Array, Array, Array, Array]:
        """(means, covariances, means_p, covariances_p): (N, dim_x, 1) (or (N, dim_x) for a
        1-d x), (N, dim_x, dim_x), ... in one call into Rust, as FilterPy's.

        Step k runs predict(u=us[k], B=Bs[k], F=Fs[k], Q=Qs[k]) then update(zs[k],
        R=Rs[k], H=Hs[k]) (update first with update_first); means/covariances are after
        the update, means_p/covariances_p after the prediction. Each of Fs, Qs, Hs, Rs, Bs
        is None (the filter's own at every step) or one matrix per step, len(zs) of them; a
        None item is the filter's own at that step. us (N, dim_u[, 1]) acts only where there
        is a B (the filter's or Bs[k]); a None item is no control. The filter's F, Q, H, R,
        B are not changed; x, P, K, y, S, ... are those of the last step, as in FilterPy.
        Missing measurements: None items or NaN entries of zs. Bad per-step input raises
        ValueError naming the argument and the step."""
    def update_sequential(
        self, start: int, z_i: _Measurement, R_i: Optional[MatrixLike] = None,
        H_i: Optional[Array] = None,
    ) -> None:
        """FilterPy's update with the measurement rows start, start + 1, ... only (z_i: a
        scalar or their values; R_i: None for those rows of R, a scalar s for s*I, or a
        matrix; H_i: None for those rows of H). Writes y, K, z in those rows; S and the
        likelihood stay those of the last full update, as in FilterPy."""
    def test_matrix_dimensions(
        self, z: Any = None, H: Any = None, R: Any = None, F: Any = None, Q: Any = None,
    ) -> None:
        """FilterPy's shape assertions (AssertionError) on the filter's arrays or those given."""
    def __copy__(self) -> "KalmanFilter": ...
    def __deepcopy__(self, memo: Any) -> "KalmanFilter": ...
    def __getstate__(self) -> dict[str, Any]: ...
    def __setstate__(self, state: dict[str, Any]) -> None: ...
    def rts_smoother(
        self, Xs: Array, Ps: Array, Fs: Optional[_PerStep] = None,
        Qs: Optional[_PerStep] = None,
        inv: Optional[Callable[[Array], Array]] = ...,
    ) -> Tuple[Array, Array, Array, Array]:
        """(x, P, K, Pp): smoothed means and covariances, smoother gains, predicted
        covariances, as FilterPy's. The step from k to k + 1 uses Fs[k + 1] and Qs[k + 1]
        (FilterPy's index: the matrices batch_filter predicted step k + 1 with; Fs[0] and
        Qs[0] are not used): Pp[k] = Fs[k+1] P[k] Fs[k+1]^T + Qs[k+1],
        K[k] = P[k] Fs[k+1]^T Pp[k]^-1 by a solve. Fs, Qs: None for the filter's own F, Q,
        or one matrix per step (len(Xs)). inv: only numpy.linalg.inv (or None). Each Ps[k]
        must be symmetric PSD (ValueError naming Ps[k])."""

class ExtendedKalmanFilter(KalmanFilter):
    """FilterPy's ``ExtendedKalmanFilter``: a KalmanFilter (the same attributes, predict,
    copies and pickles) whose update linearises h with the user's Jacobian. The callables
    are called as FilterPy calls them, with the filter's x and then the extra arguments; a
    value of the wrong shape raises ValueError naming the callable, and an exception they
    raise propagates."""
    def update(  # type: ignore[override]
        self, z: _Measurement, HJacobian: Callable[..., Any], Hx: Callable[..., Any],
        R: Optional[MatrixLike] = None, args: Any = (), hx_args: Any = (),
        residual: Callable[[Any, Any], Any] = np.subtract,
    ) -> None:
        """H = HJacobian(x, *args), y = residual(z, Hx(x, *hx_args)), K = P H^T S^-1,
        x <- x + K y, P <- (I - K H) P (I - K H)^T + K R K^T. z = None skips."""
    def predict_x(self, u: Optional[MatrixLike] = None) -> None:
        """x <- F x + B u (P unchanged)."""
    def predict_update(
        self, z: _Measurement, HJacobian: Callable[..., Any], Hx: Callable[..., Any],
        args: Any = (), hx_args: Any = (), u: Optional[MatrixLike] = None,
    ) -> None:
        """FilterPy's one-call step: H at the current x, the prediction, then the update
        with that H and y = z - Hx(x_pred); x_prior, P_prior hold the state before the
        prediction, as in FilterPy."""
class _SigmaPoints:
    """The attributes (n, the rule's parameters, sqrt, subtract, Wm, Wc) live in the
    instance ``__dict__``, as FilterPy's. ``sqrt`` is None for the built-in Cholesky factor
    (upper triangular, as SciPy's ``cholesky``)."""
    n: int
    Wm: Array
    Wc: Array
    sqrt: Optional[Callable[[Array], Any]]
    subtract: Callable[[Any, Any], Any]
    def num_sigmas(self) -> int: ...
    def sigma_points(self, x: Any, P: Any) -> Array:
        """The (num_sigmas, n) sigma points of mean x and covariance P (a scalar: P I)."""
    def _compute_weights(self) -> None: ...

class MerweScaledSigmaPoints(_SigmaPoints):
    """FilterPy's Van der Merwe scaled sigma points (2n + 1)."""
    alpha: float
    beta: float
    kappa: float
    def __init__(self, n: int, alpha: float, beta: float, kappa: float,
                 sqrt_method: Optional[Callable[[Array], Any]] = None,
                 subtract: Optional[Callable[[Any, Any], Any]] = None) -> None: ...

class JulierSigmaPoints(_SigmaPoints):
    """FilterPy's Julier and Uhlmann sigma points (2n + 1)."""
    kappa: float
    def __init__(self, n: int, kappa: float = 0.0,
                 sqrt_method: Optional[Callable[[Array], Any]] = None,
                 subtract: Optional[Callable[[Any, Any], Any]] = None) -> None: ...

class SimplexSigmaPoints(_SigmaPoints):
    """FilterPy's simplex sigma points (n + 1); alpha is kept and, as in FilterPy, unused."""
    alpha: float
    def __init__(self, n: int, alpha: float = 1,
                 sqrt_method: Optional[Callable[[Array], Any]] = None,
                 subtract: Optional[Callable[[Any, Any], Any]] = None) -> None: ...

class UnscentedKalmanFilter:
    """FilterPy 2.0.0's ``UnscentedKalmanFilter``; the attributes live in the instance
    ``__dict__`` (so assignment, in-place edits, copies, pickles and ``Saver`` behave as with
    FilterPy) and each method runs its arithmetic and loops in Rust. ``vectorized=True``
    calls fx(sigmas, dt, **fx_args) and hx(sigmas, **hx_args) once with all sigma points as
    the rows of a (num_sigmas, dim) array (returning (num_sigmas, dim_x) and (num_sigmas,
    dim_z), or (num_sigmas,) when dim_z = 1), and the residual functions with such rows and
    the mean. A failed or interrupted call leaves the filter as it was; an exception raised
    by a callable propagates unchanged."""
    x: Array
    P: Array
    Q: Any
    R: Any
    K: Array
    y: Array
    S: Array
    SI: Array
    z: Array
    x_prior: Array
    P_prior: Array
    x_post: Array
    P_post: Array
    sigmas_f: Array
    sigmas_h: Array
    Wm: Array
    Wc: Array
    points_fn: Any
    fx: Callable[..., Any]
    hx: Callable[..., Any]
    x_mean: Optional[Callable[[Array, Array], Any]]
    z_mean: Optional[Callable[[Array, Array], Any]]
    residual_x: Callable[[Any, Any], Any]
    residual_z: Callable[[Any, Any], Any]
    state_add: Callable[[Any, Any], Any]
    msqrt: Optional[Callable[[Array], Any]]
    vectorized: bool
    def __init__(
        self, dim_x: int, dim_z: int, dt: Any, hx: Callable[..., Any], fx: Callable[..., Any],
        points: Any, sqrt_fn: Optional[Callable[[Array], Any]] = None,
        x_mean_fn: Optional[Callable[[Array, Array], Any]] = None,
        z_mean_fn: Optional[Callable[[Array, Array], Any]] = None,
        residual_x: Optional[Callable[[Any, Any], Any]] = None,
        residual_z: Optional[Callable[[Any, Any], Any]] = None,
        state_add: Optional[Callable[[Any, Any], Any]] = None, vectorized: bool = False,
    ) -> None: ...
    @property
    def log_likelihood(self) -> float: ...
    @property
    def likelihood(self) -> float: ...
    @property
    def mahalanobis(self) -> float: ...
    def predict(self, dt: Any = None, UT: Optional[Callable[..., Any]] = None,
                fx: Optional[Callable[..., Any]] = None, **fx_args: Any) -> None:
        """Sigma points at (x, P), fx over them, their unscented transform with Q; sigmas_f
        then holds the points redrawn at the prior (FilterPy 2.0.0)."""
    def update(self, z: Any, R: Any = None, UT: Optional[Callable[..., Any]] = None,
               hx: Optional[Callable[..., Any]] = None, **hx_args: Any) -> None:
        """hx over sigmas_f, the transform with R (a scalar r: r I), K = Pxz S^-1 (solved),
        x = state_add(x, K y), P = P - K S K^T. z = None skips."""
    def compute_process_sigmas(self, dt: Any, fx: Optional[Callable[..., Any]] = None,
                               **fx_args: Any) -> None: ...
    def cross_variance(self, x: Any, z: Any, sigmas_f: Any, sigmas_h: Any) -> Array: ...
    def batch_filter(self, zs: Any, Rs: Any = None, dts: Any = None,
                     UT: Optional[Callable[..., Any]] = None,
                     saver: Any = None) -> tuple[Array, Array]:
        """(means, covariances) of predict + update per z (None: no update), in Rust."""
    def rts_smoother(self, Xs: Any, Ps: Any, Qs: Any = None, dts: Any = None,
                     UT: Optional[Callable[..., Any]] = None) -> tuple[Array, Array, Array]:
        """(xs, ps, Ks): the unscented RTS smoother; Qs[k] (default Q) is used at step k."""

class FixedLagSmoother:
    """FilterPy 2.0.0's ``FixedLagSmoother`` API; the attributes live in the instance
    ``__dict__`` as FilterPy keeps them. Each step is FilterPy's predict and Joseph-form
    update; the smoothed estimates are the Rauch-Tung-Striebel estimates over the window (the
    augmented-state fixed-lag smoother): after step k, ``xSmooth[j]`` = x[j|k] for j = k - N
    .. k, so lag 0 is the filter and a lag covering every step the full RTS smoother. These
    are not FilterPy's numbers, which depart from the smoother (its lag 0 returns the
    predictions, a lag of at least the number of steps the filter)."""
    dim_x: int
    dim_z: int
    N: Optional[int]
    x: Array
    x_s: Array
    P: Array
    F: Array
    H: Array
    Q: Array
    R: Array
    K: Array
    y: Array
    S: Array
    B: Any
    count: int
    xSmooth: list[Array]
    def __init__(self, dim_x: int, dim_z: int, N: Optional[int] = None) -> None: ...
    def smooth(self, z: Any, u: Any = None) -> None:
        """One step (x = F x + B u when u is given, then the update with z); xSmooth gains
        the step and its last N + 1 entries become x[j|k]; x_s = x[k-N|k]. NaN in z is a
        ValueError. A failed call changes nothing."""
    def smooth_batch(self, zs: Any, N: int, us: Any = None) -> tuple[Array, Array]:
        """(xhat_smooth, xhat): x[k|min(k+N, last)] and the filter's x[k|k], from the
        attributes (left unchanged), in Rust without the GIL."""

class IMMEstimator:
    """FilterPy 2.0.0's ``IMMEstimator`` over a bank of at least two filters with FilterPy's
    interface (this module's, FilterPy's, or any object with ``x``, ``P``, ``predict(u)``,
    ``update(z)`` and ``likelihood``); the attributes live in the instance ``__dict__`` as
    FilterPy keeps them. The mixing and moment matching run in Rust (two passes about the
    mean); mu is formed from the filters' ``log_likelihood`` where they have one. ``M`` must
    be a transition matrix (rows summing to one) and ``mu`` non-negative with a positive
    sum. A failed call (a filter's error, Ctrl-C, no positive likelihood) leaves the
    estimator and every filter as they were."""
    filters: Any
    N: int
    M: Any
    mu: Array
    cbar: Array
    omega: Array
    likelihood: Array
    x: Array
    P: Array
    x_prior: Array
    P_prior: Array
    x_post: Array
    P_post: Array
    def __init__(self, filters: Any, mu: Any, M: Any) -> None: ...
    def update(self, z: Any) -> None:
        """Every filter updates with z; mu, cbar, omega, likelihood and the combined x, P,
        x_post, P_post follow."""
    def predict(self, u: Any = None) -> None:
        """Each filter j starts from the mixture of the bank with weights omega[:, j] and
        predicts with predict(u); the combined x, P, x_prior, P_prior follow."""

FilterResult = dict[str, Array]
# filter/smooth and their continuous forms: the arrays below, plus, when a gate is given,
# "rejected": a dict of 1-d arrays "step" and "channel" (int64: the row of zs and the
# 0-based entry), "value" (the rejected measurement) and "nis" (the statistic that rejected
# it), one element per rejected entry, in step then channel order (empty if none).
SeriesResult = dict[str, Any]
_Probability = Optional[float]

def filter(
    F: Array, H: Array, Q: Array, R: Array, x0: Array, P0: Array, zs: _Series,
    us: Optional[_Series] = None, B: Optional[Array] = None, S: Optional[Array] = None,
    form: str = "joseph", gate: _Probability = None, gate_rule: str = "entries",
) -> SeriesResult:
    """The engine's filter over a whole series in one call.

    (x0, P0) is the prior of the first measurement; step k updates with zs[k] (NaN entries
    skipped) and predicts to k + 1 with us[k]; S = E[w_k v_k^T] enters the prediction.
    form: "joseph", "standard" or "sqrt". Returns "x", "P" (x_{k|k}: (N, n), (N, n, n)),
    "x_pred", "P_pred" (x_{k+1|k}), "log_likelihood" (N,) (0 with no measurement) and
    "nis" (N,) (NaN with no measurement).

    gate: None, or a probability in (0, 1) (e.g. 0.9999) of a wild-point gate. Before the
    update of step k, the present entries of zs[k] are screened against the prior
    x_{k|k-1}, P_{k|k-1}: with gate_rule "entries" each entry i whose e_i^2 / Sigma_ii
    (e = z - H x_{k|k-1}, Sigma = H P_{k|k-1} H^T + R) exceeds the chi2(1) quantile of
    gate is rejected; with "vector" every present entry of a step whose e^T Sigma^+ e
    exceeds the chi2(rank Sigma) quantile is. Rejected entries are skipped like NaN ones
    (a step with every entry rejected has nis NaN) and listed in "rejected".
    """

def smooth(
    F: Array, H: Array, Q: Array, R: Array, x0: Array, P0: Array, zs: _Series,
    us: Optional[_Series] = None, B: Optional[Array] = None, S: Optional[Array] = None,
    form: str = "joseph", gate: _Probability = None, gate_rule: str = "entries",
) -> SeriesResult:
    """Rauch-Tung-Striebel smoothing of the engine's filter: "x" (N, n), "P" (N, n, n).
    The forward pass is ``filter``'s (form, gate); with a gate also "rejected". With
    form="sqrt" the backward pass runs in square-root form too (each P formed from its
    triangular factor: symmetric positive semidefinite by construction)."""

def particle_filter(
    zs: Any, initial: Any, transition: Any, log_likelihood: Any, particles: int = 1000,
    resampling: str = "systematic", ess_threshold: float = 0.5, seed: int = 0,
) -> dict[str, Any]:
    """The bootstrap particle filter (``kalman::particle``) over callables vectorised over
    the particles: initial(N, rng) -> (N, n) draws of the prior of the first measurement;
    transition(X, k, rng) -> (N, n) successors of the particles X of step k;
    log_likelihood(X, z, k) -> (N,) values of ln g_k(z | x) (-inf: impossible). rng is a
    numpy.random.Generator seeded from the filter's stream, so a seed repeats a run.
    Resamples ("systematic", "stratified", "residual", "multinomial") when the effective
    sample size falls below ess_threshold * N (1: every step). Returns "x" (steps, n), "P"
    (steps, n, n), "ess", "resampled", "log_likelihood" (the log of an unbiased likelihood
    estimate), "particles" (N, n) and "log_weights" (N,) of the last step. A callable's
    exception propagates unchanged; a NaN or wrongly shaped value is a ValueError."""

def filter_batch(
    F: Array, H: Array, Q: Array, R: Array, x0: Array, P0: Array, zs: Array,
    form: str = "joseph", covariances: bool = False,
) -> FilterResult:
    """Many independent series of one model in one call (``kalman::batch``: eight series
    per vector register, groups on threads, the GIL released). zs is (series, steps, m), or
    (series, steps) for m = 1, NaN for a missing entry; each series is filtered as
    ``filter`` filters one, from the prior (x0, P0) of its first measurement, equal to it to
    round-off. Returns "x" (series, steps, n), "P_last" (series, n, n), "log_likelihood"
    (series,) and with covariances=True "P" (series, steps, n, n). No control input, no S;
    form "joseph" or "standard". An error names the series it arose in."""

def filter_continuous(
    A: Array, C: Array, W: Array, R: Array, x0: Array, P0: Array, t: _Series, zs: _Series,
    us: Optional[_Series] = None, B: Optional[Array] = None, form: str = "joseph",
    gate: _Probability = None, gate_rule: str = "entries",
) -> SeriesResult:
    """The engine's filter of a continuous model at a record's own time stamps.

    Model: dx/dt = A x + B u + w with W (n, n) the intensity of w as it enters the state
    (G Qc G^T for a noise input G of intensity Qc), measured at the stamps t (N,), finite
    and non-decreasing: z(t[k]) = C x(t[k]) + v[k], cov(v[k]) = R (m, m), zs (N, m) with
    NaN for a missing entry. Each interval is sampled exactly: F = e^{A dt}, the input by
    zero-order hold (u held over the interval), Q_d = int_0^dt e^{A s} W e^{A^T s} ds (Van
    Loan); dt = 0 is F = I, Q_d = 0.

    The time rule: (x0, P0) is the prior of the first row's measurement; step k updates
    with zs[k] and predicts with us[k] over t[k+1] - t[k] (the last row over 0, so its
    "x_pred", "P_pred" are its "x", "P"). Rows with equal stamps are one instant, processed
    in order. Returns ``filter``'s dict (and "rejected" with a gate; form, gate,
    gate_rule as in ``filter``).

    Raises ValueError naming the argument: a non-finite t[k], a t[k] before t[k-1], an
    interval t[k+1] - t[k] over which the model overflows f64, a gate outside (0, 1), and
    shapes that do not fit (A (n, n), C (m, n), W (n, n), R (m, m), B (n, p), x0 (n,),
    P0 (n, n), t (N,), zs (N, m), us (N, p)).
    """

def smooth_continuous(
    A: Array, C: Array, W: Array, R: Array, x0: Array, P0: Array, t: _Series, zs: _Series,
    us: Optional[_Series] = None, B: Optional[Array] = None, form: str = "joseph",
    gate: _Probability = None, gate_rule: str = "entries",
) -> SeriesResult:
    """Rauch-Tung-Striebel smoothing over ``filter_continuous``'s (gated) pass, each step
    recorded with the model sampled for its interval: "x" (N, n), "P" (N, n, n), and with
    a gate "rejected". Rows at one instant get the same smoothed estimate."""

def dare(F: Array, H: Array, Q: Array, R: Array, S: Optional[Array] = None) -> FilterResult:
    """The filter's discrete algebraic Riccati equation: "P" (prior), "P_post", "K",
    "K_pred", "innovation_cov"."""

def dlqr(A: Array, B: Array, Q: Array, R: Array, N: Optional[Array] = None) -> FilterResult:
    """Discrete LQR: "K" (u = -K x) and the cost matrix "P"."""

def care(A: Array, H: Array, Q: Array, R: Array) -> FilterResult:
    """The Kalman-Bucy filter's continuous algebraic Riccati equation: "P" and "K"."""

def c2d(
    A: Array, B: Array, C: Array, D: Array, dt: float, method: str = "zoh",
    G: Optional[Array] = None, W: Optional[Array] = None, noise: str = "van_loan",
    omega: Optional[float] = None,
) -> FilterResult:
    """Discretise dx = (A x + B u) dt + G dbeta (cov dbeta = W dt), y = C x + D u.

    method: "zoh", "tustin", "tustin_prewarp" (needs omega, rad/s), "forward_euler",
    "backward_euler". Returns "F", "B", "H", "D", and with G and W: "G", "J", "Q"
    (noise "van_loan": Q = int_0^dt e^{A t} G W G^T e^{A^T t} dt, G_d = I; or
    "intensity_over_dt": Q = W / dt through the mapped G).
    """

def fuel_model(
    channels: str = "level_and_tilt", realisation: str = "paper", dt: Optional[float] = None
) -> dict[str, Any]:
    """The paper's 7-state fuel-level model (default parameters): "F", "B" (noise input),
    "H", "D", "Q" (noise covariance), "R", "S" (E[w_k v_k^T]), "Qw" (B Q B^T),
    "known_input", "dt". channels: "level_and_tilt" or "level_only"; realisation: "paper",
    "exact_tustin" or "zoh"."""

def wls(
    H: Array, z: Array, weights: Optional[Array] = None, method: str = "qr",
    scale_covariance: bool = False, rank_tolerance: Optional[float] = None,
    tikhonov: Optional[float] = None, prior_mean: Optional[Array] = None,
    operator: Optional[Array] = None,
) -> dict[str, Any]:
    """Weighted least squares min ||V^(1/2) (H x - z)||^2 (+ lambda ||L (x - x_p)||^2) by QR
    of the whitened problem ("normal_equations" for comparison). weights V: None, a 1-d
    array (diagonal) or a 2-d SPD matrix. Returns "x", "covariance", "residuals",
    "weighted_sum_of_squares", "residual_variance", "singular_values",
    "condition_weighted", "condition_normal", "condition_solved", "rank", "rank_tolerance".
    A rank-deficient problem without tikhonov is a ValueError."""

def ekf(
    f: Any, h: Any, Q: Array, R: Array, x0: Array, P0: Array, zs: _Series,
    us: Optional[_Series] = None, iterations: int = 0, tolerance: float = 1e-9,
    manifold: Optional[Sequence[Union[str, int]]] = None,
) -> FilterResult:
    """Extended Kalman filter over callables f(x, u, k) -> (n,) and h(x, k) -> (m,), with
    Jacobians by central differences; iterations > 0 for the iterated EKF. Returns the same
    keys as ``filter``. An exception raised by f or h propagates unchanged.

    ``manifold`` puts the state on a product of unit quaternions ``"quaternion"`` (w, x, y,
    z; 4 stored, 3 tangent), wrapped angles ``"angle"`` and vectors of length k (an int),
    e.g. ``["quaternion", 3]`` for an attitude and a gyro bias: x0, f's argument and value
    and the returned "x" are stored points (7 numbers), Q, P0 and the returned "P" live in
    the tangent space (6×6), and every quaternion estimate has unit norm."""

def ukf(
    f: Any, h: Any, Q: Array, R: Array, x0: Array, P0: Array, zs: _Series,
    us: Optional[_Series] = None, points: str = "merwe", alpha: float = 1e-3,
    beta: float = 2.0, kappa: float = 0.0, form: str = "plain",
    manifold: Optional[Sequence[Union[str, int]]] = None,
) -> FilterResult:
    """Unscented Kalman filter (Merwe's scaled sigma points or "cubature") over callables
    f(x, u, k) and h(x, k); form="sqrt" runs the square-root UKF (Cholesky factors carried
    instead of covariances). ``manifold`` as in ``ekf`` (sigma points drawn in the tangent
    space). Returns the same keys as ``filter``."""

def fit(
    F: Array, H: Array, Q: Array, R: Array, x0: Array, P0: Array, zs: _Series,
    method: Optional[str] = None, q: str = "diag", r: str = "diag", free_x0: bool = False,
    free_p0_diag: bool = False, max_iter: Optional[int] = None,
    free: Optional[Sequence[str]] = None, dt: Optional[float] = None,
) -> dict[str, Any]:
    """Learn Q and R (optionally x0 and a diagonal P0), or the items named in free as the
    command line's --free names them ("Q:scalar|diag|full", "R:...", "x0", "P0:diag",
    entries "F[i,j]", "B[i,j]", "H[i,j]", "Q[i,j]", "R[i,j]", "P0[i,j]", "x0[i]",
    "Q:white-acceleration" with dt), from data by "em" (Shumway-Stoffer; the default
    without free) or "mle" (L-BFGS with the exact score; the default with free). q, r:
    "fixed", "scalar", "diag" or "full" (left at the default with free). Every entry not
    freed stays at its given value; the given matrices are the starting point. Returns the
    fitted "F", "H", "Q", "R", "x0", "P0" and "loglik", "iterations", "converged",
    "message", "boundary", "theta", "std_errors" (by name with free), "estimates",
    "correlation", "aic", "bic"."""


def fit_callable(
    model: Callable[[Array], dict[str, Any]], theta0: Sequence[float], zs: _Series,
    F: Optional[Array] = None, H: Optional[Array] = None, Q: Optional[Array] = None,
    R: Optional[Array] = None, x0: Optional[Array] = None, P0: Optional[Array] = None,
    max_iter: Optional[int] = None, log_variances: Optional[Sequence[int]] = None,
) -> dict[str, Any]:
    """Fit theta of model(theta) -> dict with some of "F", "H", "Q", "R", "x0", "P0" (the
    others fixed at the keyword arguments; x0 defaults to zeros) by maximum likelihood from
    theta0, the gradient by central differences. Returns fit's dict, the parameters named
    "θ[i]". An exception in model or a wrong shape is a ValueError/TypeError naming it."""
