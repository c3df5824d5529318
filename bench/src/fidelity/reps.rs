//! The rational representations `bench fidelity` fits: the plain 2-D
//! slice, the 2-D perceptual fit, the 3-D perceptual fits by colour
//! mode, lobe and tolerance, and the fit `ratfit fit --target-de` returns.

use super::LobeChoice;
use anyhow::Result;
use brdf::fidelity::HemisphereSettings;
use brdf::{Brdf, ColourMode};
use std::sync::Arc;
use std::time::Instant;

/// The fit of `ratfit fit --target-de D --max-bytes B` as a representation.
#[derive(Clone, Copy)]
pub(super) struct TargetPlan {
    /// Mean CIEDE2000 asked for on the target's own validation renders.
    pub(super) de: f64,
    /// Byte budget of the fit returned.
    pub(super) max_bytes: Option<usize>,
    /// Seconds of fits and renders (`--time-budget`).
    pub(super) seconds: f64,
}

/// Settings of the representations measured.
pub(super) struct Plan {
    pub(super) perceptual_2d: bool,
    pub(super) modes: Vec<ColourMode>,
    pub(super) lobes: Vec<LobeChoice>,
    pub(super) values: Vec<brdf::ValueScale>,
    pub(super) phis: Vec<brdf::PhiCoordinate>,
    pub(super) tols: Vec<f64>,
    pub(super) resolution_3d: usize,
    pub(super) cut_3d: Option<f64>,
    pub(super) post_cuts: Vec<f64>,
    pub(super) max_coeffs: usize,
    pub(super) hemisphere: HemisphereSettings,
    pub(super) target: Option<TargetPlan>,
}

/// A representation's name, its fit and description (or why it failed),
/// and the fit time.
pub(super) struct Attempt {
    pub(super) name: String,
    pub(super) result: Result<(brdf::FittedBrdf, String)>,
    pub(super) fit_s: f64,
    /// Whether the benchmark also measures it evaluated within cuts and
    /// with shell factors (not for a fit whose evaluation is chosen already).
    pub(super) variants: bool,
}

impl Attempt {
    fn timed(name: String, start: Instant, result: Result<(brdf::FittedBrdf, String)>) -> Self {
        Attempt {
            name,
            result,
            fit_s: start.elapsed().as_secs_f64(),
            variants: true,
        }
    }
}

pub(super) fn rational_reps(table: &Arc<dyn Brdf>, plan: &Plan) -> Vec<Attempt> {
    let mut out = Vec::new();
    if let Some(target) = plan.target {
        let start = Instant::now();
        let r = fit_target(table, target, plan.max_coeffs);
        let within = target
            .max_bytes
            .map_or(String::new(), |b| format!(" within {b} B"));
        out.push(Attempt {
            variants: false,
            ..Attempt::timed(
                format!("rational target dE {}{within}", target.de),
                start,
                r,
            )
        });
    }
    let table = table.as_ref();
    // Today's former default for scenes: the 2-D slice at 20% inside the cuts.
    let start = Instant::now();
    let r = rational_mode::fit_plain_2d(table, 0.2, plan.max_coeffs);
    out.push(Attempt::timed("rational 2-D 20%".to_string(), start, r));
    if plan.perceptual_2d {
        let start = Instant::now();
        let t = plan.tols.iter().copied().fold(0.0, f64::max).min(0.08);
        let grid = rational_mode::Grid {
            dims: 2,
            resolution: 90,
            cut: None,
            phi: brdf::PhiCoordinate::Radians,
        };
        let shape = rational_mode::Shape {
            mode: ColourMode::Rgb,
            lobe: None,
            scale: brdf::ValueScale::Linear,
        };
        let r = rational_mode::fit_perceptual(table, grid, t, plan.max_coeffs, shape);
        out.push(Attempt::timed(
            format!("rational 2-D perceptual {}%", t * 100.0),
            start,
            r,
        ));
    }
    // The lobe is fitted once; its time counts in every fit that uses it.
    let lobe = plan.lobes.contains(&LobeChoice::Ggx).then(|| {
        let start = Instant::now();
        (brdf::Lobe::fit(table), start.elapsed().as_secs_f64())
    });
    let combinations = plan.tols.iter().flat_map(|&t| {
        plan.modes.iter().flat_map(move |&mode| {
            plan.lobes.iter().flat_map(move |&choice| {
                plan.values.iter().flat_map(move |&scale| {
                    (plan.phis.iter()).map(move |&phi| (t, mode, choice, scale, phi))
                })
            })
        })
    });
    for (t, mode, choice, scale, phi) in combinations {
        let start = Instant::now();
        let (with, lobe_s) = match (choice, &lobe) {
            (LobeChoice::Ggx, Some((l, s))) => (Some(*l), *s),
            _ => (None, 0.0),
        };
        let grid = rational_mode::Grid {
            dims: 3,
            resolution: plan.resolution_3d,
            cut: plan.cut_3d,
            phi,
        };
        let shape = rational_mode::Shape {
            mode,
            lobe: with,
            scale,
        };
        let r = rational_mode::fit_perceptual(table, grid, t, plan.max_coeffs, shape);
        let lobe_name = if with.is_some() { " x GGX lobe" } else { "" };
        let log_name = if scale.is_linear() {
            String::new()
        } else {
            format!(" {scale}")
        };
        let cut = plan.cut_3d.map_or(String::new(), |c| format!(" cut {c}"));
        let phi_name = match phi {
            brdf::PhiCoordinate::Cosine => " cos phi_d",
            _ => "",
        };
        let mut attempt = Attempt::timed(
            format!(
                "rational 3-D {mode}{log_name}{lobe_name}{phi_name} {}%{cut}",
                t * 100.0
            ),
            start,
            r,
        );
        attempt.fit_s += lobe_s;
        out.push(attempt);
    }
    out
}

