//! Composition: series, parallel, stack, append, select, feedback and connect against
//! transfer-function algebra, and noise bookkeeping.

use model::{
    ContinuousTf, DiscreteSs, DiscreteTf, append, connect, feedback, parallel, select_outputs,
    series, stack,
};
use nalgebra::{Complex, DMatrix};

const DT: f64 = 0.1;

fn block(num: &[f64], den: &[f64]) -> (DiscreteTf, DiscreteSs) {
    let tf = DiscreteTf::new(num.to_vec(), den.to_vec(), DT).expect("valid");
    let ss = tf.realize();
    (tf, ss)
}

fn resp(s: &DiscreteSs, w: f64) -> DMatrix<Complex<f64>> {
    s.freq_response(w).expect("not a pole")
}

/// Responses are products/sums of a few O(1) complex numbers: 1e-12 absolute is ample.
fn near(a: Complex<f64>, b: Complex<f64>) -> bool {
    (a - b).norm() < 1e-12 * b.norm().max(1.0)
}

#[test]
fn series_parallel_feedback_match_transfer_function_algebra() {
    let (t1, s1) = block(&[0.2, 0.1], &[1.0, -0.7]);
    let (t2, s2) = block(&[0.0, 0.5, 0.3], &[1.0, -0.4, 0.1]);
    let ser = series(&s1, &s2).expect("ok");
    let par = parallel(&s1, &s2).expect("ok");
    let fb = feedback(&s1, &s2, -1.0).expect("ok");
    assert_eq!(ser.n_states(), s1.n_states() + s2.n_states());
    for w in [0.0, 1.0, 5.0, 20.0] {
        let (h1, h2) = (t1.freq_response(w), t2.freq_response(w));
        assert!(near(resp(&ser, w)[(0, 0)], h1 * h2), "series at {w}");
        assert!(near(resp(&par, w)[(0, 0)], h1 + h2), "parallel at {w}");
        assert!(
            near(resp(&fb, w)[(0, 0)], h1 / (1.0 + h1 * h2)),
            "feedback at {w}"
        );
    }
}

#[test]
fn feedback_with_algebraic_loop_is_solved() {
    // Both blocks have feed-through: the loop is algebraic but well posed.
    let (t1, s1) = block(&[0.5, 0.1], &[1.0, -0.5]);
    let (t2, s2) = block(&[0.3], &[1.0, 0.2]);
    let fb = feedback(&s1, &s2, -1.0).expect("ok");
    for w in [0.0, 3.0] {
        let (h1, h2) = (t1.freq_response(w), t2.freq_response(w));
        assert!(near(resp(&fb, w)[(0, 0)], h1 / (1.0 + h1 * h2)));
    }
}

#[test]
fn stack_append_select() {
    let (t1, s1) = block(&[0.2, 0.1], &[1.0, -0.7]);
    let (t2, s2) = block(&[1.0], &[1.0, -0.2]);
    let st = stack(&s1, &s2).expect("ok");
    let ap = append(&s1, &s2).expect("ok");
    assert_eq!((st.n_inputs(), st.n_outputs()), (1, 2));
    assert_eq!((ap.n_inputs(), ap.n_outputs()), (2, 2));
    let w = 2.0;
    let (h1, h2) = (t1.freq_response(w), t2.freq_response(w));
    let r = resp(&st, w);
    assert!(near(r[(0, 0)], h1) && near(r[(1, 0)], h2));
    let r = resp(&ap, w);
    assert!(near(r[(0, 0)], h1) && near(r[(1, 1)], h2));
    assert!(r[(0, 1)].norm() < 1e-15 && r[(1, 0)].norm() < 1e-15);
    let sel = select_outputs(&st, &[1, 0, 1]).expect("ok");
    let r = resp(&sel, w);
    assert!(near(r[(0, 0)], h2) && near(r[(1, 0)], h1) && near(r[(2, 0)], h2));
}

#[test]
fn connect_equals_series_and_keeps_noise() {
    let (_, s1) = block(&[0.2, 0.1], &[1.0, -0.7]);
    let s1n = model::noise_driven(
        &DiscreteTf::new(vec![1.0], vec![1.0, -0.5], DT).expect("valid"),
        2.0,
    )
    .expect("valid");
    // A noise-driven block appended to a signal block keeps its noise input and covariance.
    let both = append(&s1, &s1n).expect("ok");
    assert_eq!(both.n_noise(), 1);
    assert!((both.q()[(0, 0)] - 2.0).abs() < 1e-15);
    // connect with series wiring = series.
    let (_, s2) = block(&[0.0, 0.5, 0.3], &[1.0, -0.4, 0.1]);
    let k = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, 1.0, 0.0]);
    let e = DMatrix::from_row_slice(2, 1, &[1.0, 0.0]);
    let p = DMatrix::from_row_slice(1, 2, &[0.0, 1.0]);
    let c = connect(&[&s1, &s2], &k, &e, &p, &DMatrix::zeros(1, 1)).expect("ok");
    let s = series(&s1, &s2).expect("ok");
    assert!((c.f() - s.f()).amax() < 1e-15 && (c.h() - s.h()).amax() < 1e-15);
}

#[test]
fn continuous_blocks_connect_like_transfer_functions() {
    let t1 = ContinuousTf::new(vec![1.0], vec![1.0, 2.0]).expect("valid");
    let t2 = ContinuousTf::new(vec![1.0, 0.5], vec![1.0, 0.3, 0.2]).expect("valid");
    let (c1, c2) = (t1.realize(), t2.realize());
    let k = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, 1.0, 0.0]);
    let e = DMatrix::from_row_slice(2, 1, &[1.0, 0.0]);
    let p = DMatrix::from_row_slice(1, 2, &[0.0, 1.0]);
    let c = model::connect_continuous(&[&c1, &c2], &k, &e, &p, &DMatrix::zeros(1, 1)).expect("ok");
    for w in [0.0, 0.7, 4.0] {
        let want = t1.freq_response(w) * t2.freq_response(w);
        assert!(near(c.freq_response(w).expect("ok")[(0, 0)], want));
    }
}
