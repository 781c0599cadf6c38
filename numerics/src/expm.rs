//! The workspace's one matrix exponential: scaling and squaring with a Padé approximant of the
//! degree the matrix's 1-norm needs (Higham, "The scaling and squaring method for the matrix
//! exponential revisited", SIAM J. Matrix Anal. Appl. 26, 2005: degrees 3, 5, 7, 9 and 13,
//! each used up to its θ_m, where the approximant's backward error is below the unit
//! round-off of f64), on column-major slices in a workspace sized once, so a call allocates
//! nothing. The Padé quotient is an LU solve with partial pivoting, not an inverse.
//! `kalman::continuous::expm` and `model::expm` are its faces in their matrix types;
//! [`van_loan`] samples a continuous model with it.

use crate::Real;

/// Higham's θ_m for m = 3, 5, 7, 9, 13 (double precision).
const THETA: [f64; 5] = [
    1.495_585_217_958_292e-2,
    2.539_398_330_063_23e-1,
    9.504_178_996_162_932e-1,
    2.097_847_961_257_068,
    5.371_920_351_148_152,
];

/// Padé coefficients b_0…b_m of degrees 3, 5, 7 and 9.
const B3: [f64; 4] = [120.0, 60.0, 12.0, 1.0];
const B5: [f64; 6] = [30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0];
const B7: [f64; 8] = [
    17_297_280.0,
    8_648_640.0,
    1_995_840.0,
    277_200.0,
    25_200.0,
    1_512.0,
    56.0,
    1.0,
];
const B9: [f64; 10] = [
    17_643_225_600.0,
    8_821_612_800.0,
    2_075_673_600.0,
    302_702_400.0,
    30_270_240.0,
    2_162_160.0,
    110_880.0,
    3_960.0,
    90.0,
    1.0,
];
/// Padé coefficients of degree 13.
const B13: [f64; 14] = [
    64_764_752_532_480_000.0,
    32_382_376_266_240_000.0,
    7_771_770_303_897_600.0,
    1_187_353_796_428_800.0,
    129_060_195_264_000.0,
    10_559_470_521_600.0,
    670_442_572_800.0,
    33_522_128_640.0,
    1_323_241_920.0,
    40_840_800.0,
    960_960.0,
    16_380.0,
    182.0,
    1.0,
];

/// The workspace of [`Expm::run`] for matrices up to `cap`×`cap`, allocated once; the
/// input goes in [`Expm::input`].
///
/// # Example
/// ```
/// use numerics::Expm;
///
/// // e^{diag(1, −2)} = diag(e, e^{−2}).
/// let mut work = Expm::new(2);
/// work.input(2).copy_from_slice(&[1.0, 0.0, 0.0, -2.0]);
/// let mut e = [0.0; 4];
/// assert!(work.run(2, &mut e));
/// assert!((e[0] - 1f64.exp()).abs() < 1e-15 && (e[3] - (-2f64).exp()).abs() < 1e-16);
/// ```
#[derive(Debug, Clone)]
pub struct Expm {
    cap: usize,
    b: Bufs<f64>,
    arch: pulp::Arch,
}

/// The Padé evaluation's matrices, over the scalar `T`.
#[derive(Debug, Clone)]
struct Bufs<T> {
    a: Vec<T>,
    a2: Vec<T>,
    a4: Vec<T>,
    a6: Vec<T>,
    u: Vec<T>,
    v: Vec<T>,
    t: Vec<T>,
    piv: Vec<usize>,
}

impl<T: Real> Bufs<T> {
    fn new(cap: usize) -> Self {
        let z = vec![T::constant(0.0); cap * cap];
        Bufs {
            a: z.clone(),
            a2: z.clone(),
            a4: z.clone(),
            a6: z.clone(),
            u: z.clone(),
            v: z.clone(),
            t: z,
            piv: vec![0; cap],
        }
    }
}

impl Expm {
    /// A workspace for matrices up to `cap`×`cap`.
    pub fn new(cap: usize) -> Self {
        Expm {
            cap,
            b: Bufs::new(cap),
            arch: pulp::Arch::new(),
        }
    }

