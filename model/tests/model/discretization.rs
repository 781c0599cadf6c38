//! Discretisation: ZOH closed forms and Van Loan, Tustin (stability, DC gain, pre-warp),
//! Euler maps, and transfer-function realisations and Tustin in z⁻¹.

use model::{
    ContinuousSs, ContinuousTf, DiscreteTf, Discretization, NoiseConvention, discretize, expm,
    van_loan, zoh,
};
use nalgebra::{Complex, DMatrix};

use super::support::{assert_close, close};

fn m(r: usize, c: usize, v: &[f64]) -> DMatrix<f64> {
    DMatrix::from_row_slice(r, c, v)
}

#[test]
fn zoh_double_integrator() {
    let dt = 0.25;
    let a = m(2, 2, &[0.0, 1.0, 0.0, 0.0]);
    let b = m(2, 1, &[0.0, 1.0]);
    let (f, bd) = zoh(&a, &b, dt).expect("ok");
    // Padé exponential of a nilpotent matrix is exact up to rounding.
    assert_close("F", &f, &m(2, 2, &[1.0, dt, 0.0, 1.0]), 1e-14);
    assert_close("B", &bd, &m(2, 1, &[dt * dt / 2.0, dt]), 1e-14);
    // Through discretize() with ZOH as well.
    let sys = ContinuousSs::new(a, b, m(1, 2, &[1.0, 0.0]), m(1, 1, &[0.0])).expect("valid");
    let d = discretize(&sys, dt, Discretization::Zoh, NoiseConvention::VanLoan).expect("ok");
    assert_close(
        "F via discretize",
        d.f(),
        &m(2, 2, &[1.0, dt, 0.0, 1.0]),
        1e-14,
    );
}

#[test]
fn van_loan_white_acceleration() {
    let (dt, q) = (0.3, 0.7);
    let a = m(2, 2, &[0.0, 1.0, 0.0, 0.0]);
    let g = m(2, 1, &[0.0, 1.0]);
    let (_, qd) = van_loan(&a, &g, &m(1, 1, &[q]), dt).expect("ok");
    let want = m(
        2,
        2,
        &[dt.powi(3) / 3.0, dt.powi(2) / 2.0, dt.powi(2) / 2.0, dt],
    ) * q;
    assert_close("Q", &qd, &want, 1e-13);
}

#[test]
fn van_loan_transition_with_and_without_noise() {
    // The transition is e^{A·Δt} whether or not noise enters (a zero G W Gᵀ takes the short
    // path without the 2n×2n exponential): for the double integrator, [[1, Δt], [0, 1]],
    // exact up to rounding (nilpotent A).
    let dt = 0.3;
    let a = m(2, 2, &[0.0, 1.0, 0.0, 0.0]);
    let g = m(2, 1, &[0.0, 1.0]);
    let exact = m(2, 2, &[1.0, dt, 0.0, 1.0]);
    for q in [0.0, 0.7] {
        let (phi, qd) = van_loan(&a, &g, &m(1, 1, &[q]), dt).expect("ok");
        assert_close("e^{A dt}", &phi, &exact, 1e-14);
        assert_eq!(
            qd.iter().any(|v| v.abs() > 0.0),
            q > 0.0,
            "Q_d zero exactly when q = 0"
        );
    }
}

#[test]
fn zoh_first_order_lag() {
    for (t, dt) in [(2.0, 0.1), (0.5, 1.0), (20.0, 0.05)] {
        let a = m(1, 1, &[-1.0 / t]);
        let b = m(1, 1, &[1.0 / t]);
        let (f, bd) = zoh(&a, &b, dt).expect("ok");
        let e = (-dt / t).exp();
        assert!(close(f[(0, 0)], e, 1e-14), "F = e^(-dt/T)");
        assert!(
            close(bd[(0, 0)], 1.0 - e, 1e-13),
            "B = 1 − e^(-dt/T) (unit DC gain)"
        );
    }
}

