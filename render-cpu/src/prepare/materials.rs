//! Materials and their samplers: loaded, fitted or read from the cache.

use super::cache::{content_hash, Cache, CACHE_VERSION};
use super::checks::{check_positive, check_reflectance, resolve_path, scene_error};
use super::{Action, PrepareLog};
use crate::description::{MaterialDescription, SamplerKind};
use crate::error::{io, RenderError};
use crate::scene::{ClosedForm, FitInDomain};
use brdf::{
    AshikhminShirley, BlinnPhong, Brdf, BrdfFitSettings, CookTorranceGgx, FitFile, FittedBrdf,
    Lambert, Reduction, ReductionKind,
};
use cdf::{
    CdfFitSettings, CdfTable, CosineSampler, RationalCdf, RationalSampler, Sampler, TableSettings,
    TabulatedSampler,
};
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

pub(super) struct MaterialBuilder<'a> {
    pub(super) materials: &'a BTreeMap<String, MaterialDescription>,
    pub(super) base: &'a Path,
    pub(super) origin: &'a str,
    pub(super) cache: &'a Cache,
    /// Content keys of materials already keyed.
    pub(super) keys: BTreeMap<String, u64>,
    /// Materials being keyed (a fit of a fit of ...), to refuse cycles.
    pub(super) visiting: Vec<String>,
}

/// The BRDF, its bytes, a description, its cache key and its closed form.
/// A material as preparation builds it, before its sampler.
pub(super) struct Built {
    /// What the renderer evaluates.
    pub(super) brdf: Arc<dyn Brdf>,
    /// Bytes of its representation (0 for analytic models).
    pub(super) bytes: usize,
    /// What it is, for the preparation log.
    pub(super) description: String,
    /// Its content key (the cache's key for its sampler too).
    pub(super) key: u64,
    /// Its closed form where the renderer has one (Lambert, fits).
    pub(super) closed_form: Option<ClosedForm>,
}

impl Built {
    /// A material without a closed form.
    fn plain(brdf: Arc<dyn Brdf>, bytes: usize, description: String, key: u64) -> Self {
        Self {
            brdf,
            bytes,
            description,
            key,
            closed_form: None,
        }
    }

    /// A rational fit, which is its own closed form.
    fn fit(fit: Arc<FitInDomain>, bytes: usize, description: String, key: u64) -> Self {
        Self {
            brdf: fit.clone(),
            bytes,
            description,
            key,
            closed_form: Some(ClosedForm::Fit(fit)),
        }
    }
}

