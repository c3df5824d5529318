//! The point within a target fit's intervals that its renders prefer: each
//! function's least-squares fit within the intervals (the search's own,
//! `rational_core::FitSettings::with_centred_fit`) or its split's point of
//! largest margin.

use super::target_report::{PointChoice, TargetAttempt};
use super::target_search::{Goal, Measured};
use crate::RenderError;
use std::sync::Arc;

/// `best` or, when its functions at their largest-margin points render
/// closer on the worse scene, that fit: the least-squares point is nearer
/// the table on the samples, but the renders also see the function
/// between and beyond them. The other point is measured as `best` is
/// evaluated (its cut, and its shell layout fitted again to the other
/// functions): one validation. The choice keeps both errors.
pub(super) fn at_better_point(goal: &Goal, mut best: Measured) -> Result<Measured, RenderError> {
    let Some(other) = best.largest_margin.take() else {
        return Ok(best);
    };
    let material_error = |source| RenderError::Material {
        name: goal.table.name(),
        source,
    };
    let mut fitted = brdf::FittedBrdf {
        channels: other.channels,
        shell: None,
        ..best.fitted.clone()
    };
    if let Some(layout) = best.fitted.shell.as_ref().map(brdf::ShellFactor::layout) {
        let shell = brdf::ShellFactor::fit_layout(goal.table.as_ref(), &fitted, layout)
            .map_err(material_error)?;
        fitted = fitted.with_shell(shell).map_err(material_error)?;
    }
    let errors = goal
        .validator
        .measure(Arc::new(crate::scene::FitInDomain::new(fitted.clone())))?;
    let choice = PointChoice {
        least_squares: best.errors.worst_mean(),
        largest_margin: errors.worst_mean(),
    };
    if !choice.largest_margin_chosen() {
        best.point_choice = Some(choice);
        return Ok(best);
    }
    let attempt = TargetAttempt {
        result: Some((fitted.byte_size_f32(), choice.largest_margin)),
        ..best.attempt
    };
    Ok(Measured {
        fitted,
        errors,
        attempt,
        largest_margin: None,
        point_choice: Some(choice),
    })
}
