//! Interval data proved to have no fit within a budget, and the data it
//! covers: the same points with every interval inside.

use crate::settings::Search;
use crate::{Backend, BasisFamily, Domain, FitSettings, IntervalData, PoleControl, SolveOptions};
use crate::{FitError, FitReport, SplitSummary};

/// Interval data with no rational fit of a budget within `min..=max`
/// coefficients under given settings, proved by a search that visits every
/// split of those budgets, in which every split solved was refused with a
/// certificate of infeasibility ([`SplitSummary::proved_infeasible`]; the
/// staircase's unsolved splits follow from those by nesting).
///
/// Narrower intervals at the same points shrink every split's feasible
/// set, so data whose intervals all lie within the proof's has no fit
/// either ([`NoFitProof::covers`]); [`crate::Fitter::no_fit_proofs`] skips
/// every widening level a proof covers, without solving anything, and the
/// sweep returns what it would have without them.
///
/// ```
/// use rational_core::{FitError, FitSettings, Fitter, IntervalData, NoFitProof, Search};
///
/// // |x| within 0.1% at 400 points: beyond 6 coefficients in any split.
/// let x: Vec<f64> = (0..400).map(|i| -1.0 + 2.0 * i as f64 / 399.0).collect();
/// let v: Vec<f64> = x.iter().map(|x| x.abs() + 0.1).collect();
/// let data = IntervalData::from_values_relative(1, x.clone(), v.clone(), 1e-3)?;
/// let settings = FitSettings::default()
///     .with_search(Search::Staircase)
///     .with_coeff_range(2, 6)?;
/// let result = Fitter::new(&data).settings(settings.clone()).fit();
/// let proof = NoFitProof::from_sweep(&data, &settings, &result).expect("refused with certificates");
/// // Half the width at the same points: proved without a solve.
/// let narrower = IntervalData::from_values_relative(1, x, v, 5e-4)?;
/// assert!(proof.covers(&narrower, &settings));
/// let again = Fitter::new(&narrower).settings(settings).no_fit_proofs(&[proof]).fit();
/// assert!(matches!(again, Err(FitError::NoFeasibleFit { ref splits, .. }) if splits.is_empty()));
/// # Ok::<(), FitError>(())
/// ```
#[derive(Debug, Clone)]
pub struct NoFitProof {
    data: IntervalData,
    engine: Engine,
    min_coeffs: usize,
    max_coeffs: usize,
}

/// What of the settings, besides the budgets, decides which splits are
/// feasible.
#[derive(Debug, Clone, PartialEq)]
struct Engine {
    family: BasisFamily,
    degree_weights: Option<Vec<u16>>,
    domain: Option<Domain>,
    backend: Backend,
    solve_options: SolveOptions,
    pole_control: PoleControl,
    value_scaling: bool,
}

impl Engine {
    fn of(s: &FitSettings) -> Self {
        Self {
            family: s.family,
            degree_weights: s.degree_weights.clone(),
            domain: s.domain.clone(),
            backend: s.backend,
            solve_options: s.solve_options.clone(),
            pole_control: s.pole_control,
            value_scaling: s.value_scaling,
        }
    }
}

impl NoFitProof {
    /// The proof that a sweep of `data` with `settings` gives, from its
    /// result: the widest widening level below the accepted one (every
    /// level when there is no fit) at which splits were solved and all were
    /// refused with certificates. `None` when there is none, or when the
    /// settings' search does not visit every split of its budgets
    /// ([`Search::Probe`] judges a budget by a few).
    pub fn from_sweep(
        data: &IntervalData,
        settings: &FitSettings,
        result: &Result<FitReport, FitError>,
    ) -> Option<Self> {
        if settings.search == Search::Probe {
            return None;
        }
        let (splits, unfitted): (&[SplitSummary], usize) = match result {
            Ok(r) => (&r.splits, r.widenings),
            Err(FitError::NoFeasibleFit {
                splits, widenings, ..
            }) => (splits, widenings + 1),
            Err(_) => return None,
        };
        let proved = |level: usize| {
            let mut at = splits.iter().filter(|s| s.widenings == level).peekable();
            at.peek().is_some() && at.all(SplitSummary::proved_infeasible)
        };
        let level = (0..unfitted).rev().find(|&k| proved(k))?;
        let mut widest = data.clone();
        for _ in 0..level {
            widest = widest.widened(settings.widen_factor);
        }
        Some(Self {
            data: widest,
            engine: Engine::of(settings),
            min_coeffs: settings.min_coeffs,
            max_coeffs: settings.max_coeffs,
        })
    }

