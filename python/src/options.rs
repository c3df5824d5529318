//! Conversions between numpy, Python values and the library's types, and the
//! options of `fit_brdf` (the keyword arguments of `ratfit.fit_brdf`, which
//! are the flags of `ratfit fit`), checked by name.

use crate::errors::fit_error;
use brdf::{BrdfFitSettings, ColourMode, Coordinates, Reduction, ReductionKind, TableFormat};
use numpy::{AllowTypeChange, PyArrayLikeDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rational_core::{Backend, FitSettings, PoleControl, Search};

/// A JSON value as the Python object `json.loads` makes of it.
pub(crate) fn json_to_py<'py>(
    py: Python<'py>,
    value: &serde_json::Value,
) -> PyResult<Bound<'py, PyAny>> {
    let text =
        serde_json::to_string(value).map_err(|e| PyValueError::new_err(format!("report: {e}")))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// A Python object (dict, list, number) as JSON, through `json.dumps`.
pub(crate) fn py_to_json(value: &Bound<'_, PyAny>, what: &str) -> PyResult<serde_json::Value> {
    let text: String = value
        .py()
        .import("json")?
        .call_method1("dumps", (value,))?
        .extract()?;
    serde_json::from_str(&text).map_err(|e| PyValueError::new_err(format!("{what}: {e}")))
}

/// A one-dimensional array of `len` values named `name`.
pub(crate) fn vector(
    name: &str,
    a: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    len: usize,
) -> PyResult<Vec<f64>> {
    let a = a.as_array();
    if a.ndim() != 1 || a.len() != len {
        return Err(PyValueError::new_err(format!(
            "{name} has shape {:?}; expected ({len},), one value per point",
            a.shape()
        )));
    }
    Ok(a.iter().copied().collect())
}

/// Directions of shape (n, 3), row by row.
pub(crate) fn directions(
    name: &str,
    a: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
) -> PyResult<Vec<[f64; 3]>> {
    let a = a.as_array();
    let shape = a.shape();
    if a.ndim() != 2 || shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{name} has shape {shape:?}; expected (n, 3) unit vectors"
        )));
    }
    let flat: Vec<f64> = a.iter().copied().collect();
    let out: Vec<[f64; 3]> = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    if let Some(i) = out.iter().position(|v| v.iter().any(|x| !x.is_finite())) {
        return Err(PyValueError::new_err(format!(
            "{name}[{i}] = {:?} is not finite",
            out[i]
        )));
    }
    Ok(out)
}

/// The options of `fit_brdf`, with the defaults of `ratfit fit`.
#[derive(Debug, Clone)]
pub(crate) struct BrdfOptions {
    pub format: Option<String>,
    pub dims: Option<usize>,
    pub spread: bool,
    pub coords: String,
    pub rel_tol: f64,
    pub noise_floor: f64,
    pub max_coeffs: Option<usize>,
    pub max_theta_d: f64,
    /// `None`: 70 degrees for fits at fixed intervals, the whole
    /// hemisphere for perceptual and `target_de` fits.
    pub max_elevation: Option<f64>,
    pub resolution: Option<Vec<usize>>,
    pub backend: String,
    pub poles: String,
    pub search: Option<String>,
    pub max_widenings: usize,
    pub target_de: Option<f64>,
    pub time_budget: f64,
    /// With `target_de`: the most bytes the fit returned may have.
    pub max_bytes: Option<usize>,
    pub degree_weights: Vec<u16>,
    pub perceptual: bool,
    /// Each function the least-squares fit within its intervals
    /// (`FitSettings::with_centred_fit`; always so with `target_de`).
    pub centred: bool,
    pub cap_rounds: usize,
    pub colour: Option<String>,
    /// `"linear"` or `"log"` ([`brdf::ValueScale`]).
    pub values: Option<String>,
    /// `"radians"` or `"cosine"` ([`brdf::PhiCoordinate`]).
    pub phi: Option<String>,
    pub lobe: bool,
    pub render_check: bool,
}

