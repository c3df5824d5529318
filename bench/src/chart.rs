//! Log-log scatter charts in panels (one panel per instance, one series per
//! backend, the Pareto front marked), drawn by `plotters` as SVG and PNG
//! from one description.

use anyhow::{anyhow, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// Colours of the series, in legend order (every chart of the project).
pub const PALETTE: [[u8; 3]; 8] = [
    [214, 38, 41],
    [31, 120, 181],
    [43, 161, 43],
    [255, 128, 13],
    [148, 102, 189],
    [140, 87, 74],
    [227, 120, 194],
    [128, 128, 128],
];

/// Series `k`'s colour.
pub fn colour(k: usize) -> RGBColor {
    let [r, g, b] = PALETTE[k % PALETTE.len()];
    RGBColor(r, g, b)
}

/// The font every chart uses: DejaVu Sans cut to ASCII and a few symbols
/// (`fonts/LICENSE`), built in so that PNG text needs no system font.
const FONT: &[u8] = include_bytes!("../fonts/DejaVuSans-subset.ttf");

/// The family name charts ask for.
pub const FAMILY: &str = "sans-serif";

/// Registers the built-in font with plotters (once): every chart calls this
/// first.
pub fn register_font() {
    static REGISTERED: std::sync::Once = std::sync::Once::new();
    REGISTERED.call_once(|| {
        // The bytes are ours and checked by the tests: a failure is a bug.
        plotters::style::register_font(FAMILY, FontStyle::Normal, FONT)
            .unwrap_or_else(|_| panic!("the built-in chart font does not parse"));
    });
}

/// A plotters error as an `anyhow` one (its errors are not `Send`).
pub fn plot_error(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("drawing a chart: {e}")
}

/// Draws with `draw` on a `width x height` RGB bitmap and writes it as PNG.
pub fn write_png(
    path: &Path,
    (width, height): (u32, u32),
    draw: impl FnOnce(&DrawingArea<BitMapBackend, Shift>) -> Result<()>,
) -> Result<()> {
    register_font();
    let mut rgb = vec![255u8; 3 * width as usize * height as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        draw(&root)?;
        root.present().map_err(plot_error)?;
    }
    render_cpu::write_png(path, width as usize, height as usize, &rgb)?;
    Ok(())
}

/// Draws with `draw` on a `width x height` SVG and returns its text.
pub fn svg_text(
    (width, height): (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>) -> Result<()>,
) -> Result<String> {
    register_font();
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (width, height)).into_drawing_area();
        draw(&root)?;
        root.present().map_err(plot_error)?;
    }
    Ok(text)
}

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
    /// Series names; series `k` is drawn in [`colour`]`(k)`.
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

const PANEL_W: u32 = 380;
const PANEL_H: u32 = 280;
const HEADER: u32 = 56;
/// Height of each legend line after the first.
const LEGEND_LINE: u32 = 18;
/// Width of a legend character at the legend's 12-pixel font (an upper
/// estimate: the layout must be known before a backend exists).
const LEGEND_CHAR_W: i32 = 7;

/// A decade's label: `1e-3`, `1e2`.
fn decade_label(v: &f64) -> String {
    format!("{v:e}")
}

impl Figure {
    fn grid(&self) -> (usize, usize) {
        let cols = self.columns.max(1).min(self.panels.len().max(1));
        (self.panels.len().div_ceil(cols).max(1), cols)
    }

    /// Width and height in pixels.
    pub fn size(&self) -> (u32, u32) {
        let (rows, cols) = self.grid();
        (cols as u32 * PANEL_W, self.header() + rows as u32 * PANEL_H)
    }

    /// The legend's entries (the Pareto note last, where there is a front)
    /// laid out left to right and wrapped at the figure's width: per entry,
    /// its line and its x.
    fn legend_layout(&self) -> Vec<(String, Option<usize>, u32, i32)> {
        let width = (self.grid().1 as u32 * PANEL_W) as i32;
        let mut entries: Vec<(String, Option<usize>)> = self
            .legend
            .iter()
            .enumerate()
            .map(|(k, name)| (name.clone(), Some(k)))
            .collect();
        if self.panels.iter().any(|p| !p.front.is_empty()) {
            entries.push(("black rings and line: Pareto front".into(), None));
        }
        let (mut line, mut x) = (0u32, 10i32);
        let mut out = Vec::with_capacity(entries.len());
        for (name, k) in entries {
            let w = 24 + LEGEND_CHAR_W * name.chars().count() as i32;
            if x > 10 && x + w > width {
                line += 1;
                x = 10;
            }
            out.push((name, k, line, x));
            x += w;
        }
        out
    }

    /// Height of the title and legend.
    fn header(&self) -> u32 {
        let lines = self.legend_layout().last().map_or(0, |e| e.2);
        HEADER + lines * LEGEND_LINE
    }

    /// The figure as SVG.
    pub fn svg(&self) -> Result<String> {
        svg_text(self.size(), |root| self.draw(root))
    }

    /// The figure as PNG.
    pub fn png(&self, path: &Path) -> Result<()> {
        write_png(path, self.size(), |root| self.draw(root))
    }