    /// Whether this proves that `data` has no fit under `settings`: the
    /// same points, every interval within the proof's, budgets within its
    /// budgets, and the same basis, domain, backend, solver options, pole
    /// control and value scaling. Extra constraint rows are not compared:
    /// a proof holds for sweeps with the extra constraints of the sweep
    /// that gave it.
    pub fn covers(&self, data: &IntervalData, settings: &FitSettings) -> bool {
        self.covers_parts(
            data,
            &Engine::of(settings),
            (settings.min_coeffs, settings.max_coeffs),
        )
    }

    /// Whether this proof implies `other` (it covers `other`'s data with
    /// `other`'s settings).
    pub fn covers_proof(&self, other: &NoFitProof) -> bool {
        self.covers_parts(
            &other.data,
            &other.engine,
            (other.min_coeffs, other.max_coeffs),
        )
    }

    fn covers_parts(
        &self,
        data: &IntervalData,
        engine: &Engine,
        (min, max): (usize, usize),
    ) -> bool {
        min >= self.min_coeffs
            && max <= self.max_coeffs
            && data.dim() == self.data.dim()
            && data.points() == self.data.points()
            && *engine == self.engine
            && (data.lo().iter().zip(self.data.lo())).all(|(a, b)| a >= b)
            && (data.hi().iter().zip(self.data.hi())).all(|(a, b)| a <= b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Fitter, Search};

    /// `|x| + 0.1` at 300 points within `tol`: its kink keeps small
    /// rational functions out of narrow intervals.
    fn kink(tol: f64) -> IntervalData {
        let x: Vec<f64> = (0..300).map(|i| -1.0 + 2.0 * i as f64 / 299.0).collect();
        let v: Vec<f64> = x.iter().map(|x| x.abs() + 0.1).collect();
        IntervalData::from_values_relative(1, x, v, tol).unwrap()
    }

    fn settings() -> FitSettings {
        FitSettings::default()
            .with_search(Search::Staircase)
            .with_coeff_range(2, 8)
            .unwrap()
            .with_widening(2.0, 6)
            .unwrap()
    }

    #[test]
    fn a_covered_sweep_returns_what_it_would_without_solving_the_covered_levels() {
        let s = settings();
        let wide = kink(0.01);
        let proof =
            NoFitProof::from_sweep(&wide, &s, &Fitter::new(&wide).settings(s.clone()).fit())
                .expect("the first levels are refused with certificates");
        let narrow = kink(0.005);
        let plain = Fitter::new(&narrow).settings(s.clone()).fit().unwrap();
        assert!(plain.widenings >= 1, "the narrow data needs widening");
        let proofs = [proof];
        let skipped = Fitter::new(&narrow)
            .settings(s)
            .no_fit_proofs(&proofs)
            .fit()
            .unwrap();
        assert_eq!(skipped.widenings, plain.widenings);
        assert_eq!((skipped.n_p, skipped.n_q), (plain.n_p, plain.n_q));
        assert_eq!(skipped.function, plain.function);
        assert!(
            skipped.splits.len() < plain.splits.len(),
            "{} splits with the proof, {} without",
            skipped.splits.len(),
            plain.splits.len()
        );
        assert!(skipped.splits.iter().all(|x| x.widenings > 0));
    }

    #[test]
    fn a_proof_covers_only_narrower_intervals_at_its_points_and_settings() {
        let s = settings().with_widening(2.0, 0).unwrap();
        let data = kink(0.01);
        let result = Fitter::new(&data).settings(s.clone()).fit();
        assert!(result.is_err(), "no fit within 8 coefficients at 1%");
        let proof = NoFitProof::from_sweep(&data, &s, &result).unwrap();
        assert!(proof.covers(&data, &s));
        assert!(proof.covers(&kink(0.002), &s));
        assert!(!proof.covers(&kink(0.02), &s), "wider intervals");
        let more = s.clone().with_coeff_range(2, 9).unwrap();
        assert!(!proof.covers(&data, &more), "a larger budget");
        let legendre = s.clone().with_family(crate::BasisFamily::Legendre);
        assert!(!proof.covers(&data, &legendre), "another basis");
        let x: Vec<f64> = (0..300).map(|i| -1.0 + 2.0 * i as f64 / 300.0).collect();
        let v: Vec<f64> = x.iter().map(|x| x.abs() + 0.1).collect();
        let moved = IntervalData::from_values_relative(1, x, v, 0.001).unwrap();
        assert!(!proof.covers(&moved, &s), "other points");
        // A search that judges a budget by a few splits proves nothing.
        let probe = s.clone().with_search(Search::Probe);
        let probed = Fitter::new(&data).settings(probe.clone()).fit();
        assert!(NoFitProof::from_sweep(&data, &probe, &probed).is_none());
    }
}