impl Default for BrdfOptions {
    fn default() -> Self {
        Self {
            format: None,
            dims: None,
            spread: false,
            coords: "sqrt".into(),
            rel_tol: 0.05,
            noise_floor: 1e-2,
            max_coeffs: None,
            max_theta_d: 78.0,
            max_elevation: None,
            resolution: None,
            backend: "native".into(),
            poles: "grid".into(),
            search: None,
            max_widenings: 6,
            target_de: None,
            time_budget: render_cpu::fidelity::TARGET_TIME_BUDGET_S,
            max_bytes: None,
            degree_weights: Vec::new(),
            perceptual: false,
            centred: false,
            cap_rounds: 2,
            colour: None,
            values: None,
            phi: None,
            lobe: false,
            render_check: true,
        }
    }
}

/// The option names, for the error that refuses another.
const OPTION_NAMES: &str = "format, dims, spread, coords, rel_tol, noise_floor, max_coeffs, \
     max_theta_d, max_elevation, resolution, backend, poles, search, max_widenings, target_de, \
     time_budget, max_bytes, degree_weights, perceptual, centred, cap_rounds, colour, values, phi, lobe, render_check";

fn bad(name: &str, reason: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(format!("option `{name}`: {reason}"))
}

fn get<'a, 'py, T: pyo3::FromPyObject<'a, 'py>>(
    name: &str,
    v: &'a Bound<'py, PyAny>,
) -> PyResult<T> {
    v.extract::<T>().map_err(|e| {
        let e: PyErr = e.into();
        let shown = v.repr().map_or_else(|_| "?".into(), |r| r.to_string());
        bad(name, format!("{shown}: {e}"))
    })
}

/// The elevation cut of fits at fixed intervals when none is given.
const PLAIN_MAX_ELEVATION: f64 = 70.0;

fn angle(name: &str, v: f64) -> PyResult<f64> {
    if v > 0.0 && v <= 90.0 {
        Ok(v)
    } else {
        Err(bad(name, format!("{v} degrees is not in (0, 90]")))
    }
}

fn positive(name: &str, v: f64) -> PyResult<f64> {
    if v > 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(bad(name, format!("{v} is not a positive number")))
    }
}

impl BrdfOptions {
    /// Options from a dict of keyword arguments (None leaves a default).
    pub fn from_dict(options: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let mut o = Self::default();
        let Some(options) = options else {
            return Ok(o);
        };
        for (key, v) in options.iter() {
            let name: String = key
                .extract()
                .map_err(|_| bad("?", "option names are strings"))?;
            if v.is_none() {
                continue;
            }
            let n = name.as_str();
            match n {
                "format" => o.format = Some(get(n, &v)?),
                "dims" => o.dims = Some(get(n, &v)?),
                "spread" => o.spread = get(n, &v)?,
                "coords" => o.coords = get(n, &v)?,
                "rel_tol" => o.rel_tol = get(n, &v)?,
                "noise_floor" => o.noise_floor = get(n, &v)?,
                "max_coeffs" => o.max_coeffs = Some(get(n, &v)?),
                "max_theta_d" => o.max_theta_d = angle(n, get(n, &v)?)?,
                "max_elevation" => o.max_elevation = Some(angle(n, get(n, &v)?)?),
                "resolution" => {
                    let r: Vec<usize> = get(n, &v)?;
                    if !(2..=3).contains(&r.len())
                        || r.iter().any(|b| !(2..=brdf::MAX_BINS).contains(b))
                    {
                        return Err(bad(
                            n,
                            format!(
                                "{r:?}: give (theta_h, theta_d[, phi_d]) bins, each in 2..={}",
                                brdf::MAX_BINS
                            ),
                        ));
                    }
                    o.resolution = Some(r);
                }
                "backend" => o.backend = get(n, &v)?,
                "poles" => o.poles = get(n, &v)?,
                "search" => o.search = Some(get(n, &v)?),
                "max_widenings" => o.max_widenings = get(n, &v)?,
                "target_de" => o.target_de = Some(positive(n, get(n, &v)?)?),
                "time_budget" => o.time_budget = positive(n, get(n, &v)?)?,
                "max_bytes" => {
                    let b: usize = get(n, &v)?;
                    if !(8..=1 << 30).contains(&b) {
                        return Err(bad(
                            n,
                            format!("{b} is outside 8..=2^30 (two f32 coefficients at least)"),
                        ));
                    }
                    o.max_bytes = Some(b);
                }
                "degree_weights" => o.degree_weights = get(n, &v)?,
                "perceptual" => o.perceptual = get(n, &v)?,
                "centred" => o.centred = get(n, &v)?,
                "cap_rounds" => {
                    o.cap_rounds = get(n, &v)?;
                    if o.cap_rounds > brdf::MAX_CAP_ROUNDS {
                        return Err(bad(
                            n,
                            format!("{} is outside 0..={}", o.cap_rounds, brdf::MAX_CAP_ROUNDS),
                        ));
                    }
                }
                "colour" | "color" => o.colour = Some(get(n, &v)?),
                "values" => o.values = Some(get(n, &v)?),
                "phi" => o.phi = Some(get(n, &v)?),
                "lobe" => o.lobe = get(n, &v)?,
                "render_check" => o.render_check = get(n, &v)?,
                _ => return Err(bad(n, format!("unknown (options: {OPTION_NAMES})"))),
            }
        }
        if o.max_bytes.is_some() && o.target_de.is_none() {
            return Err(bad(
                "max_bytes",
                "bounds the fit of target_de: give target_de as well",
            ));
        }
        if o.target_de.is_some() && (o.perceptual || o.spread) {
            return Err(bad(
                "target_de",
                "chooses its own intervals: drop perceptual and spread",
            ));
        }
        Ok(o)
    }

