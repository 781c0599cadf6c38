//! The free items by name ([`FreeSpec`]): every well-formed item parsed into what it names
//! and back to the parameter names, every malformed one a [`FitError::Parameters`] naming
//! it, the white-acceleration Q₁ against its closed forms, and the map of a spec equal to
//! the one written by hand.

use faer::Mat;
use kalman::fit::{
    FitError, Free, FreeSpec, Matrix, Param, ParamMap, StandardMap, Structure, System,
    white_acceleration_q,
};

fn parameters_error(items: &[&str]) -> String {
    match FreeSpec::parse(items) {
        Err(FitError::Parameters(m)) => m,
        other => panic!("{items:?}: expected a parameters error, got {other:?}"),
    }
}

#[test]
fn every_well_formed_item_parses_to_what_it_names() {
    for (item, q, r) in [
        ("Q:scalar", Structure::Scalar, Structure::Fixed),
        ("Q:diag", Structure::Diag, Structure::Fixed),
        ("Q:full", Structure::Full, Structure::Fixed),
        ("Qc:diag", Structure::Diag, Structure::Fixed),
        ("R:scalar", Structure::Fixed, Structure::Scalar),
        ("R:diag", Structure::Fixed, Structure::Diag),
        ("R : full", Structure::Fixed, Structure::Full),
    ] {
        let s = FreeSpec::parse(&[item]).expect(item);
        assert_eq!((s.free.q, s.free.r), (q, r), "{item}");
        assert!(s.entries.is_empty() && !s.white_acceleration && !s.is_empty());
    }
    let s = FreeSpec::parse(&["x0", "P0:diag", "Q:white-acceleration"]).expect("whole");
    assert!(s.free.x0 && s.free.p0_diag && s.white_acceleration);
    assert_eq!(s.free.q, Structure::Fixed);
    // Entries: the name parsed gives the entry, whose parameter carries the name back.
    for (m, i, j) in [
        (Matrix::F, 0, 1),
        (Matrix::B, 2, 0),
        (Matrix::H, 1, 0),
        (Matrix::Q, 0, 0),
        (Matrix::R, 1, 1),
        (Matrix::P0, 3, 2),
        (Matrix::X0, 1, 0),
    ] {
        let name = Param::entry(m, i, j).name().to_string();
        let s = FreeSpec::parse(&[name.as_str()]).expect(&name);
        assert_eq!(s.entries, [(m, i, j)], "{name}");
        assert_eq!(Param::entry(m, i, j).name(), name);
    }
    // Qc[i,j] is Q[i,j]; blanks and several items in one string are accepted.
    let s = FreeSpec::parse(&["Qc[1,0]", " F[ 0 , 0 ] , R:diag,, "]).expect("list");
    assert_eq!(s.entries, [(Matrix::Q, 1, 0), (Matrix::F, 0, 0)]);
    assert_eq!(s.free.r, Structure::Diag);
    assert!(FreeSpec::parse::<&str>(&[]).expect("empty").is_empty());
    // Merging keeps the order and refuses an item in two lists.
    let a = FreeSpec::parse(&["F[0,0]", "Q:diag"]).expect("a");
    let b = FreeSpec::parse(&["R:diag", "x0[0]"]).expect("b");
    let m = FreeSpec::merge(&[a.clone(), b]).expect("merge");
    assert_eq!(m.entries, [(Matrix::F, 0, 0), (Matrix::X0, 0, 0)]);
    assert_eq!((m.free.q, m.free.r), (Structure::Diag, Structure::Diag));
    let wa = FreeSpec::parse(&["Q:white-acceleration"]).expect("wa");
    let f = FreeSpec::parse(&["F[0,0]"]).expect("f");
    for (x, y, want) in [
        (&f, &a, "F[0,0] is listed twice"),
        (&a, &wa, "Q is listed twice"),
        (&wa, &a, "Q is listed twice"),
    ] {
        match FreeSpec::merge(&[x.clone(), y.clone()]) {
            Err(FitError::Parameters(msg)) => assert!(msg.contains(want), "{msg}"),
            other => panic!("expected {want}, got {other:?}"),
        }
    }
}

#[test]
fn every_malformed_item_is_a_typed_error_naming_it() {
    for (items, want) in [
        (&["G[0,0]"][..], "unknown matrix 'G' in G[0,0]"),
        (&["F[0]"], "F[0]: an entry takes two indices"),
        (&["F[0,1,2]"], "F[0,1,2]: an entry takes two indices"),
        (&["F[-1,0]"], "F[-1,0]: an entry takes two indices"),
        (&["F[a,0]"], "F[a,0]: an entry takes two indices"),
        (&["F[0,0"], "F[0,0: an entry is written NAME[i,j]"),
        (&["x0[0,1]"], "x0[0,1]: x0 takes one index"),
        (&["Q"], "Q needs a structure: Q:scalar, Q:diag or Q:full"),
        (
            &["R:banded"],
            "R:banded: the structure must be scalar, diag or full",
        ),
        (&["x0:diag"], "x0 takes no structure"),
        (&["P0"], "P0 can only be freed as a diagonal"),
        (&["P0:full"], "P0 can only be freed as a diagonal"),
        (&["F:diag"], "unknown free item 'F' with structure 'diag'"),
        (&["bogus"], "unknown free item 'bogus'"),
        (&["Q:diag", "Q:full"], "Q is listed twice"),
        (&["Q:diag,Q:white-acceleration"], "Q is listed twice"),
        (&["Q:diag", "Qc:scalar"], "Q is listed twice"),
        (&["F[0,0]", "F[0,0]"], "F[0,0] is listed twice"),
        (&["x0", "x0"], "x0 is listed twice"),
    ] {
        let msg = parameters_error(items);
        assert!(msg.contains(want), "{items:?}: {msg}");
    }
}

