//! The refinement hook: rows added after verification are solved again on
//! the same split, a refusal moves the sweep on, and the pole control goes
//! through the same loop.

use rational_core::{
    Basis, Domain, ExtraConstraints, FitError, FitSettings, Fitter, IntervalData, RationalFunction,
    Refinement,
};
use std::sync::atomic::{AtomicUsize, Ordering};

/// `v = x` sampled on [0, 0.5], fitted over [0, 1].
fn half_line() -> (IntervalData, FitSettings) {
    let x: Vec<f64> = (0..60).map(|i| 0.5 * i as f64 / 59.0).collect();
    let data = IntervalData::from_values_absolute(1, x.clone(), x, 0.01).unwrap();
    let settings = FitSettings::default()
        .with_domain(Domain::new(vec![0.0], vec![1.0]).unwrap())
        .with_coeff_range(2, 12)
        .unwrap();
    (data, settings)
}

/// Requires `r(1) >= floor`, which the data alone do not imply: rows are
/// added only once a candidate misses it.
struct FloorAtOne {
    floor: f64,
    calls: AtomicUsize,
}

impl ExtraConstraints for FloorAtOne {
    fn rows(&self, _: &Basis, _: usize, _: usize) -> Vec<Vec<f64>> {
        Vec::new()
    }

    fn refine(&self, candidate: &RationalFunction, round: usize) -> Refinement {
        self.calls.fetch_add(1, Ordering::Relaxed);
        if candidate.eval(&[1.0]) >= self.floor * (1.0 - 1e-9) {
            return Refinement::Accept;
        }
        if round >= 3 {
            return Refinement::Reject {
                reason: "below the floor at 1".into(),
            };
        }
        let (n_p, n_q) = candidate.split();
        let mut phi = vec![0.0; candidate.basis().len()];
        candidate.basis().eval_into(&[1.0], &mut phi);
        // p(1) - floor q(1) >= 0.
        let row = phi[..n_p]
            .iter()
            .copied()
            .chain(phi[..n_q].iter().map(|v| -self.floor * v))
            .collect();
        Refinement::AddRows(vec![row])
    }
}

#[test]
fn added_rows_are_solved_on_the_same_split() {
    let (data, settings) = half_line();
    let plain = Fitter::new(&data).settings(settings.clone()).fit().unwrap();
    assert!(
        plain.function.eval(&[1.0]) < 1.5,
        "the data alone reach 1.5"
    );
    let floor = FloorAtOne {
        floor: 1.5,
        calls: AtomicUsize::new(0),
    };
    let report = Fitter::new(&data)
        .settings(settings)
        .constraints(&floor)
        .fit()
        .unwrap();
    assert!(report.verification.satisfied);
    assert!(report.function.eval(&[1.0]) >= 1.5 * (1.0 - 1e-6));
    let accepted = report
        .splits
        .iter()
        .find(|s| s.accepted && (s.n_p, s.n_q) == (report.n_p, report.n_q))
        .unwrap();
    assert!(accepted.refine_rounds >= 1, "{accepted:?}");
    assert!(floor.calls.load(Ordering::Relaxed) >= 2);
}

struct Never;

impl ExtraConstraints for Never {
    fn rows(&self, _: &Basis, _: usize, _: usize) -> Vec<Vec<f64>> {
        Vec::new()
    }

    fn refine(&self, _: &RationalFunction, _: usize) -> Refinement {
        Refinement::Reject {
            reason: "refused by the caller".into(),
        }
    }
}

#[test]
fn a_refusal_is_the_split_s_note_and_the_sweep_goes_on() {
    let (data, settings) = half_line();
    let e = Fitter::new(&data)
        .settings(settings)
        .constraints(&Never)
        .fit()
        .unwrap_err();
    let FitError::NoFeasibleFit { splits, .. } = e else {
        panic!("{e}")
    };
    assert!(splits.len() > 1, "the sweep went on after a refusal");
    assert!(splits.iter().all(|s| !s.accepted));
    assert!(splits.iter().any(|s| s.note == "refused by the caller"));
}