impl MaterialBuilder<'_> {
    fn material_error(&self, name: &str, e: brdf::BrdfError) -> RenderError {
        RenderError::Material {
            name: name.to_string(),
            source: e,
        }
    }

    /// The content key of a material without loading it (file bytes or
    /// parameters).
    fn key(&mut self, name: &str) -> Result<u64, RenderError> {
        if let Some(k) = self.keys.get(name) {
            return Ok(*k);
        }
        let desc = self
            .materials
            .get(name)
            .ok_or_else(|| scene_error(self.origin, format!("no material `{name}`")))?;
        let params = serde_json::to_string(desc).unwrap_or_default();
        let key = match desc {
            MaterialDescription::Measured { path, .. } | MaterialDescription::Fit { path } => {
                let p = resolve_path(self.base, path)?;
                let bytes = std::fs::read(&p).map_err(|e| io(&p, e))?;
                content_hash(&[CACHE_VERSION.as_bytes(), &bytes])
            }
            MaterialDescription::Fitted { source, .. } => {
                if source == name || self.visiting.iter().any(|v| v == source) {
                    return Err(scene_error(
                        self.origin,
                        format!("material `{name}` fits `{source}`, which depends on `{name}` (a cycle)"),
                    ));
                }
                self.visiting.push(name.to_string());
                let s = self.key(source);
                self.visiting.pop();
                let s = s?;
                content_hash(&[
                    CACHE_VERSION.as_bytes(),
                    &s.to_le_bytes(),
                    params.as_bytes(),
                ])
            }
            _ => content_hash(&[CACHE_VERSION.as_bytes(), params.as_bytes()]),
        };
        self.keys.insert(name.to_string(), key);
        Ok(key)
    }

    /// A `fitted` material: read from the cache, or fitted to its source
    /// (which is then built) and cached.
    fn build_fitted(
        &mut self,
        name: &str,
        desc: &MaterialDescription,
        key: u64,
        log: &mut PrepareLog,
    ) -> Result<Built, RenderError> {
        let MaterialDescription::Fitted {
            source,
            rel_tol,
            dims,
            max_coeffs,
            target_de,
            max_bytes,
            max_elevation,
            lobe,
        } = desc.clone()
        else {
            unreachable!("build_fitted is called on fitted materials");
        };
        let coefficients = crate::fidelity::TargetCoefficients::unless_named(max_coeffs);
        let max_coeffs = max_coeffs.unwrap_or(if target_de.is_some() {
            crate::fidelity::TARGET_MAX_COEFFS
        } else {
            60
        });
        let start = Instant::now();
        let what = format!("material {name}");
        if max_bytes.is_some() && target_de.is_none() {
            return Err(crate::error::invalid(
                "max_bytes",
                format!(
                    "material {name}: max_bytes bounds a target_de fit; give target_de as well"
                ),
            ));
        }
        let settings_text = format!(
            "fitted source={source} rel_tol={rel_tol} dims={dims} max_coeffs={max_coeffs} target_de={target_de:?}{}",
            key_additions(lobe, max_elevation, max_bytes, target_de.and(Some(coefficients)))
        );
        let fitted = match self
            .cache
            .get("fit", key, &settings_text)
            .and_then(|v| serde_json::from_value::<FittedBrdf>(v).ok())
        {
            Some(f) => {
                log.push(Action::Cached, &what, format!("fit of `{source}` read from the cache ({} coefficients); `{source}` not loaded", f.coefficients()), start.elapsed().as_secs_f64());
                f
            }
            None => {
                let Built {
                    brdf: src,
                    description: src_desc,
                    ..
                } = self.build(&source, log)?;
                let dims = if target_de.is_some() { 3 } else { dims };
                let settings = fit_settings(rel_tol, dims, max_coeffs, max_elevation)
                    .map_err(|e| self.material_error(name, e))?
                    .with_lobe(lobe.then(|| brdf::Lobe::fit(src.as_ref())));
                let (fitted, summary) = match target_de {
                    Some(target) => {
                        let plan = (max_elevation, max_bytes, coefficients);
                        fit_for_target(&src, target, settings, plan)?
                    }
                    None => {
                        let (f, report) = brdf::fit_brdf(src.as_ref(), &settings)
                            .map_err(|e| self.material_error(name, e))?;
                        let worst = report
                            .channels
                            .iter()
                            .map(|c| c.max_rel)
                            .fold(0.0, f64::max);
                        (f, format!("rel_tol {rel_tol}, max rel error {worst:.3}"))
                    }
                };
                let stored = self.cache.put(
                    "fit",
                    key,
                    &settings_text,
                    serde_json::to_value(&fitted).unwrap_or_default(),
                );
                log.push(
                    Action::Prepared,
                    &what,
                    format!(
                        "fitted {src_desc} ({}-D, {summary}): {} coefficients; {stored}",
                        dims,
                        fitted.coefficients()
                    ),
                    start.elapsed().as_secs_f64(),
                );
                fitted
            }
        };
        let bytes = fitted.byte_size_f32();
        let d = format!(
            "rational fit of `{source}` ({} coefficients); {}",
            fitted.coefficients(),
            domain_note(&fitted)
        );
        let fit = Arc::new(FitInDomain::new(fitted));
        let d = d + &precision_note(&fit);
        Ok(Built::fit(fit, bytes, d, key))
    }

    pub(super) fn build(&mut self, name: &str, log: &mut PrepareLog) -> Result<Built, RenderError> {
        let key = self.key(name)?;
        let desc = self.materials[name].clone();
        let is_analytic = !matches!(
            desc,
            MaterialDescription::Measured { .. }
                | MaterialDescription::Fit { .. }
                | MaterialDescription::Fitted { .. }
        );
        let start = Instant::now();
        let what = format!("material {name}");
        let rgb = |v: [f64; 3], w: &str| {
            check_reflectance(self.origin, &format!("materials.{name}.{w}"), v)
        };
        let analytic = |b: Arc<dyn Brdf>| -> Built {
            let description = b.name();
            Built::plain(b, 0, description, key)
        };
        let built: Built = match desc {
            MaterialDescription::Lambert { albedo } => {
                let albedo = rgb(albedo, "albedo")?;
                let mut built = analytic(Arc::new(Lambert { albedo }));
                built.closed_form = Some(ClosedForm::Lambert { albedo });
                built
            }
            MaterialDescription::BlinnPhong { kd, ks, exponent } => {
                analytic(Arc::new(BlinnPhong {
                    kd: rgb(kd, "kd")?,
                    ks: rgb(ks, "ks")?,
                    exponent: check_positive(self.origin, "exponent", exponent)?,
                }))
            }
            MaterialDescription::Ggx { kd, f0, alpha } => analytic(Arc::new(CookTorranceGgx {
                kd: rgb(kd, "kd")?,
                f0: rgb(f0, "f0")?,
                alpha: check_positive(self.origin, "alpha", alpha)?,
            })),
            MaterialDescription::AshikhminShirley { rd, rs, exponent } => {
                analytic(Arc::new(AshikhminShirley {
                    rd: rgb(rd, "rd")?,
                    rs: rgb(rs, "rs")?,
                    exponent: check_positive(self.origin, "exponent", exponent)?,
                }))
            }
            MaterialDescription::Measured { format, path } => {
                let p = resolve_path(self.base, &path)?;
                let table_format = format.parse::<brdf::TableFormat>().map_err(|_| {
                    scene_error(
                        self.origin,
                        format!("materials.{name}: unknown format `{format}` (merl, rgl)"),
                    )
                })?;
                let b: Arc<dyn Brdf> = table_format
                    .read(&p)
                    .map_err(|e| self.material_error(name, e))?
                    .into();
                let bytes = table_format.stored_bytes(&p);
                let d = format!("{format} table {}", p.display());
                log.push(
                    Action::Prepared,
                    &what,
                    format!("loaded {d}, {bytes} bytes"),
                    start.elapsed().as_secs_f64(),
                );
                Built::plain(b, bytes, d, key)
            }
            MaterialDescription::Fit { path } => {
                let p = resolve_path(self.base, &path)?;
                let fitted = FitFile::read(&p)
                    .map_err(|e| scene_error(self.origin, e.to_string()))?
                    .brdf;
                let bytes = fitted.byte_size_f32();
                let d = format!(
                    "rational fit {} ({} coefficients)",
                    p.display(),
                    fitted.coefficients()
                );
                log.push(
                    Action::Prepared,
                    &what,
                    format!("read {d}; {}", domain_note(&fitted)),
                    start.elapsed().as_secs_f64(),
                );
                let fit = Arc::new(FitInDomain::new(fitted));
                let d = d + &precision_note(&fit);
                Built::fit(fit, bytes, d, key)
            }
            MaterialDescription::Fitted { .. } => self.build_fitted(name, &desc, key, log)?,
        };
        if is_analytic {
            log.push(
                Action::Prepared,
                &what,
                format!("analytic {}", built.description),
                start.elapsed().as_secs_f64(),
            );
        }
        Ok(built)
    }
}