#[test]
fn euler_scalar_closed_forms() {
    let (a, dt) = (-3.0, 0.1);
    let sys = ContinuousSs::new(
        m(1, 1, &[a]),
        m(1, 1, &[1.0]),
        m(1, 1, &[1.0]),
        m(1, 1, &[0.0]),
    )
    .expect("valid");
    let fe = discretize(
        &sys,
        dt,
        Discretization::ForwardEuler,
        NoiseConvention::IntensityOverDt,
    )
    .expect("ok");
    assert!(close(fe.f()[(0, 0)], 1.0 + a * dt, 1e-15));
    assert!(close(fe.b()[(0, 0)], dt, 1e-15));
    let be = discretize(
        &sys,
        dt,
        Discretization::BackwardEuler,
        NoiseConvention::IntensityOverDt,
    )
    .expect("ok");
    assert!(close(be.f()[(0, 0)], 1.0 / (1.0 - a * dt), 1e-15));
    // Backward Euler realises H(s) at s = (z − 1)/(z Δt).
    let z = Complex::from_polar(1.0, 0.7);
    let s = (z - 1.0) / (z * dt);
    let hc = 1.0 / (s - a);
    let hd = be.freq_response(0.7 / dt).expect("ok")[(0, 0)];
    assert!((hd - hc).norm() < 1e-12, "{hd} vs {hc}");
}

#[test]
fn tustin_scalar_closed_form_and_noise_feedthrough() {
    // 1/(T s + 1) by Tustin: F = (T − Δt/2)/(T + Δt/2) (the paper's p_a); with the paper's
    // noise convention the feed-through is g_a = Δt/(2(T + Δt/2)) and Q = N/Δt.
    let (t, dt) = (20.0, 0.1);
    let f = model::ExponentialShaping::new(1e-6, t).expect("valid");
    let d = model::ShapingFilter::discretize(
        &f,
        dt,
        Discretization::Tustin,
        NoiseConvention::IntensityOverDt,
    )
    .expect("ok");
    assert!(close(d.f()[(0, 0)], (t - dt / 2.0) / (t + dt / 2.0), 1e-14));
    let ga = dt / (2.0 * (t + dt / 2.0));
    assert!(close(d.j()[(0, 0)], ga, 1e-14), "J = {}", d.j()[(0, 0)]);
    assert!(close(d.q()[(0, 0)], 2.0 * t * 1e-6 / dt, 1e-14));
}

#[test]
fn transfer_function_realisations_match_evaluation() {
    let tfs = [
        ContinuousTf::new(vec![1.0, 0.5], vec![2.0, 3.0, 1.0]).expect("valid"),
        ContinuousTf::new(vec![1.0, 2.0, 3.0], vec![4.0, 5.0, 6.0]).expect("valid"),
        ContinuousTf::new(vec![2.0], vec![1.0, 0.3, 0.2, 0.05]).expect("valid"),
    ];
    for tf in &tfs {
        let ss = tf.realize();
        for w in [0.0, 0.3, 1.0, 7.0] {
            let want = tf.freq_response(w);
            let got = ss.freq_response(w).expect("not a pole")[(0, 0)];
            assert!(
                (got - want).norm() < 1e-12 * want.norm().max(1.0),
                "{got} vs {want}"
            );
        }
        // Tustin in z⁻¹ equals H(s) at s = (2/Δt)(z − 1)/(z + 1), and the state-space Tustin
        // of the realisation has the same response.
        let dt = 0.2;
        let dtf = tf.tustin(dt, None).expect("ok");
        let dss = discretize(
            &ss,
            dt,
            Discretization::Tustin,
            NoiseConvention::IntensityOverDt,
        )
        .expect("ok");
        for w in [0.1, 1.0, 5.0] {
            let z = Complex::from_polar(1.0, w * dt);
            let s = (z - 1.0) / (z + 1.0) * (2.0 / dt);
            let want = tf.eval(s);
            assert!((dtf.freq_response(w) - want).norm() < 1e-12 * want.norm().max(1.0));
            let got = dss.freq_response(w).expect("ok")[(0, 0)];
            assert!(
                (got - want).norm() < 1e-11 * want.norm().max(1.0),
                "{got} vs {want}"
            );
            let real = dtf.realize().freq_response(w).expect("ok")[(0, 0)];
            assert!((real - want).norm() < 1e-11 * want.norm().max(1.0));
        }
    }
}

#[test]
fn discrete_tf_impulse_response_matches_realisation() {
    let tf = DiscreteTf::new(vec![0.5, 0.2, -0.1], vec![1.0, -0.6, 0.08], 0.1).expect("valid");
    let h = tf.impulse_response(30);
    let ss = tf.realize();
    // The same response from the noise input of the noise-driven model (G = B, J = D).
    let noise = model::noise_driven(&tf, 1.0).expect("valid");
    for markov in [ss.impulse_response(30), noise.noise_impulse_response(30)] {
        assert_eq!(markov.len(), 30);
        for (k, mk) in markov.iter().enumerate() {
            assert!((mk[(0, 0)] - h[k]).abs() < 1e-14, "k = {k}");
        }
    }
}