    /// Writes the figure as `dir/stem.svg` and `dir/stem.png`.
    pub fn write(&self, dir: &Path, stem: &str) -> Result<()> {
        crate::output::write(dir.join(format!("{stem}.svg")), self.svg()?)?;
        self.png(&dir.join(format!("{stem}.png")))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        root.fill(&WHITE).map_err(plot_error)?;
        let (header, body) = root.split_vertically(self.header());
        header
            .draw(&Text::new(self.title.clone(), (10, 6), (FAMILY, 16)))
            .map_err(plot_error)?;
        let style = TextStyle::from((FAMILY, 12));
        for (name, k, line, x) in self.legend_layout() {
            let y = 40 + (line * LEGEND_LINE) as i32;
            if let Some(k) = k {
                header
                    .draw(&Circle::new((x + 4, y), 4, colour(k).filled()))
                    .map_err(plot_error)?;
            }
            let text_x = if k.is_some() { x + 12 } else { x };
            header
                .draw(&Text::new(name, (text_x, y - 7), style.clone()))
                .map_err(plot_error)?;
        }
        let areas = body.split_evenly(self.grid());
        for (p, area) in self.panels.iter().zip(&areas) {
            self.draw_panel(p, area)?;
        }
        Ok(())
    }

    fn draw_panel<DB: DrawingBackend>(
        &self,
        p: &Panel,
        area: &DrawingArea<DB, Shift>,
    ) -> Result<()> {
        let points: Vec<(usize, f64, f64)> = p
            .points
            .iter()
            .copied()
            .filter(|&(_, x, y)| usable(x, y))
            .collect();
        let xd = decades(points.iter().map(|p| p.1));
        let yd = decades(points.iter().map(|p| p.2));
        let range = |d: (i32, i32)| (10f64.powi(d.0)..10f64.powi(d.1)).log_scale();
        let mut chart = ChartBuilder::on(area)
            .caption(&p.title, (FAMILY, 13))
            .margin(8)
            .x_label_area_size(34)
            .y_label_area_size(56)
            .build_cartesian_2d(range(xd), range(yd))
            .map_err(plot_error)?;
        chart
            .configure_mesh()
            .x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .x_labels(5)
            .y_labels(8)
            .x_label_formatter(&decade_label)
            .y_label_formatter(&decade_label)
            .label_style((FAMILY, 11))
            .axis_desc_style((FAMILY, 12))
            .light_line_style(WHITE)
            .draw()
            .map_err(plot_error)?;
        if points.is_empty() {
            area.draw(&Text::new("no points", (80, 140), (FAMILY, 12)))
                .map_err(plot_error)?;
        }
        let front: Vec<(f64, f64)> = p
            .front
            .iter()
            .copied()
            .filter(|&(x, y)| usable(x, y))
            .collect();
        if front.len() > 1 {
            chart
                .draw_series(LineSeries::new(front.iter().copied(), BLACK))
                .map_err(plot_error)?;
        }
        chart
            .draw_series(
                points
                    .iter()
                    .map(|&(s, x, y)| Circle::new((x, y), 3, colour(s).mix(0.8).filled())),
            )
            .map_err(plot_error)?;
        chart
            .draw_series(
                front
                    .iter()
                    .map(|&(x, y)| Circle::new((x, y), 6, BLACK.stroke_width(1))),
            )
            .map_err(plot_error)?;
        Ok(())
    }
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

    fn two_series() -> Figure {
        Figure {
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
        }
    }

    #[test]
    fn svg_has_every_usable_point() {
        let s = two_series().svg().unwrap();
        // Two legend dots, two data points and two front rings; the point
        // at x = 0 is left out.
        assert_eq!(s.matches("<circle").count(), 2 + 2 + 2, "{s}");
        assert!(s.contains("t &lt;1&gt;"), "{s}");
        assert!(s.contains(">\n1e-2\n<"), "decade labels: {s}");
    }

    #[test]
    fn a_long_legend_wraps_within_the_figure_and_makes_it_taller() {
        let mut long = two_series();
        long.legend = (0..8)
            .map(|k| format!("rational 3-D luminance-chroma {k}%"))
            .collect();
        let (width, _) = long.size();
        let layout = long.legend_layout();
        assert_eq!(layout.len(), 8 + 1, "eight series and the front's note");
        assert!(layout.last().unwrap().2 >= 2, "{layout:?}");
        for (name, _, _, x) in &layout {
            let w = 24 + LEGEND_CHAR_W * name.chars().count() as i32;
            assert!(x + w <= width as i32, "{name} at {x} overflows {width}");
        }
        assert!(long.size().1 > two_series().size().1);
        assert_eq!(two_series().legend_layout().last().unwrap().2, 0);
        assert!(long.svg().unwrap().matches("<circle").count() >= 8);
    }

    #[test]
    fn png_has_text_and_the_series_colours() {
        let dir = std::env::temp_dir().join(format!("ratfit-chart-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("f.png");
        two_series().png(&path).unwrap();
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), two_series().size());
        let pixels: Vec<&[u8]> = buf[..info.buffer_size()].chunks(3).collect();
        // Text is drawn (dark pixels in the header), and both series' colours.
        let header = 3 * info.width as usize * 30;
        assert!(buf[..header].chunks(3).any(|p| p.iter().all(|&v| v < 100)));
        for k in 0..2 {
            let [r, g, b] = PALETTE[k];
            assert!(pixels.iter().any(|p| p == &[r, g, b]), "series {k}");
        }
        std::fs::remove_dir_all(dir).ok();
    }
}
