//! Seeded and deterministic for any thread count; typed errors for bad models and options.

use kalman::Error;
use kalman::particle::{
    History, ParticleFilter, ParticleModel, ParticleOptions, ParticleRng, Proposal, Resampling,
    Trigger, ffbsi,
};

use super::common::{MODEL, record};

/// Everything a run produces, to compare bit for bit.
fn run(options: ParticleOptions, zs: &[f64]) -> (Vec<u64>, Vec<u64>) {
    let mut pf = ParticleFilter::new(MODEL, options).expect("valid options");
    let mut out = Vec::new();
    for z in zs {
        pf.step(&[*z]).expect("finite model");
        out.push(pf.mean()[0].to_bits());
        out.push(pf.log_likelihood().to_bits());
    }
    out.extend(pf.particles().iter().map(|x| x.to_bits()));
    out.extend(pf.log_weights().iter().map(|x| x.to_bits()));
    let smoothed = ffbsi(&MODEL, pf.history().expect("kept"), 40, 9).expect("a density");
    let paths = (0..40)
        .flat_map(|j| smoothed.path(j).expect("j < M").to_vec())
        .map(f64::to_bits)
        .collect();
    (out, paths)
}

#[test]
fn same_seed_same_bits_for_any_thread_count() {
    // 1000 particles are 16 blocks, so two or three threads split them differently; the
    // random streams and the reductions must not notice.
    let zs = record(&MODEL, 15, 21);
    for (proposal, resampling) in [
        (Proposal::Bootstrap, Resampling::Systematic),
        (Proposal::Auxiliary, Resampling::Multinomial),
    ] {
        let options = ParticleOptions {
            particles: 1000,
            proposal,
            resampling,
            seed: 99,
            history: History::Keep,
            ..ParticleOptions::default()
        };
        let runs: Vec<_> = [1, 2, 3]
            .into_iter()
            .map(|threads| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .expect("a pool");
                pool.install(|| run(options, &zs))
            })
            .collect();
        assert!(
            runs[0] == runs[1] && runs[1] == runs[2],
            "{proposal:?}: results depend on the thread count"
        );
        assert!(
            run(options, &zs) == runs[0],
            "{proposal:?}: not reproducible"
        );
        let other = run(
            ParticleOptions {
                seed: 100,
                ..options
            },
            &zs,
        );
        assert!(other.0 != runs[0].0, "{proposal:?}: the seed is not used");
    }
}

/// A model whose functions misbehave on demand.
struct Broken {
    transition: f64,
    likelihood: f64,
}

impl ParticleModel for Broken {
    fn state_dim(&self) -> usize {
        1
    }
    fn sample_initial(&self, _rng: &mut ParticleRng, x: &mut [f64]) {
        x[0] = 0.0;
    }
    fn sample_transition(&self, _k: usize, x: &[f64], _rng: &mut ParticleRng, next: &mut [f64]) {
        next[0] = x[0] + self.transition;
    }
    fn log_likelihood(&self, _k: usize, _x: &[f64], _z: &[f64]) -> f64 {
        self.likelihood
    }
}

#[test]
fn bad_models_and_options_are_typed_errors() {
    let options = ParticleOptions {
        particles: 100,
        history: History::Keep,
        ..ParticleOptions::default()
    };
    let ok = |t, l| {
        ParticleFilter::new(
            Broken {
                transition: t,
                likelihood: l,
            },
            options,
        )
        .expect("valid options")
    };
    let mut pf = ok(f64::NAN, 0.0);
    pf.step(&[1.0]).expect("step 0 does not propagate");
    let e = pf.step(&[1.0]);
    assert!(
        matches!(
            e,
            Err(Error::ModelNonFinite {
                function: "sample_transition",
                step: 1,
                index: 0
            })
        ),
        "{e:?}"
    );
    assert_eq!(pf.steps(), 1, "a failed step leaves the filter as it was");
    let e = ok(0.0, f64::NAN).step(&[1.0]);
    assert!(
        matches!(
            e,
            Err(Error::ModelNonFinite {
                function: "log_likelihood",
                step: 0,
                ..
            })
        ),
        "{e:?}"
    );
    let e = ok(0.0, f64::NEG_INFINITY).step(&[1.0]);
    assert!(
        matches!(e, Err(Error::ParticleCollapse { step: 0, .. })),
        "{e:?}"
    );
    // A missing measurement is not weighted, so an impossible likelihood does not matter.
    ok(0.0, f64::NEG_INFINITY)
        .step(&[f64::NAN])
        .expect("no measurement");
    let mut pf = ParticleFilter::new(
        Broken {
            transition: 0.0,
            likelihood: 0.0,
        },
        ParticleOptions {
            proposal: Proposal::Auxiliary,
            ..options
        },
    )
    .expect("valid options");
    pf.step(&[0.0]).expect("step 0 has no first stage");
    let e = pf.step(&[0.0]);
    assert!(
        matches!(
            e,
            Err(Error::MissingFunction {
                function: "lookahead",
                ..
            })
        ),
        "{e:?}"
    );
    let e = ffbsi(pf.model(), pf.history().expect("kept"), 10, 0);
    assert!(
        matches!(
            e,
            Err(Error::MissingFunction {
                function: "log_transition_density",
                ..
            })
        ),
        "{e:?}"
    );
    let e = ffbsi(pf.model(), pf.history().expect("kept"), 0, 0);
    assert!(
        matches!(
            e,
            Err(Error::Dimension {
                name: "trajectories",
                ..
            })
        ),
        "{e:?}"
    );
    for (bad, name) in [
        (
            ParticleOptions {
                particles: 0,
                ..options
            },
            "particles",
        ),
        (
            ParticleOptions {
                trigger: Trigger::EssBelow(0.0),
                ..options
            },
            "Trigger::EssBelow",
        ),
        (
            ParticleOptions {
                trigger: Trigger::EssBelow(f64::NAN),
                ..options
            },
            "Trigger::EssBelow",
        ),
    ] {
        let e = ParticleFilter::new(MODEL, bad);
        let named = matches!(&e, Err(Error::Dimension { name: n, .. }) | Err(Error::InvalidOption { name: n, .. }) if *n == name);
        assert!(named, "{name}: {e:?}");
    }
}
