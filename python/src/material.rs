//! Measured materials and their fits: `read_material`, `fit_brdf`, the
//! per-channel tasks of `ratfit.distributed`, `Material` and
//! `FittedMaterial`.

use crate::errors::{brdf_error, json_error, render_error};
use crate::function::RationalFit;
use crate::options::{directions, json_to_py, py_to_json, BrdfOptions};
use brdf::{Brdf, FitFile, FittedBrdf, TableFormat};
use numpy::{AllowTypeChange, PyArray2, PyArrayLikeDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyTuple};
use render_cpu::fidelity::{
    fit_to_target, TargetBudget, TargetChoices, TargetCoefficients, TargetColour, TargetGrid,
    TargetReduction, TargetScale, ValidationSettings,
};
use std::path::Path;
use std::sync::Arc;

/// A measured material (a MERL or RGL table), evaluated on arrays.
#[pyclass(module = "ratfit._ratfit", frozen)]
pub struct Material {
    table: Arc<dyn Brdf>,
    path: String,
}

/// `values[i] = f(wi[i], wo[i])` as an (n, 3) array, computed without the GIL.
fn eval_pairs<'py>(
    py: Python<'py>,
    f: &dyn Brdf,
    wi: &PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    wo: &PyArrayLikeDyn<'py, f64, AllowTypeChange>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let (wi, wo) = (directions("wi", wi)?, directions("wo", wo)?);
    if wi.len() != wo.len() {
        return Err(PyValueError::new_err(format!(
            "{} directions wi for {} directions wo",
            wi.len(),
            wo.len()
        )));
    }
    let values: Vec<Vec<f64>> = py.detach(|| {
        wi.iter()
            .zip(&wo)
            .map(|(&a, &b)| f.eval(a, b).to_vec())
            .collect()
    });
    if values.is_empty() {
        return Ok(PyArray2::zeros(py, [0, 3], false));
    }
    PyArray2::from_vec2(py, &values).map_err(|e| PyValueError::new_err(e.to_string()))
}

fn read_table(py: Python<'_>, path: &str, format: TableFormat) -> PyResult<Arc<dyn Brdf>> {
    let table = format
        .read(Path::new(path))
        .map_err(|e| brdf_error(py, e))?;
    Ok(table.into())
}

/// Reads a MERL (`.binary`) or RGL (`.bsdf`) table; `format` overrides the
/// extension.
#[pyfunction]
#[pyo3(signature = (path, format=None))]
pub fn read_material(py: Python<'_>, path: &str, format: Option<String>) -> PyResult<Material> {
    let options = BrdfOptions {
        format,
        ..Default::default()
    };
    let format = options.format(path)?;
    let path_owned = path.to_string();
    let table = read_table(py, &path_owned, format)?;
    Ok(Material {
        table,
        path: path_owned,
    })
}

#[pymethods]
impl Material {
    /// RGB reflectance at each pair of unit directions (arrays of shape
    /// (n, 3), local frame, z the normal): an (n, 3) array.
    fn eval<'py>(
        &self,
        py: Python<'py>,
        wi: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        wo: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        eval_pairs(py, self.table.as_ref(), &wi, &wo)
    }

    /// The material's name.
    #[getter]
    fn name(&self) -> String {
        self.table.name()
    }

    /// The file it was read from.
    #[getter]
    fn path(&self) -> &str {
        &self.path
    }

    fn __repr__(&self) -> String {
        format!("Material({:?}, path={:?})", self.table.name(), self.path)
    }
}

/// A fitted material: three rational functions (and an optional analytic
/// lobe) that evaluate, export and render like any fit file of the CLI.
#[pyclass(module = "ratfit._ratfit", frozen)]
pub struct FittedMaterial {
    fitted: FittedBrdf,
    /// What the CLI writes beside the fit: `report`, `render`, `target`.
    extra: serde_json::Map<String, serde_json::Value>,
}