/// What a fitted material's cache key adds to its basic settings. Fits
/// without a lobe, a cut or a byte budget keep the keys they had before
/// those keys existed; a target fit names its validation renders and time
/// budget, so that a fit chosen on other renders is not read back, and
/// whether its coefficient budget was named (`target`: the coefficient
/// choice of a target fit; `None` for a plain fit).
fn key_additions(
    lobe: bool,
    max_elevation: Option<f64>,
    max_bytes: Option<usize>,
    target: Option<crate::fidelity::TargetCoefficients>,
) -> String {
    let mut text = String::new();
    if lobe {
        text += " lobe=ggx";
    }
    if let Some(e) = max_elevation {
        text += &format!(" max_elevation={e}");
    }
    if let Some(b) = max_bytes {
        text += &format!(" max_bytes={b}");
    }
    if let Some(coefficients) = target {
        let v = crate::fidelity::ValidationSettings::default();
        text += &format!(
            " validation={}px,{}spp,seed{},{}s",
            v.size,
            v.sky_spp,
            v.seed,
            crate::fidelity::TARGET_TIME_BUDGET_S
        );
        // The search may end in RGB on the slice: a fit chosen by the
        // luminance-chroma searches alone is not read back.
        text += " colour=auto";
        // A budget the scene named is not raised by the search.
        if coefficients == crate::fidelity::TargetCoefficients::Fixed {
            text += " max_coeffs=named";
        }
        text += &format!(" search={}", crate::fidelity::TARGET_SEARCH_REVISION);
    }
    text
}