fn cv(dt: f64) -> System {
    System::new(
        &[[1.0, dt], [0.0, 1.0]],
        &[[1.0, 0.0]],
        &[[2.0, 0.0], [0.0, 2.0]],
        &[[1.0]],
        &[0.0, 0.0],
        &[[1.0, 0.0], [0.0, 1.0]],
    )
    .expect("cv")
}

#[test]
fn white_acceleration_matches_the_closed_forms() {
    // Constant velocity: Q₁ = [[Δt³/3, Δt²/2], [Δt²/2, Δt]]; constant acceleration: the
    // Δt⁵/20 … Δt table. Van Loan's exponential of a nilpotent block is exact up to
    // round-off: 1e-12 relative.
    let dt: f64 = 0.3;
    let q = white_acceleration_q(&cv(dt).f, dt).expect("cv");
    let want = [[dt.powi(3) / 3.0, dt.powi(2) / 2.0], [dt.powi(2) / 2.0, dt]];
    for (i, row) in want.iter().enumerate() {
        for (j, w) in row.iter().enumerate() {
            assert!((q[(i, j)] - w).abs() <= 1e-12 * w.abs(), "Q₁[{i},{j}]");
        }
    }
    let F = Mat::from_fn(3, 3, |i, j| match j.checked_sub(i) {
        Some(0) => 1.0,
        Some(1) => dt,
        Some(2) => dt * dt / 2.0,
        _ => 0.0,
    });
    let q = white_acceleration_q(&F, dt).expect("ca");
    let p = |k: i32, d: f64| dt.powi(k) / d;
    let want = [
        [p(5, 20.0), p(4, 8.0), p(3, 6.0)],
        [p(4, 8.0), p(3, 3.0), p(2, 2.0)],
        [p(3, 6.0), p(2, 2.0), dt],
    ];
    for (i, row) in want.iter().enumerate() {
        for (j, w) in row.iter().enumerate() {
            assert!((q[(i, j)] - w).abs() <= 1e-12 * w.abs(), "Q₁[{i},{j}]");
        }
    }
    // Not an integrator chain, or no dt: refused by name.
    let ar = Mat::from_fn(1, 1, |_, _| 0.9);
    for (r, want) in [
        (white_acceleration_q(&ar, dt), "chains of integrators"),
        (
            white_acceleration_q(&cv(dt).f, -1.0),
            "chains of integrators",
        ),
    ] {
        match r {
            Err(FitError::Parameters(m)) => assert!(m.contains(want), "{m}"),
            other => panic!("expected a refusal, got {other:?}"),
        }
    }
    let spec = FreeSpec::parse(&["Q:white-acceleration"]).expect("wa");
    match spec.map(cv(dt), None) {
        Err(FitError::Parameters(m)) => assert!(m.contains("dt"), "{m}"),
        other => panic!("expected a refusal without dt, got {other:?}"),
    }
    // The start keeps the given Q's trace (4 = q₀·(Δt³/3 + Δt)) with Q₁'s pattern.
    let map = spec.map(cv(dt), Some(dt)).expect("map");
    let q = &map.base().q;
    let q0 = 4.0 / (dt.powi(3) / 3.0 + dt);
    assert!((q[(0, 1)] - q0 * dt * dt / 2.0).abs() <= 1e-12 * q0);
    assert_eq!(map.names(), ["Q:white-acceleration"]);
    assert!(matches!(
        FreeSpec::default().map(cv(dt), Some(dt)),
        Err(FitError::NothingFree)
    ));
}

#[test]
fn the_map_of_a_spec_is_the_map_written_by_hand() {
    let dt = 0.5;
    let spec = FreeSpec::parse(&["F[0,1], H[0,1]", "R:diag", "x0"]).expect("spec");
    let by_name = spec.map(cv(dt), Some(dt)).expect("by name");
    let free = Free {
        r: Structure::Diag,
        x0: true,
        ..Free::default()
    };
    let params = vec![Param::entry(Matrix::F, 0, 1), Param::entry(Matrix::H, 0, 1)];
    let by_hand = StandardMap::with_params(cv(dt), free, params).expect("by hand");
    assert_eq!(by_name.names(), by_hand.names());
    let theta: Vec<f64> = (0..by_hand.n_params())
        .map(|k| 0.1 * k as f64 - 0.2)
        .collect();
    let (a, b) = (
        by_name.system(&theta).expect("a"),
        by_hand.system(&theta).expect("b"),
    );
    for (x, y) in [(&a.f, &b.f), (&a.h, &b.h), (&a.q, &b.q), (&a.r, &b.r)] {
        assert!((x - y).norm_max() == 0.0);
    }
    assert_eq!(a.x0, b.x0);
    // An entry outside its matrix is refused by the map, naming it.
    let spec = FreeSpec::parse(&["F[2,0]"]).expect("parses");
    match spec.map(cv(dt), Some(dt)) {
        Err(FitError::Parameters(m)) => assert!(m.contains("F[2,0]"), "{m}"),
        other => panic!("expected a refusal, got {other:?}"),
    }
}