    /// The k×k input (column-major, `k ≤ cap`), to be filled before [`Expm::run`].
    ///
    /// # Panics
    /// If `k` exceeds the workspace's `cap`.
    pub fn input(&mut self, k: usize) -> &mut [f64] {
        debug_assert!(k <= self.cap);
        &mut self.b.a[..k * k]
    }

    /// `out` (k×k, column-major) ← e^A of the k×k input. Returns `false` if the result is
    /// not finite (an exponential that overflows f64) or the Padé denominator is singular
    /// (only for a non-finite input).
    ///
    /// # Panics
    /// If `k` exceeds the workspace's `cap` or `out` holds fewer than k² entries.
    pub fn run(&mut self, k: usize, out: &mut [f64]) -> bool {
        self.run_block(k, k, out)
    }

    /// [`Expm::run`] for an input that is block upper triangular, zero in its rows from `blk`
    /// on and columns before `blk` (Van Loan's and the zero-order hold's block matrices): every
    /// product, the LU factors and the result keep that zero block, so the products skip it
    /// (half the work at `blk = k/2`). `blk = k` (or more) is a full matrix.
    ///
    /// # Panics
    /// As [`Expm::run`].
    pub fn run_block(&mut self, k: usize, blk: usize, out: &mut [f64]) -> bool {
        assert!(
            k <= self.cap && out.len() >= k * k,
            "Expm::run_block: k > cap or out too short"
        );
        let blk = blk.min(k);
        // The sizes of the Van Loan blocks of models up to n = 8 (k = 2n, blk = n) and of
        // small full matrices are compile-time constants, so the kernels' loops unroll; each
        // runs with the widest vector instructions the processor has (mul and add stay
        // separate, so every instruction set gives the same bits).
        let arch = self.arch;
        macro_rules! sized {
            ($($k:literal, $b:literal);*) => {
                match (k, blk) {
                    $(($k, $b) => arch.dispatch(
                        #[inline(always)]
                        || pade::<f64, true>(&mut self.b, $k, $b, out),
                    ),)*
                    _ => arch.dispatch(
                        #[inline(always)]
                        || pade::<f64, true>(&mut self.b, k, blk, out),
                    ),
                }
            };
        }
        sized!(2, 1; 4, 2; 6, 3; 8, 4; 10, 5; 12, 6; 14, 7; 16, 8; 2, 2; 3, 3; 4, 4)
    }
}

