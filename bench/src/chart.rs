//! Log-log scatter charts in panels (one panel per instance, one series per
//! backend, the Pareto front marked), as SVG and PNG from one description.

use crate::canvas::{text_width, Canvas};
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::Path;

/// Colours of the series, in legend order.
pub const PALETTE: [[f64; 3]; 8] = [
    [0.84, 0.15, 0.16],
    [0.12, 0.47, 0.71],
    [0.17, 0.63, 0.17],
    [1.0, 0.5, 0.05],
    [0.58, 0.4, 0.74],
    [0.55, 0.34, 0.29],
    [0.89, 0.47, 0.76],
    [0.5, 0.5, 0.5],
];

/// One panel: points per series (index into the figure's legend).
#[derive(Debug, Clone, Default)]
pub struct Panel {
    /// Title drawn above the panel.
    pub title: String,
    /// `(series, x, y)`; points with a non-positive or non-finite
    /// coordinate cannot go on log axes and are left out.
    pub points: Vec<(usize, f64, f64)>,
    /// Points that are on the Pareto front, drawn ringed and joined.
    pub front: Vec<(f64, f64)>,
}

/// A figure: panels sharing axis labels and a legend.
#[derive(Debug, Clone, Default)]
pub struct Figure {
    /// Title of the whole figure.
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Label of the y axis.
    pub y_label: String,
    /// Series names; series `k` is drawn in `PALETTE[k % 8]`.
    pub legend: Vec<String>,
    /// The panels, laid out in rows of `columns`.
    pub panels: Vec<Panel>,
    /// Panels per row.
    pub columns: usize,
}

/// The points on the Pareto front of `(time, error)` pairs: none faster with
/// an error as small. Sorted by time.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut sorted: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut front: Vec<(f64, f64)> = Vec::new();
    for p in sorted {
        // Equal errors up to solver rounding (the same point from two
        // backends) do not extend the front.
        if front.last().is_none_or(|last| p.1 < last.1 * (1.0 - 1e-6)) {
            front.push(p);
        }
    }
    front
}

fn usable(x: f64, y: f64) -> bool {
    x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite()
}

/// Whole decades enclosing the positive finite values (at least one decade).
fn decades(values: impl Iterator<Item = f64>) -> (i32, i32) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| *v > 0.0 && v.is_finite()) {
        lo = lo.min(v.log10());
        hi = hi.max(v.log10());
    }
    if !lo.is_finite() {
        return (0, 1);
    }
    let (a, b) = (lo.floor() as i32, hi.ceil() as i32);
    (a, b.max(a + 1))
}

const PANEL_W: f64 = 380.0;
const PANEL_H: f64 = 280.0;
const MARGIN: (f64, f64, f64, f64) = (62.0, 14.0, 30.0, 40.0); // left, right, top, bottom
const HEADER: f64 = 56.0;

struct Layout {
    width: f64,
    height: f64,
}

impl Figure {
    /// Whether a panel marks a Pareto front (the legend names it then).
    fn has_front(&self) -> bool {
        self.panels.iter().any(|p| !p.front.is_empty())
    }

    fn layout(&self) -> Layout {
        let cols = self.columns.max(1).min(self.panels.len().max(1));
        let rows = self.panels.len().div_ceil(cols).max(1);
        Layout {
            width: cols as f64 * PANEL_W,
            height: HEADER + rows as f64 * PANEL_H,
        }
    }

    fn origin(&self, k: usize) -> (f64, f64) {
        let cols = self.columns.max(1).min(self.panels.len().max(1));
        (
            (k % cols) as f64 * PANEL_W,
            HEADER + (k / cols) as f64 * PANEL_H,
        )
    }

    /// Scales of panel `k`: decade ranges and the maps to pixels.
    fn scales(&self, k: usize) -> Scales {
        let p = &self.panels[k];
        let pts = p.points.iter().filter(|(_, x, y)| usable(*x, *y));
        let xd = decades(pts.clone().map(|(_, x, _)| *x));
        let yd = decades(pts.map(|(_, _, y)| *y));
        let (ox, oy) = self.origin(k);
        Scales {
            xd,
            yd,
            left: ox + MARGIN.0,
            right: ox + PANEL_W - MARGIN.1,
            top: oy + MARGIN.2,
            bottom: oy + PANEL_H - MARGIN.3,
        }
    }

