//! What [`super::fit_to_target`] spends and reports: the budget, each fit
//! tried, the table's own error on the fitted grid, and the report.

use super::{SceneError, ValidationScene};
use serde::Serialize;

/// One fit tried by [`super::fit_to_target`].
#[derive(Debug, Clone, Serialize)]
pub struct TargetAttempt {
    /// Fitting coordinates: 2 (the slice) or 3.
    pub dims: usize,
    /// The colour mode of its functions.
    pub colour: brdf::ColourMode,
    /// The scale of its functions.
    pub scale: brdf::ValueScale,
    /// Perceptual relative half-width.
    pub rel_tol: f64,
    /// Seconds from the start of its fit to the end of its validation
    /// renders. A search makes each fit but its first while the one
    /// before it is validated, so attempts overlap and their seconds add
    /// up to more than the search's.
    pub seconds: f64,
    /// Bytes (f32) and the worse mean CIEDE2000 of the two scenes; `None`
    /// when no fit within the coefficient budget meets these intervals.
    pub result: Option<(usize, f64)>,
    /// The largest factor a channel's intervals were widened by (1: none).
    pub widened: f64,
    /// The function (`Y`, `r`, `b` or `r`, `g`, `b`) that limited the fit:
    /// the first widened most, or with no fit at all; `None` when none was
    /// widened. It says whether the luminance or the colour costs most.
    pub limiting: Option<char>,
    /// The evaluation cut chosen for this fit by the validation renders
    /// (degrees; `None`: the whole hemisphere, or none tried when
    /// [`Self::over_budget`]). See
    /// [`super::choose_evaluation_cut`].
    pub cut: Option<f64>,
    /// Whether a shell factor beyond that cut was chosen with it.
    pub shell: bool,
    /// Whether its bytes pass the byte budget ([`TargetBudget::bytes`]), so
    /// that it could not be returned. Its functions alone pass it then, and
    /// it is measured as fitted: no evaluation cut or shell factor is tried.
    pub over_budget: bool,
    /// The elevation cut (degrees) the functions were fitted within;
    /// `None`: the whole hemisphere.
    pub fitted_within: Option<f64>,
    /// The coefficient budget per function, when the search raised it
    /// above the base settings' ([`super::TargetCoefficients::Auto`]);
    /// `None`: the base settings' budget.
    pub larger_budget: Option<usize>,
}

impl TargetAttempt {
    /// The raised coefficient budget as the report line names it.
    fn budget_text(&self) -> String {
        self.larger_budget.map_or(String::new(), |n| {
            format!(" with up to {n} coefficients per function")
        })
    }
}

impl std::fmt::Display for TargetAttempt {
    /// One line: the reduction, colour mode and tolerance, then the bytes
    /// and worse-scene error with the cut chosen, or the function with no
    /// fit; the seconds spent.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.result {
            Some((bytes, worst)) => write!(
                f,
                "tried {}-D {}{}{} +-{}%{}{}: {bytes} bytes{}, worse mean CIEDE2000 {worst:.3}{} ({:.1} s)",
                self.dims,
                self.colour,
                self.scale.suffix(),
                self.fitted_within
                    .map_or(String::new(), |c| format!(" within {c} degrees")),
                brdf::scale_text(self.rel_tol * 100.0),
                self.budget_text(),
                match (self.widened > 1.0, self.limiting) {
                    (true, Some(c)) =>
                        format!(" (widened x{}: {c})", brdf::scale_text(self.widened)),
                    (true, None) => format!(" (widened x{})", brdf::scale_text(self.widened)),
                    (false, _) => String::new(),
                },
                if self.over_budget {
                    " (over the byte budget)"
                } else {
                    ""
                },
                match (self.over_budget, self.cut) {
                    (true, _) => " as fitted (no evaluation cut or shell factor tried)".to_string(),
                    (false, Some(c)) => format!(
                        " evaluated within {c} degrees{}",
                        if self.shell { " with a shell factor" } else { "" }
                    ),
                    (false, None) => String::new(),
                },
                self.seconds
            ),
            None => write!(
                f,
                "tried {}-D {}{}{} +-{}%{}: no fit within the coefficient budget{} ({:.1} s)",
                self.dims,
                self.colour,
                self.scale.suffix(),
                self.fitted_within
                    .map_or(String::new(), |c| format!(" within {c} degrees")),
                brdf::scale_text(self.rel_tol * 100.0),
                self.budget_text(),
                self.limiting.map_or(String::new(), |c| format!(" for {c}")),
                self.seconds
            ),
        }
    }
}

/// What [`super::fit_to_target`] may spend.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TargetBudget {
    /// Seconds of fits and renders, checked between fits (the last fit
    /// and its validation may run past it). Past it no fit starts once one
    /// within the byte budget is in hand; until then the search goes on.
    pub seconds: f64,
    /// Bytes (f32) of the fit returned, its shell factor included; `None`:
    /// no limit. Fits that pass it are tried and reported, never returned.
    pub bytes: Option<usize>,
}