#[test]
fn paper_tustin_keeps_dc_gain() {
    let tf = ContinuousTf::new(vec![1.0], vec![1.0, 0.3, 0.5]).expect("valid");
    for v in [model::PaperVariant::Delay, model::PaperVariant::Drop] {
        let d = tf.paper_tustin(0.1, v).expect("ok");
        let g = d.freq_response(0.0);
        assert!((g - Complex::new(1.0, 0.0)).norm() < 1e-12, "{v:?}: {g}");
    }
}

#[test]
fn pre_warped_tustin_is_exact_at_the_warp_frequency_scalar() {
    let tf = ContinuousTf::new(vec![1.0], vec![1.0, 0.1, 0.04]).expect("valid");
    let (dt, w) = (0.2, 5.0); // resonance at 5 rad/s, Nyquist 15.7 rad/s
    let d = tf.tustin(dt, Some(w)).expect("ok");
    assert!((d.freq_response(w) - tf.freq_response(w)).norm() < 1e-12);
    let plain = tf.tustin(dt, None).expect("ok");
    assert!(
        (plain.freq_response(w) - tf.freq_response(w)).norm() > 1e-3,
        "warping matters here"
    );
}

#[cfg(feature = "proptest")]
mod props {
    use model::strategies::stable_continuous;
    use model::{Discretization, NoiseConvention, discretize, expm, van_loan};
    use nalgebra::DMatrix;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(super::super::support::config())]

        /// e^{AΔt}·e^{−AΔt} = I and the Van Loan Q is symmetric PSD.
        #[test]
        fn zoh_inverse_and_van_loan_psd(sys in stable_continuous(6, 3, 3), dt in 0.01..2.0f64) {
            let n = sys.n_states();
            let f = expm(&(sys.a() * dt)).expect("ok");
            let finv = expm(&(sys.a() * -dt)).expect("ok");
            // ‖AΔt‖ ≤ 2(1 + n): the exponential's rounding grows with its norm; 1e-11 holds
            // with margin for n ≤ 6.
            let err = (&f * &finv - DMatrix::<f64>::identity(n, n)).amax();
            prop_assert!(err < 1e-11, "F·F(−Δt) − I = {err:e}");
            let (_, q) = van_loan(sys.a(), sys.g(), sys.w(), dt).expect("ok");
            prop_assert!((&q - q.transpose()).amax() <= 0.0, "Q is symmetrised exactly");
            let min = q.symmetric_eigenvalues().min();
            prop_assert!(min >= -1e-12 * q.amax().max(1e-300), "min eig {min:e}");
        }

        /// Tustin maps a stable system to a stable one and keeps its DC gain.
        #[test]
        fn tustin_stable_and_dc_gain(sys in stable_continuous(6, 3, 3), dt in 0.01..2.0f64) {
            let d = discretize(&sys, dt, Discretization::Tustin, NoiseConvention::IntensityOverDt).expect("ok");
            let rho = d.spectral_radius().expect("ok");
            prop_assert!(rho < 1.0, "spectral radius {rho}");
            let gc = sys.dc_gain().expect("A is stable hence invertible");
            let gd = d.dc_gain().expect("stable");
            // Both are solves with matrices of condition ≲ 1e3 for these bounded systems.
            let err = (&gc - &gd).amax();
            prop_assert!(err <= 1e-9 * gc.amax().max(1.0), "DC gain differs by {err:e}");
        }

        /// Pre-warped Tustin reproduces the continuous response at the warp frequency.
        #[test]
        fn tustin_prewarp_exact_at_omega(
            sys in stable_continuous(6, 3, 3),
            dt in 0.01..1.0f64,
            frac in 0.05..0.9f64,
        ) {
            let omega = frac * std::f64::consts::PI / dt;
            let d = discretize(&sys, dt, Discretization::TustinPrewarp { omega }, NoiseConvention::IntensityOverDt)
                .expect("ok");
            let hc = sys.freq_response(omega).expect("stable: no pole on the axis");
            let hd = d.freq_response(omega).expect("stable");
            let err = (&hc - &hd).iter().map(|c| c.norm()).fold(0.0, f64::max);
            let scale = hc.iter().map(|c| c.norm()).fold(1.0, f64::max);
            prop_assert!(err <= 1e-9 * scale, "response differs by {err:e}");
        }
    }
}

#[test]
fn expm_of_zero_matrix_is_identity() {
    let e = expm(&DMatrix::zeros(3, 3)).expect("ok");
    assert_close("e^0", &e, &DMatrix::identity(3, 3), 0.0);
    assert_eq!(expm(&DMatrix::zeros(0, 0)).expect("ok").shape(), (0, 0));
}
