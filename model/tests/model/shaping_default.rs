//! The provided `ShapingFilter::spectral_density`, N·|H(jω)|², for a filter that does not
//! override it (every built-in filter overrides it with a closed form, so a user's filter is
//! the only one that reaches it), and the shortest time constant that sets Δt.

use model::{
    ContinuousTf, DampedCosineShaping, ExponentialShaping, IrregularRollingShaping, ShapingFilter,
};

/// A user-defined filter: delegates everything but the spectral density to a built-in one.
struct Delegating<'a>(&'a dyn ShapingFilter);

impl ShapingFilter for Delegating<'_> {
    fn variance(&self) -> f64 {
        self.0.variance()
    }
    fn transfer_function(&self) -> ContinuousTf {
        self.0.transfer_function()
    }
    fn intensity(&self) -> f64 {
        self.0.intensity()
    }
    fn correlation(&self, tau: f64) -> f64 {
        self.0.correlation(tau)
    }
    fn shortest_time_constant(&self) -> f64 {
        self.0.shortest_time_constant()
    }
}

/// The provided density equals each built-in filter's closed form (an independent
/// expression in the correlation parameters) at DC, near the resonance and in the tail.
/// Both are a few flops from the same parameters: 1e-12 relative is rounding with margin.
#[test]
fn the_provided_spectral_density_matches_the_closed_forms() {
    let builtins: [&dyn ShapingFilter; 3] = [
        &ExponentialShaping::new(2.0, 1.5).expect("valid"),
        &IrregularRollingShaping::new(0.5, 0.3, 2.0).expect("valid"),
        &DampedCosineShaping::new(1.2, 0.4, 3.0).expect("valid"),
    ];
    for f in builtins {
        let user = Delegating(f);
        for w in [0.0, 0.7, 2.0, 3.0, 25.0] {
            let closed = f.spectral_density(w);
            assert!(closed > 0.0);
            assert!(
                (user.spectral_density(w) - closed).abs() <= 1e-12 * closed,
                "S({w}): {} vs {closed}",
                user.spectral_density(w)
            );
        }
    }
}

/// The shortest time constant is, by its definition, the smaller of the correlation's decay
/// time and its oscillation time (1/rate, 1/frequency). Parameters put each term on each side
/// of the minimum once, so a wrong operand or a max shows.
#[test]
fn shortest_time_constant_is_the_smaller_time_scale() {
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-15 * b;
    assert!(close(
        ExponentialShaping::new(1.0, 0.8)
            .expect("valid")
            .shortest_time_constant(),
        0.8
    ));
    for (rate, freq) in [(0.3_f64, 2.0_f64), (5.0, 0.25)] {
        let expected = (1.0 / rate).min(1.0 / freq);
        let rolling = IrregularRollingShaping::new(1.0, rate, freq).expect("valid");
        assert!(close(rolling.shortest_time_constant(), expected));
        let damped = DampedCosineShaping::new(1.0, rate, freq).expect("valid");
        assert!(close(damped.shortest_time_constant(), expected));
    }
}