/// A scene's `target_de` fit: luminance-chroma (and RGB when the chroma
/// ratios limit the slice) over the whole hemisphere
/// (or within `max_elevation`), the 2-D slice and the grid of
/// [`crate::fidelity::TARGET_GRID_3D`] in the order of
/// [`crate::fidelity::fit_to_target`], validated on the renders `ratfit fit --target-de` uses
/// ([`crate::fidelity::ValidationSettings::default`]) within
/// [`crate::fidelity::TARGET_TIME_BUDGET_S`] and `max_bytes`, with the
/// coefficient budget raised or not as `coefficients` says, so that both
/// return the same fit; returns the fit and what it reached.
fn fit_for_target(
    src: &Arc<dyn Brdf>,
    target: f64,
    settings: BrdfFitSettings,
    (max_elevation, max_bytes, coefficients): (
        Option<f64>,
        Option<usize>,
        crate::fidelity::TargetCoefficients,
    ),
) -> Result<(FittedBrdf, String), RenderError> {
    let budget = crate::fidelity::TargetBudget::seconds(crate::fidelity::TARGET_TIME_BUDGET_S)
        .with_bytes(max_bytes);
    let engine = settings
        .fit_settings()
        .clone()
        .with_search(rational_core::Search::Staircase);
    let base = crate::fidelity::target_settings(engine).with_lobe(settings.lobe().cloned());
    let settings = match max_elevation {
        Some(degrees) => {
            let grid = base.reduction().with_max_elevation(degrees);
            base.with_reduction(grid)
        }
        None => base,
    };
    let (fitted, report) = crate::fidelity::fit_to_target(
        src.clone(),
        target,
        &settings,
        crate::fidelity::TargetChoices {
            coefficients,
            ..Default::default()
        },
        crate::fidelity::ValidationSettings::default(),
        budget,
    )?;
    let summary = format!(
        "target CIEDE2000 {}: {}",
        report.target_de,
        report.to_string().lines().next().unwrap_or_default()
    );
    Ok((fitted, summary))
}

fn domain_note(fit: &FittedBrdf) -> String {
    format!(
        "evaluated at {} degrees beyond its sampled elevations",
        fit.reduction.max_elevation_deg
    )
}

fn fit_settings(
    rel_tol: f64,
    dims: usize,
    max_coeffs: usize,
    max_elevation: Option<f64>,
) -> Result<BrdfFitSettings, brdf::BrdfError> {
    let kind = match dims {
        2 => ReductionKind::Slice2d,
        3 => ReductionKind::Full3d,
        d => {
            return Err(brdf::BrdfError::Invalid {
                name: "dims",
                reason: format!("{d}: use 2 or 3"),
            })
        }
    };
    let mut r = Reduction::default().with_kind(kind);
    if dims == 3 {
        r = r.with_resolution(45, 45).with_phi_resolution(45);
    }
    if let Some(degrees) = max_elevation {
        if !(degrees > 0.0 && degrees <= 90.0) {
            return Err(brdf::BrdfError::Invalid {
                name: "max_elevation",
                reason: format!("{degrees} degrees is not in (0, 90]"),
            });
        }
        r = r.with_max_elevation(degrees);
    }
    // Widening keeps a scene rendering when the intervals asked for have no
    // fit within the budget; the log names the factor.
    let engine = rational_core::FitSettings::default()
        .with_coeff_range(2, max_coeffs)
        .and_then(|s| s.with_widening(2.0, 4))
        .map_err(|e| brdf::BrdfError::Invalid {
            name: "max_coeffs",
            reason: e.to_string(),
        })?;
    Ok(BrdfFitSettings::default()
        .with_reduction(r)
        .with_rel_tol(rel_tol)?
        .with_baselines(false)
        .with_fit_settings(engine))
}

