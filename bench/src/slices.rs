//! `ratfit plot`'s picture: theta_h slices of the data and of the fit at
//! several theta_d, on a log scale, as a PNG (the picture users check first).

use crate::chart::{colour, plot_error, write_png, FAMILY};
use anyhow::Result;
use brdf::{Brdf, HalfDiff};
use plotters::prelude::*;
use std::path::Path;

/// The theta_d of the slices drawn for `fitted`: 0, 20, 40 and 60 degrees
/// and its cut, those up to the cut.
pub fn theta_d_deg(fitted: &brdf::FittedBrdf) -> Vec<f64> {
    let cut = fitted.reduction.max_theta_d_deg;
    [0.0, 20.0, 40.0, 60.0, cut]
        .into_iter()
        .filter(|d| *d <= cut)
        .collect()
}

/// Values against `theta_h` (radians) on the slice `phi_d = pi/2`, `None`
/// where a direction is below the horizon or the value is not positive.
type Curve = Vec<(f64, Option<f64>)>;

/// `channel` of `data` and of `fit` on 401 values of `theta_h`, denser
/// towards the specular peak, for each theta_d of `theta_d_deg`.
fn slice_curves(
    data: &dyn Brdf,
    fit: &dyn Brdf,
    channel: usize,
    theta_d_deg: &[f64],
) -> Vec<(Curve, Curve)> {
    let value = |b: &dyn Brdf, th: f64, td: f64| {
        let (wi, wo) = HalfDiff {
            theta_h: th,
            phi_h: 0.0,
            theta_d: td,
            phi_d: std::f64::consts::FRAC_PI_2,
        }
        .to_directions();
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            return None;
        }
        let v = b.eval(wi, wo)[channel];
        (v > 0.0 && v.is_finite()).then_some(v)
    };
    let n = 400;
    let theta = |i: usize| (i as f64 / n as f64).powi(2) * std::f64::consts::FRAC_PI_2;
    let mut curves = Vec::new();
    for &td in theta_d_deg {
        let td = td.to_radians();
        let d: Curve = (0..=n)
            .map(|i| (theta(i), value(data, theta(i), td)))
            .collect();
        let f: Curve = (0..=n)
            .map(|i| (theta(i), value(fit, theta(i), td)))
            .collect();
        curves.push((d, f));
    }
    curves
}

/// Draws `channel` of `data` (dots) and `fit` (lines) against theta_h for
/// each theta_d in `theta_d_deg`, on the slice phi_d = pi/2.
pub fn draw(
    data: &dyn Brdf,
    fit: &dyn Brdf,
    channel: usize,
    theta_d_deg: &[f64],
    path: &Path,
) -> Result<()> {
    let curves = slice_curves(data, fit, channel, theta_d_deg);
    let all = curves
        .iter()
        .flat_map(|(d, f)| d.iter().chain(f.iter()).filter_map(|p| p.1));
    let (mut lo, mut hi) = (f64::INFINITY, 0.0_f64);
    for v in all {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !(lo.is_finite() && hi > 0.0) {
        anyhow::bail!("nothing positive to plot");
    }
    let (ylo, yhi) = (
        lo.log10().floor().max(hi.log10().ceil() - 8.0),
        hi.log10().ceil(),
    );
    let floor = 10f64.powf(ylo);
    write_png(path, (900, 560), |root| {
        root.fill(&WHITE).map_err(plot_error)?;
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!("channel {} at phi_d = 90 degrees", ["r", "g", "b"][channel]),
                (FAMILY, 15),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..90.0, (floor..10f64.powf(yhi)).log_scale())
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .x_desc("theta_h (degrees)")
            .y_desc("value")
            .x_label_formatter(&|v: &f64| format!("{v:.0}"))
            .y_label_formatter(&|v: &f64| format!("{v:e}"))
            .label_style((FAMILY, 12))
            .light_line_style(WHITE)
            .draw()
            .map_err(plot_error)?;
        for (k, (td, (d, f))) in theta_d_deg.iter().zip(&curves).enumerate() {
            let c = colour(k);
            // The fit as lines (broken where it has no value), the data as dots.
            let runs = f.split(|p| p.1.is_none()).filter(|r| r.len() > 1);
            for (i, run) in runs.enumerate() {
                let line = run
                    .iter()
                    .map(|p| (p.0.to_degrees(), p.1.unwrap_or(floor).max(floor)));
                let series = chart
                    .draw_series(LineSeries::new(line, c))
                    .map_err(plot_error)?;
                if i == 0 {
                    series
                        .label(format!("theta_d = {td:.0}"))
                        .legend(move |(x, y)| Circle::new((x + 8, y), 3, c.filled()));
                }
            }
            let dots = d.iter().step_by(4).filter_map(|p| p.1.map(|v| (p.0, v)));
            chart
                .draw_series(
                    dots.map(|(th, v)| Circle::new((th.to_degrees(), v.max(floor)), 2, c.filled())),
                )
                .map_err(plot_error)?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font((FAMILY, 12))
            .draw()
            .map_err(plot_error)
    })
}