    /// The file format: the option, else from the extension (`.binary`:
    /// MERL, `.bsdf`: RGL).
    pub fn format(&self, path: &str) -> PyResult<TableFormat> {
        match self.format.as_deref() {
            Some(f) => f.parse().map_err(|_| {
                bad(
                    "format",
                    format!("`{f}`: the Python package reads merl and rgl tables"),
                )
            }),
            None => TableFormat::of_path(std::path::Path::new(path)).ok_or_else(|| {
                bad(
                    "format",
                    format!(
                        "{path}: cannot tell the format from the name; give format=\"merl\" or \"rgl\""
                    ),
                )
            }),
        }
    }

    /// The engine's settings: budgets, backend, poles, search, widening.
    pub fn fit_settings(&self, py: Python<'_>) -> PyResult<FitSettings> {
        let with =
            |s: Result<FitSettings, rational_core::FitError>| s.map_err(|e| fit_error(py, e));
        let target = self.target_de.is_some();
        let search = match &self.search {
            Some(s) => s.parse::<Search>().map_err(|e| fit_error(py, e))?,
            None => Search::Staircase,
        };
        let backend = self
            .backend
            .parse::<Backend>()
            .map_err(|e| bad("backend", e))?;
        let poles = self
            .poles
            .parse::<PoleControl>()
            .map_err(|e| fit_error(py, e))?;
        let max = self.max_coeffs.unwrap_or(if target {
            render_cpu::fidelity::TARGET_MAX_COEFFS
        } else {
            60
        });
        let mut s = with(FitSettings::default().with_coeff_range(2, max))?;
        s = with(s.with_backend(backend))?
            .with_pole_control(poles)
            .with_search(search)
            .with_centred_fit(self.centred);
        if !self.degree_weights.is_empty() {
            s = with(s.with_degree_weights(self.degree_weights.clone()))?;
        }
        if self.max_widenings > 0 {
            s = with(s.with_widening(2.0, self.max_widenings))?;
        }
        Ok(s)
    }