    /// The figure as SVG.
    pub fn svg(&self) -> String {
        let l = self.layout();
        let mut s = String::new();
        let _ = writeln!(
            s,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>",
            l.width, l.height
        );
        let _ = writeln!(
            s,
            "<text x=\"10\" y=\"18\" font-size=\"14\">{}</text>",
            escape(&self.title)
        );
        let mut x = 10.0;
        for (k, name) in self.legend.iter().enumerate() {
            let _ = writeln!(
                s,
                "<circle cx=\"{}\" cy=\"36\" r=\"4\" fill=\"{}\"/><text x=\"{}\" y=\"40\">{}</text>",
                x + 4.0,
                hex(PALETTE[k % PALETTE.len()]),
                x + 12.0,
                escape(name)
            );
            x += 24.0 + 7.0 * name.len() as f64;
        }
        if self.has_front() {
            let _ = writeln!(
                s,
                "<text x=\"{}\" y=\"40\">black rings and line: Pareto front</text>",
                x + 10.0
            );
        }
        for (k, p) in self.panels.iter().enumerate() {
            let sc = self.scales(k);
            let _ = writeln!(
                s,
                "<text x=\"{}\" y=\"{}\" font-size=\"12\">{}</text>",
                sc.left,
                sc.top - 10.0,
                escape(&p.title)
            );
            if !p.points.iter().any(|(_, x, y)| usable(*x, *y)) {
                let _ = writeln!(
                    s,
                    "<text x=\"{:.1}\" y=\"{:.1}\">no points</text>",
                    sc.left + 20.0,
                    0.5 * (sc.top + sc.bottom)
                );
            }
            for e in sc.xd.0..=sc.xd.1 {
                let px = sc.x(10f64.powi(e));
                let _ = writeln!(s, "<line x1=\"{px:.1}\" y1=\"{:.1}\" x2=\"{px:.1}\" y2=\"{:.1}\" stroke=\"#ddd\"/><text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">1e{e}</text>", sc.top, sc.bottom, px, sc.bottom + 14.0);
            }
            for e in sc.yd.0..=sc.yd.1 {
                let py = sc.y(10f64.powi(e));
                let _ = writeln!(s, "<line x1=\"{:.1}\" y1=\"{py:.1}\" x2=\"{:.1}\" y2=\"{py:.1}\" stroke=\"#ddd\"/><text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">1e{e}</text>", sc.left, sc.right, sc.left - 4.0, py + 4.0);
            }
            let _ = writeln!(
                s,
                "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"none\" stroke=\"black\"/>",
                sc.left,
                sc.top,
                sc.right - sc.left,
                sc.bottom - sc.top
            );
            let _ = writeln!(
                s,
                "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>",
                0.5 * (sc.left + sc.right),
                sc.bottom + 30.0,
                escape(&self.x_label)
            );
            let (cx, cy) = (sc.left - 48.0, 0.5 * (sc.top + sc.bottom));
            let _ = writeln!(
                s,
                "<text x=\"{cx:.1}\" y=\"{cy:.1}\" text-anchor=\"middle\" transform=\"rotate(-90 {cx:.1} {cy:.1})\">{}</text>",
                escape(&self.y_label)
            );
            let front = sc.front_pixels(p);
            if front.len() > 1 {
                let path: Vec<String> = front
                    .iter()
                    .map(|(x, y)| format!("{x:.1},{y:.1}"))
                    .collect();
                let _ = writeln!(
                    s,
                    "<polyline points=\"{}\" fill=\"none\" stroke=\"black\" stroke-dasharray=\"3,2\"/>",
                    path.join(" ")
                );
            }
            for &(series, x, y) in p.points.iter().filter(|(_, x, y)| usable(*x, *y)) {
                let _ = writeln!(
                    s,
                    "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"3.5\" fill=\"{}\" fill-opacity=\"0.8\"/>",
                    sc.x(x),
                    sc.y(y),
                    hex(PALETTE[series % PALETTE.len()])
                );
            }
            for (x, y) in front {
                let _ = writeln!(
                    s,
                    "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"6\" fill=\"none\" stroke=\"black\"/>"
                );
            }
        }
        s.push_str("</svg>\n");
        s
    }

    /// The figure as PNG.
    pub fn png(&self, path: &Path) -> Result<()> {
        let l = self.layout();
        let mut c = Canvas::new(l.width as usize, l.height as usize, [1.0; 3]);
        let (black, grey) = ([0.0; 3], [0.86; 3]);
        c.text(10, 8, &self.title, 2, black);
        let mut x = 10i64;
        for (k, name) in self.legend.iter().enumerate() {
            c.dot(x as f64 + 4.0, 37.0, 3, PALETTE[k % PALETTE.len()]);
            c.text(x + 12, 33, name, 2, black);
            x += 28 + text_width(name, 2);
        }
        if self.has_front() {
            c.ring(x as f64 + 4.0, 37.0, 5, black);
            c.text(x + 14, 33, "PARETO FRONT", 2, black);
        }
        for (k, p) in self.panels.iter().enumerate() {
            let sc = self.scales(k);
            c.text(sc.left as i64, sc.top as i64 - 16, &p.title, 2, black);
            if !p.points.iter().any(|(_, x, y)| usable(*x, *y)) {
                c.text(
                    sc.left as i64 + 20,
                    (0.5 * (sc.top + sc.bottom)) as i64,
                    "NO POINTS",
                    2,
                    black,
                );
            }
            for e in sc.xd.0..=sc.xd.1 {
                let px = sc.x(10f64.powi(e));
                c.line((px, sc.top), (px, sc.bottom), grey);
                let label = format!("1e{e}");
                c.text(
                    px as i64 - text_width(&label, 2) / 2,
                    sc.bottom as i64 + 6,
                    &label,
                    2,
                    black,
                );
            }
            for e in sc.yd.0..=sc.yd.1 {
                let py = sc.y(10f64.powi(e));
                c.line((sc.left, py), (sc.right, py), grey);
                let label = format!("1e{e}");
                c.text(
                    sc.left as i64 - 4 - text_width(&label, 2),
                    py as i64 - 5,
                    &label,
                    2,
                    black,
                );
            }
            for (a, b) in [
                ((sc.left, sc.top), (sc.right, sc.top)),
                ((sc.left, sc.bottom), (sc.right, sc.bottom)),
                ((sc.left, sc.top), (sc.left, sc.bottom)),
                ((sc.right, sc.top), (sc.right, sc.bottom)),
            ] {
                c.line(a, b, black);
            }
            c.text(
                (0.5 * (sc.left + sc.right)) as i64 - text_width(&self.x_label, 2) / 2,
                sc.bottom as i64 + 22,
                &self.x_label,
                2,
                black,
            );
            let front = sc.front_pixels(p);
            for w in front.windows(2) {
                c.line(w[0], w[1], black);
            }
            for &(series, x, y) in p.points.iter().filter(|(_, x, y)| usable(*x, *y)) {
                c.dot(sc.x(x), sc.y(y), 2, PALETTE[series % PALETTE.len()]);
            }
            for (x, y) in front {
                c.ring(x, y, 5, black);
            }
        }
        c.save_png(path)
            .with_context(|| format!("cannot write {}", path.display()))
    }
}

struct Scales {
    xd: (i32, i32),
    yd: (i32, i32),
    left: f64,
    right: f64,
    top: f64,
    bottom: f64,
}

impl Scales {
    /// The panel's front in pixels, left out points that log axes cannot show.
    fn front_pixels(&self, p: &Panel) -> Vec<(f64, f64)> {
        p.front
            .iter()
            .filter(|(x, y)| usable(*x, *y))
            .map(|&(x, y)| (self.x(x), self.y(y)))
            .collect()
    }

    fn x(&self, v: f64) -> f64 {
        let t = (v.log10() - self.xd.0 as f64) / (self.xd.1 - self.xd.0) as f64;
        self.left + t * (self.right - self.left)
    }

    fn y(&self, v: f64) -> f64 {
        let t = (v.log10() - self.yd.0 as f64) / (self.yd.1 - self.yd.0) as f64;
        self.bottom - t * (self.bottom - self.top)
    }
}

fn hex(c: [f64; 3]) -> String {
    let b = c.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8);
    format!("#{:02x}{:02x}{:02x}", b[0], b[1], b[2])
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        let pts = [(1.0, 0.5), (2.0, 0.6), (3.0, 0.1), (0.5, 0.9), (4.0, 0.1)];
        assert_eq!(pareto_front(&pts), vec![(0.5, 0.9), (1.0, 0.5), (3.0, 0.1)]);
        assert!(pareto_front(&[]).is_empty());
    }

    #[test]
    fn decades_enclose_the_data() {
        assert_eq!(decades([0.003, 20.0].into_iter()), (-3, 2));
        assert_eq!(decades([1.0].into_iter()), (0, 1));
        assert_eq!(decades([f64::NAN, -1.0].into_iter()), (0, 1));
    }

    #[test]
    fn svg_has_every_usable_point() {
        let f = Figure {
            title: "t <1>".into(),
            x_label: "s".into(),
            y_label: "err".into(),
            legend: vec!["a".into(), "b".into()],
            panels: vec![Panel {
                title: "p".into(),
                points: vec![(0, 1e-3, 1e-2), (1, 1e-2, 1e-3), (1, 0.0, 1.0)],
                front: vec![(1e-3, 1e-2), (1e-2, 1e-3)],
            }],
            columns: 2,
        };
        let s = f.svg();
        // Two data points and two front rings; the point at x = 0 is left out.
        assert_eq!(s.matches("<circle").count(), 2 + 2 + 2);
        assert!(s.contains("t &lt;1&gt;"));
    }
}
