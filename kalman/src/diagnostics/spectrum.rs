//! Spectra: an in-place radix-2 FFT and Welch's averaged periodogram (one-sided PSD).

use std::f64::consts::PI;

use crate::Error;

/// In-place iterative radix-2 decimation-in-time FFT, `X_k = Σ x_n e^{−2πikn/N}`, of the
/// complex sequence (`re`, `im`).
///
/// # Errors
/// [`Error::Shape`] naming `im` if the lengths differ; [`Error::Dimension`] naming `N` if
/// the length is not a power of two.
///
/// # Example
/// ```
/// // The transform of a unit impulse is flat.
/// let (mut re, mut im) = (vec![1.0, 0.0, 0.0, 0.0], vec![0.0; 4]);
/// kalman::diagnostics::fft(&mut re, &mut im)?;
/// assert!(re.iter().all(|v| (v - 1.0).abs() < 1e-15) && im.iter().all(|v| v.abs() < 1e-15));
/// # Ok::<(), kalman::Error>(())
/// ```
pub fn fft(re: &mut [f64], im: &mut [f64]) -> Result<(), Error> {
    let n = re.len();
    if im.len() != n {
        return Err(Error::Shape {
            name: "im",
            rows: im.len(),
            cols: 1,
            expected_rows: n,
            expected_cols: 1,
        });
    }
    if !n.is_power_of_two() {
        return Err(Error::Dimension {
            name: "N",
            value: n,
            rule: "the FFT length must be a power of two",
        });
    }
    // Bit-reversal permutation.
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            re.swap(i, j);
            im.swap(i, j);
        }
    }
    let mut len = 2;
    while len <= n {
        let ang = -2.0 * PI / len as f64;
        for start in (0..n).step_by(len) {
            for k in 0..len / 2 {
                // Twiddles computed directly (not by recurrence) to keep round-off at O(ε).
                let (s, c) = (ang * k as f64).sin_cos();
                let (a, b) = (start + k, start + k + len / 2);
                let tr = re[b] * c - im[b] * s;
                let ti = re[b] * s + im[b] * c;
                re[b] = re[a] - tr;
                im[b] = im[a] - ti;
                re[a] += tr;
                im[a] += ti;
            }
        }
        len <<= 1;
    }
    Ok(())
}

/// A one-sided power spectral density.
///
/// # Example
/// ```
/// // 1024 samples at 8 Hz in segments of 64: bins 0, 1/8, …, 4 Hz, 31 half-overlapping segments.
/// let x: Vec<f64> = (0..1024).map(|i| ((i * 37) % 17) as f64).collect();
/// let p = kalman::diagnostics::welch(&x, 8.0, 64)?;
/// assert_eq!((p.freq.len(), p.psd.len(), p.segments), (33, 33, 31));
/// assert!((p.freq[32] - 4.0).abs() < 1e-15);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Psd {
    /// Frequencies, Hz: 0, fs/L, …, fs/2 (L the segment length).
    pub freq: Vec<f64>,
    /// Density, units²/Hz; Σ psd·Δf over the bins ≈ the signal's variance (Parseval).
    pub psd: Vec<f64>,
    /// Segments averaged.
    pub segments: usize,
}

/// Welch's method: Hann-windowed segments of `segment` samples (a power of two) with 50 %
/// overlap, each with its mean removed, periodograms averaged, scaled to a one-sided density
/// at sampling frequency `fs`: `P(f_k) = c·|X_k|²/(fs·Σw²)` with c = 2 except at 0 and fs/2
/// (P. D. Welch, *The use of fast Fourier transform for the estimation of power spectra*,
/// 1967). White noise of variance σ² has the level 2σ²/fs.
///
/// # Errors
/// [`Error::InvalidOption`] naming `segment` (not a power of two ≥ 4) or `fs` (not finite
/// and > 0); [`Error::Dimension`] naming `x` for a signal shorter than one segment.
///
/// # Example
/// ```
/// // A tone on a bin: the peak is at its frequency.
/// let x: Vec<f64> = (0..1024).map(|i| (2.0 * std::f64::consts::PI * 0.25 * i as f64).sin()).collect();
/// let p = kalman::diagnostics::welch(&x, 1.0, 64)?;
/// let peak = (0..p.psd.len()).max_by(|&a, &b| p.psd[a].total_cmp(&p.psd[b])).unwrap_or(0);
/// assert!((p.freq[peak] - 0.25).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
pub fn welch(x: &[f64], fs: f64, segment: usize) -> Result<Psd, Error> {
    if segment < 4 || !segment.is_power_of_two() {
        return Err(Error::InvalidOption {
            name: "segment",
            value: segment as f64,
            rule: "the Welch segment length must be a power of two ≥ 4",
        });
    }
    if x.len() < segment {
        return Err(Error::Dimension {
            name: "x",
            value: x.len(),
            rule: "the signal is shorter than one Welch segment",
        });
    }
    if !(fs.is_finite() && fs > 0.0) {
        return Err(Error::InvalidOption {
            name: "fs",
            value: fs,
            rule: "the sampling frequency must be finite and > 0",
        });
    }
    let w: Vec<f64> = (0..segment)
        .map(|i| 0.5 - 0.5 * (2.0 * PI * i as f64 / segment as f64).cos())
        .collect();
    let wss: f64 = w.iter().map(|v| v * v).sum();
    let half = segment / 2;
    let mut acc = vec![0.0; half + 1];
    let (mut re, mut im) = (vec![0.0; segment], vec![0.0; segment]);
    let mut segments = 0;
    let mut start = 0;
    while start + segment <= x.len() {
        let seg = &x[start..start + segment];
        let mean = seg.iter().sum::<f64>() / segment as f64;
        for i in 0..segment {
            re[i] = (seg[i] - mean) * w[i];
            im[i] = 0.0;
        }
        fft(&mut re, &mut im)?;
        for (k, a) in acc.iter_mut().enumerate() {
            *a += re[k] * re[k] + im[k] * im[k];
        }
        segments += 1;
        start += half;
    }
    let scale = 1.0 / (fs * wss * segments as f64);
    let psd = acc
        .iter()
        .enumerate()
        .map(|(k, a)| {
            let c = if k == 0 || k == half { 1.0 } else { 2.0 };
            c * a * scale
        })
        .collect();
    let freq = (0..=half).map(|k| k as f64 * fs / segment as f64).collect();
    Ok(Psd {
        freq,
        psd,
        segments,
    })
}