    /// The reduction of a fit at fixed intervals, or the base reduction of
    /// `target_de` (the whole hemisphere; 16^3 in 3-D, 90^2 in 2-D unless
    /// `resolution` says; without it `target_de` may move the 3-D fits to
    /// 24 x 16 x 8, `render_cpu::fidelity::TargetGrid::Auto`).
    pub fn reduction(&self) -> PyResult<Reduction> {
        let kind = match (self.dims.unwrap_or(2), self.spread) {
            (2, false) => ReductionKind::Slice2d,
            (2, true) => ReductionKind::Spread2d,
            (3, false) => ReductionKind::Full3d,
            (3, true) => return Err(bad("spread", "applies to 2-D fits only")),
            (d, _) => return Err(bad("dims", format!("{d}: use 2 or 3"))),
        };
        let coords = match self.coords.as_str() {
            "sqrt" => Coordinates::SqrtThetaH,
            "radians" => Coordinates::Radians,
            "cosines" => Coordinates::Cosines,
            c => {
                return Err(bad(
                    "coords",
                    format!("unknown `{c}` (sqrt, radians, cosines)"),
                ))
            }
        };
        let mut r = Reduction::default()
            .with_kind(kind)
            .with_coordinates(coords)
            .with_max_theta_d(self.max_theta_d)
            .with_max_elevation(self.max_elevation.unwrap_or(PLAIN_MAX_ELEVATION));
        if self.target_de.is_some() {
            let three = self.dims != Some(2);
            r = r
                .with_kind(if three {
                    ReductionKind::Full3d
                } else {
                    ReductionKind::Slice2d
                })
                .whole_hemisphere();
            if let Some(degrees) = self.max_elevation {
                r = r.with_max_elevation(degrees);
            }
            if self.resolution.is_none() {
                r = render_cpu::fidelity::on_target_grid(r);
            }
        } else if kind == ReductionKind::Full3d {
            // The full MERL grid is 1.46 M cells per channel: a 45^3 subgrid.
            r = r.with_resolution(45, 45).with_phi_resolution(45);
        }
        if let Some(v) = &self.resolution {
            r = r.with_resolution(v[0], v[1]);
            if let Some(&p) = v.get(2) {
                r = r.with_phi_resolution(p);
            }
        }
        // `phi_d` as `ratfit fit --phi`: radians unless named, its cosine
        // with `target_de`.
        let phi = match &self.phi {
            Some(p) => p.parse().map_err(|e| bad("phi", e))?,
            None if self.target_de.is_some() => render_cpu::fidelity::TARGET_PHI,
            None => brdf::PhiCoordinate::Radians,
        };
        Ok(r.with_phi(phi))
    }

    /// The colour mode: the option, else RGB (luminance-chroma with
    /// `target_de`, as `ratfit fit`).
    pub fn colour_mode(&self) -> PyResult<ColourMode> {
        match &self.colour {
            Some(c) => c.parse().map_err(|e| bad("colour", e)),
            None if self.target_de.is_some() => Ok(ColourMode::LuminanceChroma),
            None => Ok(ColourMode::default()),
        }
    }

    /// What the functions' values stand for: the option, else linear (with
    /// `target_de`, the search's first reduction on the log scale, as
    /// `ratfit fit`: [`render_cpu::fidelity::TargetScale::Auto`]).
    pub fn value_scale(&self) -> PyResult<brdf::ValueScale> {
        match &self.values {
            Some(v) => v.parse().map_err(|e| bad("values", e)),
            None => Ok(brdf::ValueScale::default()),
        }
    }

    /// The settings of a fit at fixed (or perceptual) intervals.
    pub fn brdf_settings(
        &self,
        py: Python<'_>,
        fit: FitSettings,
        lobe: Option<brdf::Lobe>,
    ) -> PyResult<BrdfFitSettings> {
        let mut s = BrdfFitSettings::default()
            .with_reduction(self.reduction()?)
            .with_rel_tol(self.rel_tol)
            .and_then(|s| s.with_noise_floor(self.noise_floor))
            .map_err(|e| crate::errors::brdf_error(py, e))?
            .with_colour_mode(self.colour_mode()?)
            .with_value_scale(self.value_scale()?)
            .with_lobe(lobe)
            .with_cap_rounds(self.cap_rounds)
            .map_err(|e| crate::errors::brdf_error(py, e))?
            .with_fit_settings(fit);
        let design = brdf::PerceptualBounds::default();
        if self.target_de.is_some() {
            s = s.with_baselines(false).with_design(design);
        } else if self.perceptual {
            let mut whole = s.reduction().whole_hemisphere();
            if let Some(degrees) = self.max_elevation {
                whole = whole.with_max_elevation(degrees);
            }
            let design = design
                .with_rel_tol(self.rel_tol)
                .map_err(|e| crate::errors::brdf_error(py, e))?;
            s = s.with_reduction(whole).with_design(design);
        }
        Ok(s)
    }
}