pub(super) fn build_sampler(
    name: &str,
    brdf: &Arc<dyn Brdf>,
    key: u64,
    kind: SamplerKind,
    samples_brdf: bool,
    cache: &Cache,
    log: &mut PrepareLog,
) -> Result<(Arc<dyn Sampler>, usize), RenderError> {
    let what = format!("{} sampler for {name}", kind.name());
    if kind == SamplerKind::Cosine {
        return Ok((Arc::new(CosineSampler), 0));
    }
    if !samples_brdf {
        log.push(
            Action::Skipped,
            what,
            "the integrator never samples the BRDF (direct lighting from delta lights only)",
            0.0,
        );
        return Ok((Arc::new(CosineSampler), 0));
    }
    let err = |e| RenderError::Sampler {
        name: name.to_string(),
        source: e,
    };
    let start = Instant::now();
    let table_settings = TableSettings::default();
    if kind == SamplerKind::Rational {
        let settings_text = format!(
            "rational cdf {table_settings:?} {:?}",
            CdfFitSettings::default()
        );
        let ckey = content_hash(&[&key.to_le_bytes(), settings_text.as_bytes()]);
        if let Some(cdf) = cache
            .get("cdf", ckey, &settings_text)
            .and_then(|v| RationalCdf::from_json(&v.to_string()).ok())
        {
            let bytes = cdf.byte_size_f32();
            log.push(
                Action::Cached,
                what,
                format!("inverse CDFs read from the cache, {bytes} bytes"),
                start.elapsed().as_secs_f64(),
            );
            return Ok((Arc::new(RationalSampler::new(cdf)), bytes));
        }
        let table = CdfTable::new(brdf.as_ref(), table_settings).map_err(err)?;
        let (cdf, _report) = cdf::fit_table(&table, &CdfFitSettings::default()).map_err(err)?;
        let bytes = cdf.byte_size_f32();
        let payload = serde_json::from_str(&cdf.to_json()).unwrap_or_default();
        let stored = cache.put("cdf", ckey, &settings_text, payload);
        log.push(
            Action::Prepared,
            what,
            format!("tabulated and fitted inverse CDFs, {bytes} bytes; {stored}"),
            start.elapsed().as_secs_f64(),
        );
        return Ok((Arc::new(RationalSampler::new(cdf)), bytes));
    }
    let table = CdfTable::new(brdf.as_ref(), table_settings).map_err(err)?;
    let bytes = table.byte_size_f32();
    log.push(
        Action::Prepared,
        what,
        format!("tabulated CDFs and pdf, {bytes} bytes"),
        start.elapsed().as_secs_f64(),
    );
    Ok((Arc::new(TabulatedSampler::new(table)), bytes))
}

/// Says when a fit is evaluated in f64 because its f32 form disagrees.
fn precision_note(fit: &FitInDomain) -> String {
    if fit.uses_f32() {
        String::new()
    } else {
        format!(
            "; evaluated in f64: its f32 form differs by {:.1e} (relative), beyond {:.0e}, and a GPU render of it is not exact",
            fit.f32_error(),
            crate::scene::F32_TOLERANCE
        )
    }
}

#[cfg(test)]
mod tests {
    use super::key_additions;

    #[test]
    fn a_target_fit_is_keyed_by_its_search_and_plain_fits_keep_their_keys() {
        use crate::fidelity::TargetCoefficients;
        assert_eq!(key_additions(false, None, None, None), "");
        let target = key_additions(false, None, Some(1024), Some(TargetCoefficients::Auto));
        let revision = format!(" search={}", crate::fidelity::TARGET_SEARCH_REVISION);
        assert!(target.ends_with(&revision), "{target}");
        assert!(target.contains(" max_bytes=1024"), "{target}");
        // A named coefficient budget, which the search does not raise, is
        // another fit.
        let named = key_additions(false, None, Some(1024), Some(TargetCoefficients::Fixed));
        assert_ne!(named, target);
    }
}