impl TargetBudget {
    /// `seconds` and no byte limit.
    pub fn seconds(seconds: f64) -> Self {
        TargetBudget {
            seconds,
            bytes: None,
        }
    }

    /// `self` with a byte limit.
    pub fn with_bytes(self, bytes: Option<usize>) -> Self {
        TargetBudget { bytes, ..self }
    }

    pub(super) fn passed_by(&self, bytes: usize) -> bool {
        self.bytes.is_some_and(|m| bytes > m)
    }
}

/// The table averaged over the cells of the grid a 3-D fit samples
/// ([`brdf::DownsampledTable`], interpolated between cell centres) and
/// rendered on the validation scenes: what that sampling alone loses. A
/// fit of those samples rarely renders much below it, so a target under it
/// asks for a finer grid (`theta_h` first) before tighter intervals.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct GridFloor {
    /// `theta_h`, `theta_d` and `phi_d` bins of the grid.
    pub bins: [usize; 3],
    /// The larger mean CIEDE2000 of the two scenes.
    pub worst_mean_de: f64,
}

/// The table seen through the 2-D slice ([`brdf::SliceView`]) within an
/// elevation cut, the table itself beyond, rendered on the validation
/// scenes: about the least a slice fit renders at. Above the target, the
/// slice is searched only after the 3-D fits, and only when their best
/// renders above it.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct SliceFloor {
    /// The elevation cut (degrees) within which the slice stands for the
    /// table.
    pub within_deg: f64,
    /// The larger mean CIEDE2000 of the two scenes.
    pub worst_mean_de: f64,
    /// Whether the slice's fits were searched.
    pub searched: bool,
    /// Whether its search, due after the 3-D fits, was left out because
    /// the time budget was spent with a fit in hand.
    pub left_for_time: bool,
}

/// The chosen fit's render error (worse scene) with each function at its
/// split's least-squares point within the intervals, the search's own
/// (`rational_core::FitSettings::with_centred_fit`), and at its point of
/// largest margin; the lower is returned.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct PointChoice {
    /// With the least-squares points.
    pub least_squares: f64,
    /// With the largest-margin points.
    pub largest_margin: f64,
}

impl PointChoice {
    /// Whether the largest-margin points were returned.
    pub fn largest_margin_chosen(&self) -> bool {
        self.largest_margin < self.least_squares
    }

    /// One line: the point returned and both errors.
    pub fn describe(&self) -> String {
        let (kept, other) = if self.largest_margin_chosen() {
            (
                "largest-margin points",
                "least-squares points within the intervals",
            )
        } else {
            (
                "least-squares points within the intervals",
                "largest-margin points",
            )
        };
        format!(
            "its functions at their {kept} (worse scene {:.3}; at their {other} {:.3})",
            self.largest_margin.min(self.least_squares),
            self.largest_margin.max(self.least_squares),
        )
    }
}

/// What [`super::fit_to_target`] reached.
#[derive(Debug, Clone, Serialize)]
pub struct TargetReport {
    /// The target: mean CIEDE2000 on both validation scenes.
    pub target_de: f64,
    /// Whether the chosen fit reaches it.
    pub reached: bool,
    /// Fitting coordinates of the chosen fit.
    pub dims: usize,
    /// The colour mode of the chosen fit.
    pub colour: brdf::ColourMode,
    /// The scale of its functions that carry light.
    pub scale: brdf::ValueScale,
    /// Why this reduction was chosen.
    pub why: String,
    /// The perceptual half-width of the chosen fit.
    pub rel_tol: f64,
    /// The largest factor a channel's intervals were widened by in the
    /// chosen fit (1: none).
    pub widened: f64,
    /// Bytes of the chosen fit (f32).
    pub bytes: usize,
    /// The byte budget the fit was chosen within; `None`: none.
    pub max_bytes: Option<usize>,
    /// The evaluation cut chosen by the validation renders for a fit over
    /// the whole hemisphere (degrees; `None`: none).
    pub evaluation_cut: Option<f64>,
    /// The elevation cut (degrees) the chosen fit's functions were fitted
    /// within; `None`: the whole hemisphere.
    pub fitted_within: Option<f64>,
    /// Bytes of the shell factor beyond that cut ([`brdf::ShellFactor`]),
    /// included in `bytes`, when the renders chose one.
    pub shell_bytes: Option<usize>,
    /// Its cells, when the renders chose one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shell_layout: Option<brdf::ShellLayout>,
    /// Its render errors, lights first.
    pub scenes: Vec<SceneError>,
    /// The table against itself with another seed (noise of the comparison).
    pub noise: Vec<SceneError>,
    /// When the target is not reached by a 3-D fit: what the table itself
    /// renders at on the grid that fit samples (see [`GridFloor`]).
    pub grid_floor: Option<GridFloor>,
    /// With [`super::TargetGrid::Auto`] and a 3-D base grid: what the table
    /// renders at on that grid, and the grid the 3-D fits sampled instead
    /// when that is far above the target.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grid_choice: Option<super::GridChoice>,
    /// With the reduction chosen by the search: what the table seen through
    /// the 2-D slice renders at, and whether the slice was searched (see
    /// [`SliceFloor`]).
    pub slice_floor: Option<SliceFloor>,
    /// When the target is not reached: the render error of the fit's
    /// luminance alone and of its colour alone ([`super::colour_split`]),
    /// which says which functions to improve.
    pub colour_split: Option<super::ColourSplit>,
    /// When a function of the chosen fit was centred: its render error
    /// with the least-squares and with the largest-margin points, the
    /// lower returned.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub point_choice: Option<PointChoice>,
    /// Every fit tried, in order.
    pub tried: Vec<TargetAttempt>,
    /// Total time in seconds (fits and renders).
    pub seconds: f64,
}