#[cfg(test)]
mod tests {
    use super::super::tests::white;
    use super::*;

    #[test]
    fn fft_matches_direct_dft() {
        let x: Vec<f64> = (0..16).map(|i| ((i * i) as f64 * 0.37).sin()).collect();
        let (mut re, mut im) = (x.clone(), vec![0.0; 16]);
        fft(&mut re, &mut im).expect("power of two");
        for k in 0..16 {
            let (mut sr, mut si) = (0.0, 0.0);
            for (n, v) in x.iter().enumerate() {
                let a = -2.0 * PI * (k * n) as f64 / 16.0;
                sr += v * a.cos();
                si += v * a.sin();
            }
            // 16-point transform of O(1) data: round-off ~ 16·log2(16)·ε.
            assert!(
                (re[k] - sr).abs() < 1e-12 && (im[k] - si).abs() < 1e-12,
                "bin {k}"
            );
        }
        assert!(matches!(
            fft(&mut [0.0; 6], &mut [0.0; 6]),
            Err(Error::Dimension { name: "N", .. })
        ));
        assert!(matches!(
            fft(&mut [0.0; 4], &mut [0.0; 2]),
            Err(Error::Shape { name: "im", .. })
        ));
    }

    proptest::proptest! {
        /// Any complex sequence of length 2^k (k ≤ 7) transforms as the O(N²) DFT does.
        #[test]
        fn fft_equals_dft_for_any_input(
            k in 0usize..=7,
            data in proptest::collection::vec(-1e3f64..1e3, 256),
        ) {
            let n = 1 << k;
            let (x, y) = (&data[..n], &data[128..128 + n]);
            let (mut re, mut im) = (x.to_vec(), y.to_vec());
            fft(&mut re, &mut im).expect("power of two");
            let scale = data.iter().fold(1.0f64, |m, v| m.max(v.abs())) * n as f64;
            for j in 0..n {
                let (mut sr, mut si) = (0.0, 0.0);
                for t in 0..n {
                    let a = -2.0 * PI * ((j * t) % n) as f64 / n as f64;
                    sr += x[t] * a.cos() - y[t] * a.sin();
                    si += x[t] * a.sin() + y[t] * a.cos();
                }
                // Both sums carry O(N·ε·max|x|) round-off; 1e-12 relative to N·max|x| is
                // ~100× that bound.
                proptest::prop_assert!((re[j] - sr).abs() <= 1e-12 * scale);
                proptest::prop_assert!((im[j] - si).abs() <= 1e-12 * scale);
            }
        }
    }

    #[test]
    fn white_noise_level_is_two_sigma_squared_over_fs() {
        let (sigma, fs) = (1.5, 4.0);
        let x = white(16384, sigma, 7);
        let p = welch(&x, fs, 256).expect("valid");
        let inner = &p.psd[1..p.psd.len() - 1];
        let mean = inner.iter().sum::<f64>() / inner.len() as f64;
        let expected = 2.0 * sigma * sigma / fs;
        // 127 segments × 127 bins, Hann-correlated: the mean level's relative standard error
        // is ≈ 1/√(127·127/2) ≈ 1 %; 5 % is a 5σ bound.
        assert!((mean / expected - 1.0).abs() < 0.05, "{mean} vs {expected}");
        // Parseval: the integrated density is the variance.
        let df = p.freq[1];
        let total: f64 = p.psd.iter().sum::<f64>() * df;
        assert!((total / (sigma * sigma) - 1.0).abs() < 0.05, "{total}");
        assert!(matches!(
            welch(&x, fs, 100),
            Err(Error::InvalidOption {
                name: "segment",
                ..
            })
        ));
        assert!(matches!(
            welch(&x, 0.0, 256),
            Err(Error::InvalidOption { name: "fs", .. })
        ));
        assert!(matches!(
            welch(&x[..100], fs, 256),
            Err(Error::Dimension { name: "x", .. })
        ));
    }

    #[test]
    fn sinusoid_peak_sits_at_its_frequency_with_its_power() {
        let (fs, f0, amp) = (4.0, 0.5, 2.0);
        let x: Vec<f64> = (0..4096)
            .map(|i| amp * (2.0 * PI * f0 * i as f64 / fs).sin())
            .collect();
        let p = welch(&x, fs, 256).expect("valid");
        let (imax, _) = p
            .psd
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .expect("non-empty");
        assert!((p.freq[imax] - f0).abs() < 1e-12);
        let df = p.freq[1];
        let power: f64 = p.psd[imax - 2..=imax + 2].iter().sum::<f64>() * df;
        // A Hann window spreads an on-bin tone over 3 bins; the density integrates to A²/2.
        assert!((power / (amp * amp / 2.0) - 1.0).abs() < 1e-6, "{power}");
    }
}
