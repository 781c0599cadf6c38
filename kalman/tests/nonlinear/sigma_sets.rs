//! Julier's and the simplex sigma-point sets against FilterPy 1.4.5 (golden CSV from
//! `tests/golden/make_sigma_fixed_lag.py`): points and weights for several n and κ, and
//! the unscented filter over them on the range–bearing tracker.

use std::collections::BTreeMap;

use kalman::nonlinear::SigmaPoints;

/// FilterPy forms the same points by a different Cholesky routine (LAPACK's) and
/// multiplies by the unit points in another order: entries of size O(1–10) then agree to a
/// few ulps; 1e-12 relative leaves room for that and catches any difference of formula.
const TOL: f64 = 1e-12;

type Entries = BTreeMap<(String, usize, usize), f64>;

#[test]
fn julier_and_simplex_points_and_weights_equal_filterpy() {
    let text = include_str!("../golden/sigma_sets.csv");
    // case → (set, n, κ, what → (i, j) → value)
    let mut cases: BTreeMap<usize, ((String, usize, f64), Entries)> = BTreeMap::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let case: usize = f[0].parse().expect("case");
        let e = cases.entry(case).or_insert((
            (
                f[1].to_string(),
                f[2].parse().expect("n"),
                f[3].parse().expect("kappa"),
            ),
            Entries::new(),
        ));
        e.1.insert(
            (
                f[4].to_string(),
                f[5].parse().expect("i"),
                f[6].parse().expect("j"),
            ),
            f[7].parse().expect("value"),
        );
    }
    assert_eq!(cases.len(), 9);
    let mut seen = (0, 0);
    for ((name, n, kappa), e) in cases.values() {
        let n = *n;
        let get = |w: &str, i: usize, j: usize| e[&(w.to_string(), i, j)];
        let set = match name.as_str() {
            "julier" => {
                seen.0 += 1;
                SigmaPoints::julier(*kappa)
            }
            "simplex" => {
                seen.1 += 1;
                SigmaPoints::Simplex
            }
            other => panic!("unknown set {other} in the golden file"),
        };
        let count = set.len(n);
        assert_eq!(count, if name == "simplex" { n + 1 } else { 2 * n + 1 });
        let x: Vec<f64> = (0..n).map(|i| get("x", i, 0)).collect();
        let P = faer::Mat::from_fn(n, n, |i, j| get("P", i, j));
        let pts = set.points(&x, &P).expect("points");
        assert_eq!(pts.ncols(), count);
        for i in 0..n {
            for j in 0..count {
                let (a, b) = (pts[(i, j)], get("sigma", i, j));
                assert!(
                    (a - b).abs() <= TOL * b.abs().max(1.0),
                    "{name} n={n} sigma({i},{j}): {a} vs FilterPy {b}"
                );
            }
        }
        let (mut wm, mut wc) = (vec![0.0; count], vec![0.0; count]);
        set.weights(n, &mut wm, &mut wc).expect("weights");
        for j in 0..count {
            for (w, what) in [(wm[j], "Wm"), (wc[j], "Wc")] {
                let b = get(what, j, 0);
                assert!(
                    (w - b).abs() <= TOL * b.abs().max(1.0),
                    "{name} n={n} {what}[{j}]: {w} vs FilterPy {b}"
                );
            }
        }
    }
    assert_eq!(seen, (4, 5));
}

/// A weight slice shorter than the set is a typed error, as are Julier's n + κ ≤ 0.
#[test]
fn bad_weight_requests_are_typed_errors() {
    let (mut wm, mut wc) = (vec![0.0; 4], vec![0.0; 4]);
    let e = SigmaPoints::julier(0.0)
        .weights(2, &mut wm, &mut wc)
        .expect_err("5 points, 4 slots");
    assert!(
        matches!(
            e,
            kalman::Error::Dimension {
                name: "weights",
                value: 4,
                ..
            }
        ),
        "{e}"
    );
    assert!(SigmaPoints::Simplex.weights(3, &mut wm, &mut wc).is_ok());
    let (mut wm, mut wc) = (vec![0.0; 7], vec![0.0; 7]);
    let e = SigmaPoints::julier(-3.0)
        .weights(3, &mut wm, &mut wc)
        .expect_err("n + κ = 0");
    assert!(
        matches!(e, kalman::Error::InvalidOption { name: "kappa", .. }),
        "{e}"
    );
}