impl std::fmt::Display for TargetReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "target mean CIEDE2000 <= {}: {} with a {}-D {}{} fit, perceptual intervals of +-{}% ({} bytes{})",
            self.target_de,
            if self.reached {
                "reached"
            } else {
                "NOT reached; the closest fit within the budget"
            },
            self.dims,
            self.colour,
            self.scale.suffix(),
            brdf::scale_text(self.rel_tol * 100.0),
            self.bytes,
            self.max_bytes
                .map_or(String::new(), |m| format!(" of at most {m}"))
        )?;
        writeln!(f, "  {}", self.why)?;
        if let Some(c) = self.fitted_within {
            writeln!(
                f,
                "  fitted within {c} degrees of the normal (no coefficients spent beyond; directions beyond are evaluated at the cut)"
            )?;
        } else if let Some(c) = self.evaluation_cut {
            writeln!(
                f,
                "  evaluated within {c} degrees of the normal (directions beyond moved onto the cut; chosen by the validation renders)"
            )?;
        }
        if let (Some(b), Some(layout)) = (self.shell_bytes, self.shell_layout) {
            let what = match layout.colour {
                brdf::ShellColour::Luminance => "the table's luminance",
                brdf::ShellColour::PerFunction => "the table's energy in each RGB channel",
            };
            writeln!(
                f,
                "  beyond the cut, a shell factor of {b} bytes ({}) scales the fit to {what}, cell by cell of theta_h x theta_d (chosen by the validation renders)",
                layout.describe()
            )?;
        }
        for (k, scene) in ValidationScene::ALL.iter().enumerate() {
            writeln!(
                f,
                "  {:<6} mean CIEDE2000 {:.3}, p99 {:.2} (table against itself: {:.3})",
                scene.name(),
                self.scenes[k].mean_de,
                self.scenes[k].p99_de,
                self.noise[k].mean_de
            )?;
        }
        if let Some(choice) = self.grid_choice.filter(|c| c.fine.is_some()) {
            writeln!(f, "  {}", choice.describe(self.target_de))?;
        }
        if let Some(g) = self.grid_floor {
            let [h, d, p] = g.bins;
            writeln!(
                f,
                "  the table itself, averaged over the {h} x {d} x {p} grid the fit samples, renders at {:.3} (worse scene){}",
                g.worst_mean_de,
                if g.worst_mean_de > self.target_de {
                    ": the target needs a finer grid (theta_h first)"
                } else {
                    ""
                }
            )?;
        }
        if let Some(floor) = self.slice_floor {
            writeln!(
                f,
                "  the table seen through the 2-D slice within {} degrees (the table beyond) renders at {:.3} (worse scene): {}",
                floor.within_deg,
                floor.worst_mean_de,
                match (floor.worst_mean_de <= self.target_de, floor.searched, floor.left_for_time) {
                    (true, _, _) => "the slice was searched first",
                    (false, true, _) => "above the target, so the slice was searched after the 3-D fits, whose best rendered above it",
                    (false, false, true) => "above the target, so the slice was due after the 3-D fits, whose best rendered above it, but the time budget was spent",
                    (false, false, false) => "above the target and the 3-D fits' best, so no slice fit was tried",
                }
            )?;
        }
        if let Some(split) = &self.colour_split {
            writeln!(f, "  {}", split.describe("the fit"))?;
        }
        if let Some(p) = self.point_choice {
            writeln!(f, "  {}", p.describe())?;
        }
        for a in &self.tried {
            writeln!(f, "  {a}")?;
        }
        write!(f, "  {:.1} s", self.seconds)
    }
}