/// The fit `ratfit fit FILE --target-de D [--max-bytes B]` returns (its
/// settings: luminance-chroma, perceptual intervals over the whole
/// hemisphere, the slice (also in RGB when the chroma ratios limit it)
/// and the 16^3 grid (24 x 16 x 8 where the table on 16^3 renders above
/// 3 times the target) in the order of `fit_to_target`, chosen on the
/// default validation renders, 96 x 96 with 256 sky samples), described by
/// its report.
fn fit_target(
    table: &Arc<dyn Brdf>,
    target: TargetPlan,
    max_coeffs: usize,
) -> Result<(brdf::FittedBrdf, String)> {
    use render_cpu::fidelity::{
        fit_to_target, target_settings, TargetBudget, TargetChoices, ValidationSettings,
    };
    let engine = rational_core::FitSettings::default()
        .with_coeff_range(2, max_coeffs)?
        .with_search(rational_core::Search::Staircase);
    let settings = target_settings(engine);
    let budget = TargetBudget::seconds(target.seconds).with_bytes(target.max_bytes);
    let (fitted, report) = fit_to_target(
        table.clone(),
        target.de,
        &settings,
        TargetChoices::default(),
        ValidationSettings::default(),
        budget,
    )?;
    let widened = report.widened;
    let note = format!(
        "{}-D {}{}{} +-{}%{}{}{}; {} on its own validation renders ({:.3}); {} fits tried",
        report.dims,
        report.colour,
        fitted.scale.suffix(),
        match (report.dims, report.grid_choice.and_then(|c| c.fine)) {
            (3, Some([h, d, p])) => format!(" on {h} x {d} x {p}"),
            _ => String::new(),
        },
        brdf::scale_text(report.rel_tol * 100.0),
        if widened > 1.0 {
            format!(" widened x{}", brdf::scale_text(widened))
        } else {
            String::new()
        },
        match (report.fitted_within, report.evaluation_cut) {
            (Some(c), _) => format!(", fitted within {c}"),
            (None, Some(c)) => format!(", evaluated within {c}"),
            (None, None) => String::new(),
        },
        report
            .shell_bytes
            .map_or(String::new(), |b| format!(" + shell {b} B")),
        if report.reached { "reached" } else { "missed" },
        report.scenes.iter().map(|s| s.mean_de).fold(0.0, f64::max),
        report.tried.len()
    );
    Ok((fitted, note))
}

/// The rational modes the benchmark fits, by name.
mod rational_mode {
    use anyhow::Result;
    use brdf::{
        fit_brdf, Brdf, BrdfFitSettings, ColourMode, FittedBrdf, PerceptualBounds, Reduction,
        ReductionKind,
    };
    use rational_core::{FitSettings, Search};

    /// The staircase search; perceptual intervals widen by sqrt 2 up to
    /// 16 times (as `ratfit fit --perceptual`), plain ones by 2.
    fn engine(max_coeffs: usize, perceptual: bool) -> Result<FitSettings> {
        let (factor, times) = if perceptual {
            (std::f64::consts::SQRT_2, 8)
        } else {
            (2.0, 4)
        };
        Ok(FitSettings::default()
            .with_coeff_range(2, max_coeffs)?
            .with_search(Search::Staircase)
            .with_widening(factor, times)?)
    }