/// The render check of `ratfit fit`, as JSON.
fn render_check(
    table: Arc<dyn Brdf>,
    fitted: &FittedBrdf,
) -> Result<serde_json::Value, render_cpu::RenderError> {
    let errors = render_cpu::fidelity::render_check(table, fitted)?;
    Ok(serde_json::to_value(&errors).unwrap_or_default())
}

/// The lobe of `lobe = True`, fitted to the table.
fn lobe_of(options: &BrdfOptions, table: &dyn Brdf) -> Option<brdf::Lobe> {
    options.lobe.then(|| brdf::Lobe::fit(table))
}

/// Fits a material file (see `ratfit.fit_brdf` for the options): a fit at
/// fixed intervals, or with `target_de` the smallest fit whose validation
/// renders reach that mean CIEDE2000.
#[pyfunction]
#[pyo3(signature = (path, options=None))]
pub fn fit_brdf(
    py: Python<'_>,
    path: &str,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<FittedMaterial> {
    let o = BrdfOptions::from_dict(options)?;
    let table = read_table(py, path, o.format(path)?)?;
    let fit = o.fit_settings(py)?;
    let base = o.brdf_settings(py, fit, None)?;
    let result = crate::interruptible(py, move |cancel| -> Result<FittedMaterial, Failure> {
        let fit = base.fit_settings().clone().with_cancel(cancel);
        let settings = base
            .clone()
            .with_fit_settings(fit)
            .with_lobe(lobe_of(&o, table.as_ref()));
        let mut extra = serde_json::Map::new();
        let fitted = if let Some(target) = o.target_de {
            let mode = match o.dims {
                None => TargetReduction::Auto,
                Some(_) => TargetReduction::Fixed,
            };
            let colour = match o.colour {
                None => TargetColour::Auto,
                Some(_) => TargetColour::Fixed,
            };
            let scale = match o.values {
                None => TargetScale::Auto,
                Some(_) => TargetScale::Fixed,
            };
            let grid = match o.resolution {
                None => TargetGrid::Auto,
                Some(_) => TargetGrid::Fixed,
            };
            let choices = TargetChoices {
                reduction: mode,
                colour,
                scale,
                grid,
                coefficients: TargetCoefficients::unless_named(o.max_coeffs),
            };
            let (fitted, report) = fit_to_target(
                table.clone(),
                target,
                &settings,
                choices,
                ValidationSettings::default(),
                TargetBudget::seconds(o.time_budget).with_bytes(o.max_bytes),
            )
            .map_err(Failure::Render)?;
            extra.insert(
                "target".into(),
                serde_json::to_value(&report).unwrap_or_default(),
            );
            fitted
        } else {
            let (mut fitted, report) =
                brdf::fit_brdf(table.as_ref(), &settings).map_err(Failure::Brdf)?;
            extra.insert(
                "report".into(),
                serde_json::to_value(&report).unwrap_or_default(),
            );
            if o.render_check && o.perceptual {
                // As `ratfit fit`: the render check of a perceptual fit
                // also chooses its evaluation cut and shell factor.
                let choice = render_cpu::fidelity::render_check_choosing_cut(table.clone(), fitted)
                    .map_err(Failure::Render)?;
                extra.insert(
                    "render".into(),
                    serde_json::to_value(&choice.errors).unwrap_or_default(),
                );
                extra.insert(
                    "evaluation_cut".into(),
                    serde_json::json!({ "chosen": choice.cut, "shell": choice.shell, "tried": choice.tried }),
                );
                fitted = choice.fitted;
            } else if o.render_check {
                let render = render_check(table.clone(), &fitted).map_err(Failure::Render)?;
                extra.insert("render".into(), render);
            }
            fitted
        };
        Ok(FittedMaterial { fitted, extra })
    })?;
    result.map_err(|f| f.into_py(py))
}

/// A library error carried out of the worker thread.
enum Failure {
    Brdf(brdf::BrdfError),
    Render(render_cpu::RenderError),
}

impl Failure {
    fn into_py(self, py: Python<'_>) -> PyErr {
        match self {
            Failure::Brdf(e) => brdf_error(py, e),
            Failure::Render(e) => render_error(py, e),
        }
    }
}

/// One channel (0, 1, 2 of the colour mode) of `fit_brdf` at fixed
/// intervals, alone: `(RationalFit, channel report dict)`. A task of
/// `ratfit.distributed.fit_many`.
#[pyfunction]
#[pyo3(signature = (path, channel, options=None))]
pub fn fit_brdf_channel<'py>(
    py: Python<'py>,
    path: &str,
    channel: usize,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<(RationalFit, Bound<'py, PyAny>)> {
    let o = BrdfOptions::from_dict(options)?;
    if o.target_de.is_some() {
        return Err(PyValueError::new_err(
            "target_de judges the three channels together by their renders: fit the material whole",
        ));
    }
    let table = read_table(py, path, o.format(path)?)?;
    let base = o.brdf_settings(py, o.fit_settings(py)?, None)?;
    let (function, report) = crate::interruptible(py, move |cancel| {
        let fit = base.fit_settings().clone().with_cancel(cancel);
        let settings = base
            .clone()
            .with_fit_settings(fit)
            .with_lobe(lobe_of(&o, table.as_ref()));
        let samples = settings.reduction().sample(table.as_ref());
        brdf::fit_samples_channel(&samples, channel, &settings)
    })?
    .map_err(|e| brdf_error(py, e))?;
    let report = serde_json::to_value(&report).map_err(|e| json_error("channel report", e))?;
    Ok((RationalFit::bare(function), json_to_py(py, &report)?))
}

/// Joins the three `fit_brdf_channel` results of one material and options
/// into the `FittedMaterial` that `fit_brdf` returns (the render check runs
/// here when the options ask for it).
#[pyfunction]
#[pyo3(signature = (path, parts, options=None))]
pub fn assemble_channels(
    py: Python<'_>,
    path: &str,
    parts: Vec<(PyRef<'_, RationalFit>, Bound<'_, PyAny>)>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<FittedMaterial> {
    let o = BrdfOptions::from_dict(options)?;
    let table = read_table(py, path, o.format(path)?)?;
    let mut channels = Vec::with_capacity(parts.len());
    for (f, r) in &parts {
        let report: brdf::ChannelReport = serde_json::from_value(py_to_json(r, "channel report")?)
            .map_err(|e| json_error("malformed channel report", e))?;
        channels.push((f.function.clone(), report));
    }
    let base = o.brdf_settings(py, o.fit_settings(py)?, None)?;
    let result = crate::interruptible(py, move |_| -> Result<FittedMaterial, Failure> {
        let settings = base.with_lobe(lobe_of(&o, table.as_ref()));
        let samples = settings.reduction().sample(table.as_ref());
        let (fitted, report) =
            brdf::assemble_channels(&samples, &table.name(), &settings, channels)
                .map_err(Failure::Brdf)?;
        let mut extra = serde_json::Map::new();
        extra.insert(
            "report".into(),
            serde_json::to_value(&report).unwrap_or_default(),
        );
        if o.render_check {
            let render = render_check(table.clone(), &fitted).map_err(Failure::Render)?;
            extra.insert("render".into(), render);
        }
        Ok(FittedMaterial { fitted, extra })
    })?;
    result.map_err(|f| f.into_py(py))
}

#[pymethods]
impl FittedMaterial {
    /// RGB reflectance of the fit at each pair of unit directions (arrays
    /// of shape (n, 3)): an (n, 3) array, as `ratfit eval --directions`.
    fn eval<'py>(
        &self,
        py: Python<'py>,
        wi: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        wo: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyAny>> {
        Ok(eval_pairs(py, &self.fitted, &wi, &wo)?.into_any())
    }

    /// The fit in another form, as `ratfit export`: "wgsl" or "glsl" (a
    /// shader function, str), "alta" (ALTA's rational text, str) or
    /// "binary" (the compact f32 file, bytes).
    fn export<'py>(&self, py: Python<'py>, kind: &str) -> PyResult<Bound<'py, PyAny>> {
        let compact = brdf::CompactBrdf::from_fitted(&self.fitted);
        let text = match kind {
            "wgsl" => brdf::shader::shader_source(&compact, brdf::shader::Language::Wgsl),
            "glsl" => brdf::shader::shader_source(&compact, brdf::shader::Language::Glsl),
            "alta" => brdf::AltaRational::from_fitted(&self.fitted)
                .map_err(|e| brdf_error(py, e))?
                .to_text("ratfit (Python) export alta"),
            "binary" => return Ok(PyBytes::new(py, &compact.to_bytes()).into_any()),
            other => {
                return Err(PyValueError::new_err(format!(
                    "unknown export `{other}` (wgsl, glsl, alta, binary)"
                )))
            }
        };
        Ok(text.into_pyobject(py)?.into_any())
    }

    /// The three fitted functions (luminance and two ratios in the
    /// luminance-chroma mode), as bare `RationalFit`s: on the log scale
    /// (`value_scale == "log"`) each is the logarithm of its value.
    #[getter]
    fn channels(&self) -> Vec<RationalFit> {
        self.fitted
            .channels
            .iter()
            .map(|f| RationalFit::bare(f.clone()))
            .collect()
    }

    /// What each function's value stands for: `"linear"` (the value) or
    /// `"log"` (its natural logarithm).
    #[getter]
    fn value_scale(&self) -> String {
        self.fitted.scale.to_string()
    }

    /// The material's name.
    #[getter]
    fn name(&self) -> &str {
        &self.fitted.name
    }

    /// Total coefficients of the three functions.
    #[getter]
    fn coefficients(&self) -> usize {
        self.fitted.coefficients()
    }

    /// Bytes of the representation stored as f32: the coefficients, the
    /// lobe and the ceiling when there are.
    #[getter]
    fn nbytes(&self) -> usize {
        self.fitted.byte_size_f32()
    }

    /// What the fit reached, as a dict: `report` (per channel: split,
    /// verified, errors), `render` (mean and 99th-percentile CIEDE2000 on
    /// the validation scenes, when checked) or `target` (for `target_de`).
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &serde_json::Value::Object(self.extra.clone()))
    }

    /// The JSON `ratfit fit` writes (`{"brdf": ..., "report": ..., ...}`),
    /// which every command that takes a fit file reads.
    fn to_json(&self) -> PyResult<String> {
        let file = FitFile {
            brdf: self.fitted.clone(),
            extra: self.extra.clone(),
        };
        serde_json::to_string_pretty(&file.to_value()).map_err(|e| json_error("fit", e))
    }

    /// Reads what `to_json` or `ratfit fit` wrote, validated.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        let file = FitFile::parse(text, std::path::Path::new("<text>"))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(Self {
            fitted: file.brdf,
            extra: file.extra,
        })
    }

    /// Pickling (Dask moves fits between processes) through the JSON.
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let from_json = py.get_type::<Self>().getattr("from_json")?;
        let args = PyTuple::new(py, [slf.get().to_json()?])?;
        Ok((from_json, args))
    }

    fn __repr__(&self) -> String {
        format!(
            "FittedMaterial({:?}, {}-D, {} coefficients, {} bytes)",
            self.fitted.name,
            self.fitted.reduction.dims(),
            self.fitted.coefficients(),
            self.fitted.byte_size_f32()
        )
    }
}

/// Checks the options of `fit_brdf` without reading or fitting anything:
/// unknown names and values out of range raise `ValueError`.
#[pyfunction]
#[pyo3(name = "_check_brdf_options", signature = (options=None))]
pub fn check_brdf_options(py: Python<'_>, options: Option<&Bound<'_, PyDict>>) -> PyResult<()> {
    let o = BrdfOptions::from_dict(options)?;
    if let Some(f) = &o.format {
        o.format(&format!("material.{f}"))?;
    }
    o.brdf_settings(py, o.fit_settings(py)?, None)?;
    Ok(())
}