/// The scaling-and-squaring Padé evaluation of `e^A` for the k×k input in `bufs.a` (see
/// [`Expm::run_block`]), over the scalar `T`: `f64`, or a dual number carrying derivatives
/// through the same rational function. `SKIP` skips the products' exact zeros (valid for
/// `f64` only: a dual number with a zero value may carry a derivative). Inlined into each of
/// its size-specialised callers.
#[inline(always)]
fn pade<T: Real, const SKIP: bool>(
    bufs: &mut Bufs<T>,
    k: usize,
    blk: usize,
    out: &mut [T],
) -> bool {
    let kk = k * k;
    let norm1 = (0..k)
        .map(|j| {
            bufs.a[j * k..(j + 1) * k]
                .iter()
                .map(|x| x.value().abs())
                .sum::<f64>()
        })
        .fold(0.0_f64, f64::max);
    if !norm1.is_finite() {
        return false;
    }
    let degree = THETA.iter().position(|&t| norm1 <= t).unwrap_or(4);
    let s = if degree == 4 && norm1 > THETA[4] {
        (norm1 / THETA[4]).log2().ceil() as i32
    } else {
        0
    };
    if s > 0 {
        let f = 0.5_f64.powi(s);
        bufs.a[..kk].iter_mut().for_each(|x| *x = *x * f);
    }
    let (a, a2, a4, a6) = (
        &bufs.a[..kk],
        &mut bufs.a2[..kk],
        &mut bufs.a4[..kk],
        &mut bufs.a6[..kk],
    );
    let (u, v, t) = (&mut bufs.u[..kk], &mut bufs.v[..kk], &mut bufs.t[..kk]);
    mm::<T, SKIP>(blk, a2, a, a, k);
    match degree {
        0 => {
            // U = A (b3 A2 + b1 I), V = b2 A2 + b0 I.
            combine(t, &[(B3[3], &*a2)], B3[1], k);
            mm::<T, SKIP>(blk, u, a, t, k);
            combine(v, &[(B3[2], &*a2)], B3[0], k);
        }
        1 => {
            mm::<T, SKIP>(blk, a4, a2, a2, k);
            combine(t, &[(B5[5], &*a4), (B5[3], &*a2)], B5[1], k);
            mm::<T, SKIP>(blk, u, a, t, k);
            combine(v, &[(B5[4], &*a4), (B5[2], &*a2)], B5[0], k);
        }
        2 => {
            mm::<T, SKIP>(blk, a4, a2, a2, k);
            mm::<T, SKIP>(blk, a6, a4, a2, k);
            combine(t, &[(B7[7], &*a6), (B7[5], &*a4), (B7[3], &*a2)], B7[1], k);
            mm::<T, SKIP>(blk, u, a, t, k);
            combine(v, &[(B7[6], &*a6), (B7[4], &*a4), (B7[2], &*a2)], B7[0], k);
        }
        3 => {
            mm::<T, SKIP>(blk, a4, a2, a2, k);
            mm::<T, SKIP>(blk, a6, a4, a2, k);
            // A8 = A4 A4 goes in v until V is formed.
            mm::<T, SKIP>(blk, v, a4, a4, k);
            combine(
                t,
                &[(B9[9], &*v), (B9[7], &*a6), (B9[5], &*a4), (B9[3], &*a2)],
                B9[1],
                k,
            );
            mm::<T, SKIP>(blk, u, a, t, k);
            // V = b8 A8 + b6 A6 + b4 A4 + b2 A2 + b0 I, in place over A8.
            for i in 0..kk {
                v[i] = v[i] * B9[8] + a6[i] * B9[6] + a4[i] * B9[4] + a2[i] * B9[2];
            }
            add_identity(v, B9[0], k);
        }
        _ => {
            mm::<T, SKIP>(blk, a4, a2, a2, k);
            mm::<T, SKIP>(blk, a6, a4, a2, k);
            // U = A [A6 (b13 A6 + b11 A4 + b9 A2) + b7 A6 + b5 A4 + b3 A2 + b1 I].
            combine(
                t,
                &[(B13[13], &*a6), (B13[11], &*a4), (B13[9], &*a2)],
                0.0,
                k,
            );
            mm::<T, SKIP>(blk, v, a6, t, k);
            for i in 0..kk {
                t[i] = v[i] + a6[i] * B13[7] + a4[i] * B13[5] + a2[i] * B13[3];
            }
            add_identity(t, B13[1], k);
            mm::<T, SKIP>(blk, u, a, t, k);
            // V = A6 (b12 A6 + b10 A4 + b8 A2) + b6 A6 + b4 A4 + b2 A2 + b0 I.
            combine(
                t,
                &[(B13[12], &*a6), (B13[10], &*a4), (B13[8], &*a2)],
                0.0,
                k,
            );
            mm::<T, SKIP>(blk, v, a6, t, k);
            for i in 0..kk {
                v[i] += a6[i] * B13[6] + a4[i] * B13[4] + a2[i] * B13[2];
            }
            add_identity(v, B13[0], k);
        }
    }
    // (V − U) X = (V + U): the denominator in v, the numerator in out.
    for i in 0..kk {
        out[i] = v[i] + u[i];
        v[i] -= u[i];
    }
    if !lu_solve::<T, SKIP>(v, &mut bufs.piv[..k], out, k, blk) {
        return false;
    }
    for _ in 0..s {
        t.copy_from_slice(&out[..kk]);
        mm::<T, SKIP>(blk, out, t, t, k);
    }
    out[..kk].iter().all(|x| x.value().is_finite())
}

