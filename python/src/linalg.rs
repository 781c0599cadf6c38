//! Small dense kernels on row-major slices for the FilterPy-compatible filter and smoother
//! (sizes of a few tens at most, where a plain loop beats any dispatch), with the one
//! factorisation they need: Cholesky, falling back to LU with partial pivoting.

/// `out = a · b` with `a` r×k and `b` k×c.
pub(crate) fn mul(a: &[f64], b: &[f64], r: usize, k: usize, c: usize, out: &mut [f64]) {
    for i in 0..r {
        let row = &mut out[i * c..(i + 1) * c];
        row.fill(0.0);
        for l in 0..k {
            let ail = a[i * k + l];
            let brow = &b[l * c..(l + 1) * c];
            for (o, bv) in row.iter_mut().zip(brow) {
                *o += ail * bv;
            }
        }
    }
}

/// `out = a · bᵀ` with `a` r×k and `b` c×k.
pub(crate) fn mul_bt(a: &[f64], b: &[f64], r: usize, k: usize, c: usize, out: &mut [f64]) {
    for i in 0..r {
        let arow = &a[i * k..(i + 1) * k];
        for j in 0..c {
            let brow = &b[j * k..(j + 1) * k];
            out[i * c + j] = arow.iter().zip(brow).map(|(x, y)| x * y).sum();
        }
    }
}

/// `y = a · x` with `a` r×k.
pub(crate) fn mul_vec(a: &[f64], x: &[f64], r: usize, k: usize, y: &mut [f64]) {
    for i in 0..r {
        y[i] = a[i * k..(i + 1) * k]
            .iter()
            .zip(x)
            .map(|(p, q)| p * q)
            .sum();
    }
}

/// `y += a · x` with `a` (len y)×(len x): each row's dot product, then added.
pub(crate) fn add_mul_vec(a: &[f64], x: &[f64], y: &mut [f64]) {
    let k = x.len();
    for (i, yi) in y.iter_mut().enumerate() {
        *yi += a[i * k..(i + 1) * k]
            .iter()
            .zip(x)
            .map(|(p, q)| p * q)
            .sum::<f64>();
    }
}

/// How a square matrix was factored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Cholesky,
    Lu,
}

/// A factorisation of a square matrix A (Cholesky when A is positive definite, LU with
/// partial pivoting otherwise), kept to solve with it several times.
#[derive(Clone, Debug)]
pub(crate) struct Factor {
    kind: Kind,
    n: usize,
    lu: Vec<f64>,
    piv: Vec<usize>,
}

impl Factor {
    /// Room for an n×n factorisation.
    pub(crate) fn new(n: usize) -> Self {
        Self {
            kind: Kind::Cholesky,
            n: 0,
            lu: vec![0.0; n * n],
            piv: vec![0; n],
        }
    }

    /// [`Factor::new`], allocated fallibly (`None`: n×n floats do not fit in memory).
    pub(crate) fn try_new(n: usize) -> Option<Self> {
        let mut lu = Vec::new();
        lu.try_reserve_exact(n.checked_mul(n)?).ok()?;
        lu.resize(n * n, 0.0);
        let mut piv = Vec::new();
        piv.try_reserve_exact(n).ok()?;
        piv.resize(n, 0);
        Some(Self {
            kind: Kind::Cholesky,
            n: 0,
            lu,
            piv,
        })
    }

    /// Factors the n×n matrix `a`; `false` if it is singular.
    pub(crate) fn factor(&mut self, a: &[f64], n: usize) -> bool {
        self.n = n;
        if self.lu.len() < n * n {
            self.lu.resize(n * n, 0.0);
            self.piv.resize(n, 0);
        }
        let lu = &mut self.lu[..n * n];
        lu.copy_from_slice(&a[..n * n]);
        // A symmetric A reads the same column-major: the factor is kalman's, with L in the
        // column-major lower triangle.
        if kalman::dense::cholesky(lu, n, 0.0) {
            self.kind = Kind::Cholesky;
            return true;
        }
        self.kind = Kind::Lu;
        lu.copy_from_slice(&a[..n * n]);
        let scale = a[..n * n].iter().fold(0.0f64, |s, v| s.max(v.abs()));
        for k in 0..n {
            let mut p = k;
            for i in k + 1..n {
                if lu[i * n + k].abs() > lu[p * n + k].abs() {
                    p = i;
                }
            }
            self.piv[k] = p;
            if lu[p * n + k].abs() <= f64::EPSILON * scale * n as f64 || scale == 0.0 {
                return false;
            }
            if p != k {
                for j in 0..n {
                    lu.swap(k * n + j, p * n + j);
                }
            }
            let d = lu[k * n + k];
            for i in k + 1..n {
                let f = lu[i * n + k] / d;
                lu[i * n + k] = f;
                for j in k + 1..n {
                    lu[i * n + j] -= f * lu[k * n + j];
                }
            }
        }
        true
    }

    /// Solves A X = B in place for B n×c (row-major).
    pub(crate) fn solve(&self, b: &mut [f64], c: usize) {
        let n = self.n;
        let lu = &self.lu[..n * n];
        match self.kind {
            Kind::Cholesky => kalman::dense::cholesky_solve_columns(lu, n, b, c),
            Kind::Lu => {
                for k in 0..n {
                    let p = self.piv[k];
                    if p != k {
                        for j in 0..c {
                            b.swap(k * c + j, p * c + j);
                        }
                    }
                }
                for col in 0..c {
                    for i in 0..n {
                        let mut s = b[i * c + col];
                        for k in 0..i {
                            s -= lu[i * n + k] * b[k * c + col];
                        }
                        b[i * c + col] = s;
                    }
                    for i in (0..n).rev() {
                        let mut s = b[i * c + col];
                        for k in i + 1..n {
                            s -= lu[i * n + k] * b[k * c + col];
                        }
                        b[i * c + col] = s / lu[i * n + i];
                    }
                }
            }
        }
    }

    /// log |det A|.
    pub(crate) fn log_abs_det(&self) -> f64 {
        let n = self.n;
        let d: f64 = (0..n).map(|i| self.lu[i * n + i].abs().ln()).sum();
        match self.kind {
            Kind::Cholesky => 2.0 * d,
            Kind::Lu => d,
        }
    }

    /// yᵀ A⁻¹ y (with `work` of length n).
    pub(crate) fn quad(&self, y: &[f64], work: &mut [f64]) -> f64 {
        let n = self.n;
        work[..n].copy_from_slice(&y[..n]);
        self.solve(&mut work[..n], 1);
        y[..n].iter().zip(&work[..n]).map(|(a, b)| a * b).sum()
    }
}