    fn describe(fitted: &FittedBrdf, report: &brdf::BrdfFitReport) -> String {
        let widened: Vec<String> = report
            .channels
            .iter()
            .filter(|c| c.interval_scale > 1.0)
            .map(|c| format!("{} x{}", c.channel, brdf::scale_text(c.interval_scale)))
            .collect();
        let splits: Vec<String> = report
            .channels
            .iter()
            .map(|c| format!("({},{})", c.n_p, c.n_q))
            .collect();
        let verified = report.channels.iter().all(|c| c.verified);
        // The dense cap check's largest value over the cap left, per function.
        let caps: Vec<String> = report
            .channels
            .iter()
            .filter_map(|c| c.cap.map(|k| (c.channel, k)))
            .map(|(ch, k)| {
                if k.non_finite > 0 {
                    format!("{ch} {:.2} ({} not finite)", k.largest, k.non_finite)
                } else {
                    format!("{ch} {:.2}", k.largest)
                }
            })
            .collect();
        format!(
            "splits {}; {}{}",
            splits.join(" "),
            if verified { "verified" } else { "NOT verified" },
            if widened.is_empty() {
                String::new()
            } else {
                format!("; widened {}", widened.join(" "))
            }
        ) + &format!("; {} coefficients", fitted.coefficients())
            + &if caps.is_empty() {
                String::new()
            } else {
                format!("; over the cap x {}", caps.join(" "))
            }
    }

    /// The 2-D `phi_d = pi/2` slice with plain relative intervals inside the
    /// 78-degree grazing and 70-degree elevation cuts.
    pub fn fit_plain_2d(
        table: &dyn Brdf,
        rel_tol: f64,
        max_coeffs: usize,
    ) -> Result<(FittedBrdf, String)> {
        let settings = BrdfFitSettings::default()
            .with_rel_tol(rel_tol)?
            .with_baselines(false)
            .with_fit_settings(engine(max_coeffs, false)?);
        let (f, r) = fit_brdf(table, &settings)?;
        let d = describe(&f, &r);
        Ok((f, d))
    }

    /// Where a perceptual fit samples its table.
    #[derive(Clone, Copy)]
    pub struct Grid {
        /// 2 (the `phi_d = pi/2` slice) or 3.
        pub dims: usize,
        /// Bins per angle.
        pub resolution: usize,
        /// An elevation cut in degrees; `None`: the whole hemisphere.
        pub cut: Option<f64>,
        /// How `phi_d` enters a 3-D grid's coordinates.
        pub phi: brdf::PhiCoordinate,
    }

    /// What a perceptual fit's functions are.
    #[derive(Clone, Copy)]
    pub struct Shape {
        /// The colour mode.
        pub mode: ColourMode,
        /// The lobe they multiply, if any.
        pub lobe: Option<brdf::Lobe>,
        /// The scale of the functions that carry light.
        pub scale: brdf::ValueScale,
    }

    /// The 2-D slice or the full `(theta_h, theta_d, phi_d)` grid over the
    /// whole hemisphere (or within the grid's elevation cut) with
    /// perceptual intervals.
    pub fn fit_perceptual(
        table: &dyn Brdf,
        grid: Grid,
        rel_tol: f64,
        max_coeffs: usize,
        shape: Shape,
    ) -> Result<(FittedBrdf, String)> {
        let Grid {
            dims,
            resolution,
            cut,
            phi,
        } = grid;
        let kind = if dims == 3 {
            ReductionKind::Full3d
        } else {
            ReductionKind::Slice2d
        };
        let reduction = Reduction::default()
            .with_kind(kind)
            .with_resolution(resolution, resolution)
            .with_phi_resolution(resolution)
            .with_phi(phi)
            .whole_hemisphere();
        let reduction = match cut {
            Some(degrees) => reduction.with_max_elevation(degrees),
            None => reduction,
        };
        let settings = BrdfFitSettings::default()
            .with_reduction(reduction)
            .with_design(PerceptualBounds::default().with_rel_tol(rel_tol)?)
            .with_colour_mode(shape.mode)
            .with_lobe(shape.lobe)
            .with_value_scale(shape.scale)
            .with_baselines(false)
            .with_fit_settings(engine(max_coeffs, true)?);
        let (f, r) = fit_brdf(table, &settings)?;
        let d = describe(&f, &r);
        Ok((f, d))
    }
}