/// `c ← a b` (k×k, column-major), both zero in rows `blk..` of columns `..blk`; `SKIP`
/// skips a zero entry of `b` (see [`pade`]).
#[inline(always)]
fn mm<T: Real, const SKIP: bool>(blk: usize, c: &mut [T], a: &[T], b: &[T], k: usize) {
    c[..k * k].iter_mut().for_each(|x| *x = T::constant(0.0));
    for j in 0..k {
        // b's column j is zero below `blk` when j < blk; a's column l is zero below `blk`
        // when l < blk.
        let lmax = if j < blk { blk } else { k };
        for l in 0..lmax {
            let blj = b[l + j * k];
            if SKIP && blj.value() == 0.0 {
                continue;
            }
            let imax = if l < blk { blk } else { k };
            let (col, acol) = (&mut c[j * k..j * k + imax], &a[l * k..l * k + imax]);
            for i in 0..imax {
                col[i] += acol[i] * blj;
            }
        }
    }
}

/// `c ← Σ w_i M_i + d I`.
#[inline(always)]
fn combine<T: Real>(c: &mut [T], terms: &[(f64, &[T])], d: f64, k: usize) {
    for i in 0..k * k {
        let mut acc = T::constant(0.0);
        for (w, m) in terms {
            acc += m[i] * *w;
        }
        c[i] = acc;
    }
    add_identity(c, d, k);
}

#[inline(always)]
fn add_identity<T: Real>(c: &mut [T], d: f64, k: usize) {
    for i in 0..k {
        c[i + i * k] += T::constant(d);
    }
}

/// Solves `a x = b` in place (a k×k destroyed by its LU factors with partial pivoting on the
/// values, b k×k overwritten by x). `false` for a zero pivot.
#[inline(always)]
fn lu_solve<T: Real, const SKIP: bool>(
    a: &mut [T],
    piv: &mut [usize],
    b: &mut [T],
    k: usize,
    blk: usize,
) -> bool {
    // Below `blk`, the columns before `blk` are zero: the pivot search and the elimination of
    // such a column stop at `blk`, and L keeps the zero block.
    let rows = |c: usize| if c < blk { blk } else { k };
    for c in 0..k {
        let p = (c..rows(c))
            .max_by(|&i, &j| {
                a[i + c * k]
                    .value()
                    .abs()
                    .total_cmp(&a[j + c * k].value().abs())
            })
            .unwrap_or(c);
        piv[c] = p;
        let pv = a[p + c * k].value();
        if pv == 0.0 || !pv.is_finite() {
            return false;
        }
        if p != c {
            for j in 0..k {
                a.swap(c + j * k, p + j * k);
            }
        }
        let d = a[c + c * k];
        for i in c + 1..rows(c) {
            a[i + c * k] = a[i + c * k] / d;
        }
        for j in c + 1..k {
            let acj = a[c + j * k];
            if SKIP && acj.value() == 0.0 {
                continue;
            }
            for i in c + 1..rows(c) {
                let l = a[i + c * k];
                a[i + j * k] -= l * acj;
            }
        }
    }
    for j in 0..k {
        let x = &mut b[j * k..(j + 1) * k];
        for c in 0..k {
            x.swap(c, piv[c]);
        }
        for c in 0..k {
            let xc = x[c];
            for i in c + 1..rows(c) {
                x[i] -= a[i + c * k] * xc;
            }
        }
        for c in (0..k).rev() {
            x[c] = x[c] / a[c + c * k];
            let xc = x[c];
            for i in 0..c {
                x[i] -= a[i + c * k] * xc;
            }
        }
    }
    true
}

/// `e^A` of the k×k `a` (column-major) over the scalar `T` (a dual number gives the
/// derivative of the exponential along the input's derivative, through the same Padé
/// approximant and squarings as `f64`), block upper triangular from `blk` as
/// [`Expm::run_block`]; `None` where the result is not finite. Allocates its workspace: for
/// fitting, not for the filter's step.
#[cfg(feature = "autodiff")]
pub fn expm_of<T: Real>(a: &[T], k: usize, blk: usize) -> Option<Vec<T>> {
    let mut bufs = Bufs::<T>::new(k);
    bufs.a[..k * k].copy_from_slice(&a[..k * k]);
    let mut out = vec![T::constant(0.0); k * k];
    pade::<T, false>(&mut bufs, k, blk, &mut out).then_some(out)
}

/// Van Loan's sampling of ẋ = A x + w (w white, of intensity `q`, n×n, as it enters the
/// state) over `dt`: `f` ← F = e^{A·dt} and `qd` ← Q_d = ∫₀^dt e^{Aτ} Q e^{Aᵀτ} dτ
/// (symmetrised), both n×n column-major, from one exponential of the block matrix
/// `[[−A, Q], [0, Aᵀ]]·dt` (Van Loan, "Computing integrals involving the matrix
/// exponential", IEEE Trans. Autom. Control 23, 1978): F = E₂₂ᵀ, Q_d = F·E₁₂. A zero `q`
/// gives Q_d = 0 exactly from the n×n exponential of A·dt alone. Returns `false` (the
/// outputs unspecified) when the exponential is not finite. Allocates its workspace; a
/// caller sampling many intervals keeps an [`Expm`] instead.
///
/// # Panics
/// If `a`, `q`, `f` or `qd` holds fewer than n² entries.
///
/// # Example
/// ```
/// // White acceleration of intensity 0.5 on a double integrator over 0.2 s:
/// // Q_d = q·[[Δt³/3, Δt²/2], [Δt²/2, Δt]].
/// let (q, dt) = (0.5, 0.2);
/// let a = [0.0, 0.0, 1.0, 0.0]; // [[0, 1], [0, 0]]
/// let w = [0.0, 0.0, 0.0, q];
/// let (mut f, mut qd) = ([0.0; 4], [0.0; 4]);
/// assert!(numerics::van_loan(&a, &w, 2, dt, &mut f, &mut qd));
/// let exact = [q * dt.powi(3) / 3.0, q * dt * dt / 2.0, q * dt * dt / 2.0, q * dt];
/// assert!(qd.iter().zip(exact).all(|(x, e)| (x - e).abs() < 1e-15));
/// assert!((f[2] - dt).abs() < 1e-15);
/// ```
pub fn van_loan(a: &[f64], q: &[f64], n: usize, dt: f64, f: &mut [f64], qd: &mut [f64]) -> bool {
    let nn = n * n;
    if n == 0 {
        return true;
    }
    if !q[..nn].iter().any(|v| v.abs() > 0.0) {
        let mut work = Expm::new(n);
        for (m, &v) in work.input(n).iter_mut().zip(&a[..nn]) {
            *m = v * dt;
        }
        qd[..nn].fill(0.0);
        return work.run(n, &mut f[..nn]);
    }
    let k = 2 * n;
    let mut work = Expm::new(k);
    let m = work.input(k);
    m.fill(0.0);
    for j in 0..n {
        for i in 0..n {
            m[i + j * k] = -a[i + j * n] * dt;
            m[i + (n + j) * k] = q[i + j * n] * dt;
            m[n + i + (n + j) * k] = a[j + i * n] * dt;
        }
    }
    let mut e = vec![0.0; k * k];
    if !work.run_block(k, n, &mut e) {
        return false;
    }
    for j in 0..n {
        for i in 0..n {
            f[i + j * n] = e[n + j + (n + i) * k];
        }
    }
    for j in 0..n {
        for i in 0..n {
            let mut s = 0.0;
            for l in 0..n {
                s += f[i + l * n] * e[l + (n + j) * k];
            }
            qd[i + j * n] = s;
        }
    }
    crate::symmetrise(&mut qd[..nn], n);
    qd[..nn].iter().all(|v| v.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exp_of(a: &[f64], k: usize) -> Vec<f64> {
        let mut e = Expm::new(k);
        e.input(k).copy_from_slice(a);
        let mut out = vec![0.0; k * k];
        assert!(e.run(k, &mut out));
        out
    }

    /// A rotation generator at every degree's range: e^{[[0, w], [−w, 0]]} = [[cos w, sin w],
    /// [−sin w, cos w]], from ‖A‖₁ = w just below θ₃ to 40 (three halvings at degree 13).
    /// Tolerance 1e-13: each degree's backward error is below the unit round-off, and the
    /// squarings add a few ulps each.
    #[test]
    fn each_degree_reproduces_a_rotation() {
        for w in [0.01_f64, 0.2, 0.9, 2.0, 5.0, 10.0, 40.0] {
            let e = exp_of(&[0.0, -w, w, 0.0], 2);
            let want = [w.cos(), -w.sin(), w.sin(), w.cos()];
            for i in 0..4 {
                assert!((e[i] - want[i]).abs() < 1e-13, "w {w}: {e:?}");
            }
        }
    }

    /// A diagonal matrix exponentiates entry by entry; a nilpotent one is a finite series.
    #[test]
    fn diagonal_and_nilpotent_closed_forms() {
        let d = [-3.0, 0.5, 1e-4];
        let mut a = vec![0.0; 9];
        for i in 0..3 {
            a[i + 3 * i] = d[i];
        }
        let e = exp_of(&a, 3);
        for i in 0..3 {
            assert!((e[i + 3 * i] - d[i].exp()).abs() < 1e-14 * d[i].exp().max(1.0));
        }
        // N = [[0, 1, 0], [0, 0, 1], [0, 0, 0]] · c: e^N = I + N + N²/2.
        let c = 3.0;
        let n = [0.0, 0.0, 0.0, c, 0.0, 0.0, 0.0, c, 0.0];
        let e = exp_of(&n, 3);
        assert!((e[3] - c).abs() < 1e-13 && (e[6] - c * c / 2.0).abs() < 1e-12);
        assert!((e[0] - 1.0).abs() < 1e-14 && e[1].abs() < 1e-14);
    }

    #[test]
    fn an_overflowing_exponential_is_reported() {
        let mut e = Expm::new(1);
        e.input(1)[0] = 1000.0;
        let mut out = [0.0];
        assert!(!e.run(1, &mut out));
        e.input(1)[0] = f64::NAN;
        assert!(!e.run(1, &mut out));
    }

    /// A block upper triangular input through the block path equals the full path (to
    /// round-off: the skipped products are exact zeros, so the two agree to the last bits of
    /// the summation order), at a norm that needs degree 13 and one at degree 5.
    #[test]
    fn the_block_path_equals_the_full_path() {
        for scale in [0.05, 3.0] {
            let k = 5;
            let blk = 3;
            let mut a = vec![0.0; k * k];
            for j in 0..k {
                for i in 0..k {
                    if !(i >= blk && j < blk) {
                        a[i + j * k] = scale * (((i * 7 + j * 3) % 5) as f64 - 2.0) / 3.0;
                    }
                }
            }
            let full = exp_of(&a, k);
            let mut e = Expm::new(k);
            e.input(k).copy_from_slice(&a);
            let mut out = vec![0.0; k * k];
            assert!(e.run_block(k, blk, &mut out));
            let big = full.iter().fold(0.0_f64, |s, x| s.max(x.abs()));
            for i in 0..k * k {
                assert!(
                    (out[i] - full[i]).abs() <= 1e-14 * big,
                    "scale {scale} entry {i}"
                );
            }
            for j in 0..blk {
                for i in blk..k {
                    assert!(out[i + j * k].abs() < f64::MIN_POSITIVE);
                }
            }
        }
    }

    /// A first-order lag ẋ = −λx + w: F = e^{−λΔt}, Q_d = q(1 − e^{−2λΔt})/(2λ) (the closed
    /// form of the integral); and with q = 0 the shortcut path gives F alone, Q_d = 0
    /// exactly. Tolerance 1e-15 relative: a few ulps of one exponential and one product.
    #[test]
    fn van_loan_reproduces_the_first_order_lag() {
        let (lam, q, dt) = (0.8_f64, 2.5, 0.3);
        let (mut f, mut qd) = ([0.0], [0.0]);
        assert!(van_loan(&[-lam], &[q], 1, dt, &mut f, &mut qd));
        let want = q * (1.0 - (-2.0 * lam * dt).exp()) / (2.0 * lam);
        assert!((f[0] - (-lam * dt).exp()).abs() < 1e-15);
        assert!((qd[0] - want).abs() < 1e-15 * want);
        assert!(van_loan(&[-lam], &[0.0], 1, dt, &mut f, &mut qd));
        assert!((f[0] - (-lam * dt).exp()).abs() < 1e-15 && qd[0].abs() < f64::MIN_POSITIVE);
        assert!(van_loan(&[], &[], 0, dt, &mut [], &mut []));
        assert!(!van_loan(&[1000.0], &[1.0], 1, 1.0, &mut f, &mut qd));
    }
}
