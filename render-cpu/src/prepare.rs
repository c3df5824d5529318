//! From a scene description to a renderable [`Scene`], preparing only what
//! the scene needs: materials no object uses are never loaded; a fit is
//! computed only when an object uses a fitted material and no cached fit
//! (keyed by the content hash of the data and the settings) exists; inverse
//! CDFs are tabulated or fitted only when the integrator samples the BRDF.
//! Every decision is written to the [`PrepareLog`].

use crate::camera::Camera;
use crate::error::{invalid, io, RenderError};
use crate::geometry::Shape;
use crate::image::Image;
use crate::light::{area_normal, Environment, EnvironmentMap, Light};
use crate::math::{dot, normalize, Frame, Vec3};
use crate::mesh::TriangleMesh;
use crate::scene::{
    EnvironmentDescription, IntegratorKind, LightDescription, MaterialDescription,
    ObjectDescription, SamplerKind, SceneDescription,
};
use crate::world::{FitInDomain, IntegratorSettings, Object, PreparedMaterial, Scene};
use brdf::{
    AshikhminShirley, BlinnPhong, Brdf, BrdfFitSettings, CookTorranceGgx, FittedBrdf, Lambert,
    MerlBrdf, Reduction, ReductionKind, RglBrdf,
};
use cdf::{
    CdfFitSettings, CdfTable, CosineSampler, RationalCdf, RationalSampler, Sampler, TableSettings,
    TabulatedSampler,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// Version of cached files; bump when fits change meaning.
const CACHE_VERSION: &str = "ratfit-render-cache-2";

/// Overrides of a scene's settings, for the command line and studies.
#[derive(Debug, Clone, Default)]
pub struct RenderOptions {
    /// Image size.
    pub resolution: Option<(usize, usize)>,
    /// Samples per pixel.
    pub spp: Option<usize>,
    /// Seed.
    pub seed: Option<u64>,
    /// BRDF sampling strategy.
    pub sampler: Option<SamplerKind>,
    /// Multiple importance sampling on or off.
    pub mis: Option<bool>,
    /// `(from, to)`: objects using material `from` use `to` instead.
    pub swaps: Vec<(String, String)>,
    /// Cache directory for fits and inverse CDFs (default: `$RATFIT_CACHE`,
    /// else `$XDG_CACHE_HOME/ratfit`, else `$HOME/.cache/ratfit`).
    pub cache_dir: Option<PathBuf>,
    /// Never read or write the cache.
    pub no_cache: bool,
}

/// What preparation did with one item.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// Loaded or computed.
    Prepared,
    /// Read from the cache.
    Cached,
    /// Not needed.
    Skipped,
}

/// One decision of the preparation.
#[derive(Debug, Clone)]
pub struct LogEntry {
    /// What was done.
    pub action: Action,
    /// The item.
    pub what: String,
    /// Why, and what it cost.
    pub why: String,
    /// Seconds spent.
    pub seconds: f64,
}

/// The decisions of [`prepare`], in order.
#[derive(Debug, Clone, Default)]
pub struct PrepareLog {
    /// Entries.
    pub entries: Vec<LogEntry>,
}

impl PrepareLog {
    fn push(&mut self, action: Action, what: impl Into<String>, why: impl Into<String>, t: f64) {
        self.entries.push(LogEntry {
            action,
            what: what.into(),
            why: why.into(),
            seconds: t,
        });
    }

    /// Entries with `action` whose item contains `needle`.
    pub fn find(&self, action: Action, needle: &str) -> Vec<&LogEntry> {
        self.entries
            .iter()
            .filter(|e| e.action == action && e.what.contains(needle))
            .collect()
    }
}

impl std::fmt::Display for PrepareLog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for e in &self.entries {
            let tag = match e.action {
                Action::Prepared => "prepared",
                Action::Cached => "cached  ",
                Action::Skipped => "skipped ",
            };
            writeln!(f, "  {tag} {:<40} {} ({:.2} s)", e.what, e.why, e.seconds)?;
        }
        Ok(())
    }
}

/// FNV-1a, 64 bits: a content key for cache files (the cached file also
/// stores the full settings, checked on load).
pub fn content_hash(parts: &[&[u8]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for p in parts {
        for &b in *p {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
        // Separate parts so that ("ab", "c") and ("a", "bc") differ.
        h ^= 0xff;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

struct Cache {
    dir: Option<PathBuf>,
}

impl Cache {
    fn new(options: &RenderOptions) -> Self {
        if options.no_cache {
            return Self { dir: None };
        }
        let env = |k: &str| {
            std::env::var_os(k)
                .filter(|v| !v.is_empty())
                .map(PathBuf::from)
        };
        let dir = options
            .cache_dir
            .clone()
            .or_else(|| env("RATFIT_CACHE"))
            .or_else(|| env("XDG_CACHE_HOME").map(|d| d.join("ratfit")))
            .or_else(|| env("HOME").map(|d| d.join(".cache").join("ratfit")));
        Self { dir }
    }

    fn path(&self, kind: &str, key: u64) -> Option<PathBuf> {
        self.dir
            .as_ref()
            .map(|d| d.join(format!("{kind}-{key:016x}.json")))
    }

    /// The cached payload for `settings`, if present and made with them.
    fn get(&self, kind: &str, key: u64, settings: &str) -> Option<serde_json::Value> {
        let text = std::fs::read_to_string(self.path(kind, key)?).ok()?;
        let v: serde_json::Value = serde_json::from_str(&text).ok()?;
        (v.get("settings")?.as_str()? == settings).then(|| v.get("payload").cloned())?
    }

    /// Stores a payload; a cache that cannot be written is not an error
    /// (the log says so).
    fn put(&self, kind: &str, key: u64, settings: &str, payload: serde_json::Value) -> String {
        let Some(path) = self.path(kind, key) else {
            return "not cached (no cache directory)".into();
        };
        let doc = serde_json::json!({ "settings": settings, "payload": payload });
        let write = || -> std::io::Result<()> {
            std::fs::create_dir_all(path.parent().unwrap_or(Path::new(".")))?;
            let tmp = path.with_extension("tmp");
            std::fs::write(&tmp, doc.to_string())?;
            std::fs::rename(&tmp, &path)
        };
        match write() {
            Ok(()) => format!("cached as {}", path.display()),
            Err(e) => format!("not cached ({}: {e})", path.display()),
        }
    }
}

/// Resolves a path in a scene file: relative to the scene's directory, with
/// `$RATFIT_DATA/` the data directory (`RATFIT_DATA`, else a `shared/data`
/// directory above the scene or the working directory).
///
/// # Errors
/// `$RATFIT_DATA/` used but no data directory found.
pub fn resolve_path(base: &Path, p: &str) -> Result<PathBuf, RenderError> {
    if let Some(rest) = p.strip_prefix("$RATFIT_DATA/") {
        return Ok(data_dir(base)?.join(rest));
    }
    let path = Path::new(p);
    Ok(if path.is_absolute() {
        path.to_path_buf()
    } else {
        base.join(path)
    })
}

fn data_dir(base: &Path) -> Result<PathBuf, RenderError> {
    if let Some(d) = std::env::var_os("RATFIT_DATA").filter(|v| !v.is_empty()) {
        return Ok(PathBuf::from(d));
    }
    let cwd = std::env::current_dir().unwrap_or_default();
    let base = if base.is_absolute() {
        base.to_path_buf()
    } else {
        cwd.join(base)
    };
    base.ancestors()
        .chain(cwd.ancestors())
        .map(|a| a.join("shared").join("data"))
        .find(|d| d.is_dir())
        .ok_or_else(|| {
            invalid(
                "data directory",
                format!(
                    "`$RATFIT_DATA/` is used but RATFIT_DATA is not set and no shared/data directory is above {}",
                    base.display()
                ),
            )
        })
}

fn scene_error(origin: &str, reason: String) -> RenderError {
    RenderError::Scene {
        path: origin.to_string(),
        reason,
    }
}

fn check_vec(origin: &str, what: &str, v: [f64; 3], nonzero: bool) -> Result<Vec3, RenderError> {
    if v.iter().any(|x| !x.is_finite()) || (nonzero && dot(v, v) <= 0.0) {
        return Err(scene_error(
            origin,
            format!(
                "{what} {v:?} must be finite{}",
                if nonzero { " and non-zero" } else { "" }
            ),
        ));
    }
    Ok(v)
}

fn check_rgb(origin: &str, what: &str, v: [f64; 3]) -> Result<[f64; 3], RenderError> {
    if v.iter().any(|x| !x.is_finite() || *x < 0.0) {
        return Err(scene_error(
            origin,
            format!("{what} {v:?} must be finite and non-negative"),
        ));
    }
    Ok(v)
}

fn check_positive(origin: &str, what: &str, v: f64) -> Result<f64, RenderError> {
    if !(v.is_finite() && v > 0.0) {
        return Err(scene_error(origin, format!("{what} {v} must be positive")));
    }
    Ok(v)
}

/// Reads and prepares a scene file.
///
/// # Errors
/// See [`prepare`].
pub fn prepare_file(
    path: &Path,
    options: &RenderOptions,
) -> Result<(Scene, PrepareLog), RenderError> {
    let desc = SceneDescription::read(path)?;
    let base = path.parent().unwrap_or(Path::new("."));
    prepare(desc, base, &path.display().to_string(), options)
}

/// Prepares a scene: applies `options`, checks every value, loads, fits or
/// reads from the cache only what the scene uses. Paths are relative to
/// `base`; `origin` names the scene in errors.
///
/// # Errors
/// Invalid values, unknown materials, unreadable files, fits or inverse
/// CDFs that fail.
pub fn prepare(
    mut desc: SceneDescription,
    base: &Path,
    origin: &str,
    options: &RenderOptions,
) -> Result<(Scene, PrepareLog), RenderError> {
    let mut log = PrepareLog::default();
    for (from, to) in &options.swaps {
        if !desc.materials.contains_key(to) {
            return Err(scene_error(
                origin,
                format!("swap {from}={to}: no material `{to}`"),
            ));
        }
        let mut hits = 0;
        for o in &mut desc.objects {
            if o.material() == from {
                o.set_material(to);
                hits += 1;
            }
        }
        if hits == 0 {
            return Err(scene_error(
                origin,
                format!("swap {from}={to}: no object uses `{from}`"),
            ));
        }
    }
    let integrator = integrator_settings(&desc, origin, options)?;
    let cam = &desc.camera;
    let (width, height) = options.resolution.unwrap_or((cam.width, cam.height));
    if !(1..=16_384).contains(&width) || !(1..=16_384).contains(&height) {
        return Err(scene_error(
            origin,
            format!("resolution {width}x{height} is outside 1..=16384"),
        ));
    }
    if !(cam.fov_deg > 0.0 && cam.fov_deg < 180.0) {
        return Err(scene_error(
            origin,
            format!("fov_deg {} is outside (0, 180)", cam.fov_deg),
        ));
    }
    let from = check_vec(origin, "camera.from", cam.from, false)?;
    let to = check_vec(origin, "camera.to", cam.to, false)?;
    let up = check_vec(origin, "camera.up", cam.up, true)?;
    if dot(crate::math::sub(to, from), crate::math::sub(to, from)) <= 0.0 {
        return Err(scene_error(
            origin,
            "camera.from and camera.to coincide".into(),
        ));
    }
    let camera = Camera::new(from, to, up, cam.fov_deg, width, height);
    let exposure = check_positive(origin, "film.exposure", desc.film.exposure)?;

    // Materials: only those objects use, in order of first use.
    let mut used: Vec<String> = Vec::new();
    for o in &desc.objects {
        let m = o.material().to_string();
        if !desc.materials.contains_key(&m) {
            return Err(scene_error(
                origin,
                format!("an object uses material `{m}`, which is not defined"),
            ));
        }
        if !used.contains(&m) {
            used.push(m);
        }
    }
    let sources: Vec<&String> = used
        .iter()
        .filter_map(|n| match &desc.materials[n] {
            MaterialDescription::Fitted { source, .. } => Some(source),
            _ => None,
        })
        .collect();
    for name in desc.materials.keys().filter(|n| !used.contains(n)) {
        let why = if sources.contains(&name) {
            "no object uses it; loaded only if its fit is not cached"
        } else {
            "no object uses it"
        };
        log.push(Action::Skipped, format!("material {name}"), why, 0.0);
    }
    let samples_brdf = integrator.kind == IntegratorKind::Path
        || desc.environment.is_some()
        || desc
            .lights
            .iter()
            .any(|l| matches!(l, LightDescription::Area { .. }));
    let cache = Cache::new(options);
    let mut builder = MaterialBuilder {
        materials: &desc.materials,
        base,
        origin,
        cache: &cache,
        keys: BTreeMap::new(),
    };
    let mut materials = Vec::new();
    for name in &used {
        let (brdf, brdf_bytes, description, key) = builder.build(name, &mut log)?;
        let (sampler, sampler_bytes) = build_sampler(
            name,
            &brdf,
            key,
            integrator.sampler,
            samples_brdf,
            &cache,
            &mut log,
        )?;
        materials.push(PreparedMaterial {
            name: name.clone(),
            description,
            brdf,
            brdf_bytes,
            sampler,
            sampler_bytes,
        });
    }

    let mut objects = Vec::new();
    for o in &desc.objects {
        let shape = build_shape(o, base, origin, &mut log)?;
        let material = used.iter().position(|n| n == o.material());
        objects.push(Object {
            shape,
            material,
            emission: None,
        });
    }
    let mut lights = Vec::new();
    for l in &desc.lights {
        build_light(l, origin, &mut lights, &mut objects)?;
    }
    let environment = match &desc.environment {
        None => None,
        Some(e) => Some(build_environment(e, base, origin, &mut log)?),
    };
    if lights.is_empty() && environment.is_none() {
        return Err(scene_error(
            origin,
            "the scene has no light and no environment".into(),
        ));
    }
    if integrator.mis && integrator.sampler == SamplerKind::Rational && samples_brdf {
        log.push(
            Action::Prepared,
            "MIS weights for the rational sampler",
            "its pdf is found by inverting the fitted map at each light sample (the pdf-free estimator needs mis = false)",
            0.0,
        );
    }
    Ok((
        Scene {
            camera,
            exposure,
            objects,
            lights,
            environment,
            materials,
            integrator,
        },
        log,
    ))
}

fn integrator_settings(
    desc: &SceneDescription,
    origin: &str,
    options: &RenderOptions,
) -> Result<IntegratorSettings, RenderError> {
    let i = &desc.integrator;
    let s = IntegratorSettings {
        kind: i.kind,
        spp: options.spp.unwrap_or(i.spp),
        seed: options.seed.unwrap_or(i.seed),
        sampler: options.sampler.unwrap_or(i.sampler),
        mis: options.mis.unwrap_or(i.mis),
        max_depth: i.max_depth,
        shadows: i.shadows,
    };
    if s.spp == 0 {
        return Err(scene_error(
            origin,
            "integrator.spp must be at least 1".into(),
        ));
    }
    if s.kind == IntegratorKind::Path && !(1..=64).contains(&s.max_depth) {
        return Err(scene_error(
            origin,
            format!("integrator.max_depth {} is outside 1..=64", s.max_depth),
        ));
    }
    Ok(s)
}

struct MaterialBuilder<'a> {
    materials: &'a BTreeMap<String, MaterialDescription>,
    base: &'a Path,
    origin: &'a str,
    cache: &'a Cache,
    /// Content keys of materials already keyed.
    keys: BTreeMap<String, u64>,
}

type Built = (Arc<dyn Brdf>, usize, String, u64);

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
                if source == name {
                    return Err(scene_error(
                        self.origin,
                        format!("material `{name}` fits itself"),
                    ));
                }
                let s = self.key(source)?;
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

    fn build(&mut self, name: &str, log: &mut PrepareLog) -> Result<Built, RenderError> {
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
        let rgb =
            |v: [f64; 3], w: &str| check_rgb(self.origin, &format!("materials.{name}.{w}"), v);
        let analytic = |b: Arc<dyn Brdf>| -> Built {
            let d = b.name();
            (b, 0, d, key)
        };
        let built: Built = match desc {
            MaterialDescription::Lambert { albedo } => analytic(Arc::new(Lambert {
                albedo: rgb(albedo, "albedo")?,
            })),
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
                let (b, bytes): (Arc<dyn Brdf>, usize) = match format.as_str() {
                    "merl" => (
                        Arc::new(MerlBrdf::read(&p).map_err(|e| self.material_error(name, e))?),
                        brdf::merl::FILE_SIZE,
                    ),
                    "rgl" => (
                        Arc::new(RglBrdf::read(&p).map_err(|e| self.material_error(name, e))?),
                        std::fs::metadata(&p).map(|m| m.len() as usize).unwrap_or(0),
                    ),
                    other => {
                        return Err(scene_error(
                            self.origin,
                            format!("materials.{name}: unknown format `{other}` (merl, rgl)"),
                        ))
                    }
                };
                let d = format!("{format} table {}", p.display());
                log.push(
                    Action::Prepared,
                    &what,
                    format!("loaded {d}, {bytes} bytes"),
                    start.elapsed().as_secs_f64(),
                );
                (b, bytes, d, key)
            }
            MaterialDescription::Fit { path } => {
                let p = resolve_path(self.base, &path)?;
                let text = std::fs::read_to_string(&p).map_err(|e| io(&p, e))?;
                let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
                    scene_error(self.origin, format!("{}: not JSON: {e}", p.display()))
                })?;
                let fitted: FittedBrdf =
                    serde_json::from_value(v.get("brdf").cloned().unwrap_or(v)).map_err(|e| {
                        scene_error(self.origin, format!("{}: not a BRDF fit: {e}", p.display()))
                    })?;
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
                (Arc::new(FitInDomain::new(fitted)), bytes, d, key)
            }
            MaterialDescription::Fitted {
                source,
                rel_tol,
                dims,
                max_coeffs,
            } => {
                let settings_text = format!(
                    "fitted source={source} rel_tol={rel_tol} dims={dims} max_coeffs={max_coeffs}"
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
                        let (src, _, src_desc, _) = self.build(&source, log)?;
                        let settings = fit_settings(rel_tol, dims, max_coeffs)
                            .map_err(|e| self.material_error(name, e))?;
                        let (fitted, report) = brdf::fit_brdf(src.as_ref(), &settings)
                            .map_err(|e| self.material_error(name, e))?;
                        let stored = self.cache.put(
                            "fit",
                            key,
                            &settings_text,
                            serde_json::to_value(&fitted).unwrap_or_default(),
                        );
                        let worst = report
                            .channels
                            .iter()
                            .map(|c| c.max_rel)
                            .fold(0.0, f64::max);
                        log.push(Action::Prepared, &what, format!("fitted {src_desc} ({}-D, rel_tol {rel_tol}): {} coefficients, max rel error {worst:.3}; {stored}", dims, fitted.coefficients()), start.elapsed().as_secs_f64());
                        fitted
                    }
                };
                let bytes = fitted.byte_size_f32();
                let d = format!(
                    "rational fit of `{source}` ({} coefficients); {}",
                    fitted.coefficients(),
                    domain_note(&fitted)
                );
                (Arc::new(FitInDomain::new(fitted)), bytes, d, key)
            }
        };
        if is_analytic {
            log.push(
                Action::Prepared,
                &what,
                format!("analytic {}", built.2),
                start.elapsed().as_secs_f64(),
            );
        }
        Ok(built)
    }
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
    let engine = rational_core::FitSettings::default()
        .with_coeff_range(2, max_coeffs)
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

fn build_sampler(
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

fn build_shape(
    o: &ObjectDescription,
    base: &Path,
    origin: &str,
    log: &mut PrepareLog,
) -> Result<Shape, RenderError> {
    let v = |what: &str, x: [f64; 3]| check_vec(origin, what, x, false);
    let nz = |what: &str, x: [f64; 3]| check_vec(origin, what, x, true);
    let pos = |what: &str, x: f64| check_positive(origin, what, x);
    let tri = |n: usize| {
        if (8..=10_000_000).contains(&n) {
            Ok(n)
        } else {
            Err(scene_error(
                origin,
                format!("triangles {n} is outside 8..=10000000"),
            ))
        }
    };
    Ok(match o {
        ObjectDescription::Sphere { center, radius, .. } => Shape::Sphere {
            center: v("center", *center)?,
            radius: pos("radius", *radius)?,
        },
        ObjectDescription::Plane { point, normal, .. } => Shape::Plane {
            point: v("point", *point)?,
            normal: normalize(nz("normal", *normal)?),
        },
        ObjectDescription::Quad {
            corner, u, v: e2, ..
        } => {
            let (u, e2) = (nz("u", *u)?, nz("v", *e2)?);
            if crate::math::length(crate::math::cross(u, e2)) <= 0.0 {
                return Err(scene_error(
                    origin,
                    "quad edges u and v are parallel".into(),
                ));
            }
            Shape::Quad {
                corner: v("corner", *corner)?,
                u,
                v: e2,
            }
        }
        ObjectDescription::Mesh {
            path,
            scale,
            translate,
            ..
        } => {
            let start = Instant::now();
            let p = resolve_path(base, path)?;
            let mesh = TriangleMesh::read_obj(&p)?
                .transformed(pos("scale", *scale)?, v("translate", *translate)?);
            log.push(
                Action::Prepared,
                format!("mesh {}", p.display()),
                format!("{} triangles", mesh.triangle_count()),
                start.elapsed().as_secs_f64(),
            );
            Shape::Mesh(Box::new(mesh))
        }
        ObjectDescription::MeshSphere {
            center,
            radius,
            triangles,
            ..
        } => {
            let mesh = TriangleMesh::uv_sphere(
                v("center", *center)?,
                pos("radius", *radius)?,
                tri(*triangles)?,
            );
            log.push(
                Action::Prepared,
                "mesh sphere",
                format!("{} triangles", mesh.triangle_count()),
                0.0,
            );
            Shape::Mesh(Box::new(mesh))
        }
        ObjectDescription::Torus {
            center,
            major,
            minor,
            triangles,
            ..
        } => {
            let mesh = TriangleMesh::torus(
                v("center", *center)?,
                pos("major", *major)?,
                pos("minor", *minor)?,
                tri(*triangles)?,
            );
            log.push(
                Action::Prepared,
                "mesh torus",
                format!("{} triangles", mesh.triangle_count()),
                0.0,
            );
            Shape::Mesh(Box::new(mesh))
        }
    })
}

/// `count` unit directions on a Fibonacci spiral over the cone of
/// half-angle `max_angle` around `axis`, equal solid angle each.
pub fn spiral_directions(count: usize, axis: Vec3, max_angle: f64) -> Vec<Vec3> {
    let frame = Frame::from_normal(normalize(axis));
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let cos_max = max_angle.cos();
    (0..count)
        .map(|i| {
            let z = 1.0 - (1.0 - cos_max) * (i as f64 + 0.5) / count as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f64;
            frame.to_world([r * phi.cos(), r * phi.sin(), z])
        })
        .collect()
}

fn build_light(
    l: &LightDescription,
    origin: &str,
    lights: &mut Vec<Light>,
    objects: &mut Vec<Object>,
) -> Result<(), RenderError> {
    match l {
        LightDescription::Directional {
            direction,
            irradiance,
        } => lights.push(Light::Directional {
            direction: normalize(check_vec(origin, "light direction", *direction, true)?),
            irradiance: check_rgb(origin, "irradiance", *irradiance)?,
        }),
        LightDescription::DirectionalSet {
            count,
            irradiance,
            axis,
            max_angle_deg,
        } => {
            if !(1..=100_000).contains(count) {
                return Err(scene_error(
                    origin,
                    format!("directional-set count {count} is outside 1..=100000"),
                ));
            }
            if !(*max_angle_deg > 0.0 && *max_angle_deg <= 180.0) {
                return Err(scene_error(
                    origin,
                    format!("max_angle_deg {max_angle_deg} is outside (0, 180]"),
                ));
            }
            let e = check_rgb(origin, "irradiance", *irradiance)?.map(|x| x / *count as f64);
            let axis = check_vec(origin, "axis", *axis, true)?;
            for d in spiral_directions(*count, axis, max_angle_deg.to_radians()) {
                lights.push(Light::Directional {
                    direction: d,
                    irradiance: e,
                });
            }
        }
        LightDescription::Point {
            position,
            intensity,
        } => lights.push(Light::Point {
            position: check_vec(origin, "position", *position, false)?,
            intensity: check_rgb(origin, "intensity", *intensity)?,
        }),
        LightDescription::Area {
            corner,
            u,
            v,
            radiance,
        } => {
            let (corner, u, v) = (
                check_vec(origin, "corner", *corner, false)?,
                check_vec(origin, "u", *u, true)?,
                check_vec(origin, "v", *v, true)?,
            );
            if crate::math::length(crate::math::cross(u, v)) <= 0.0 {
                return Err(scene_error(
                    origin,
                    "area light edges u and v are parallel".into(),
                ));
            }
            let radiance = check_rgb(origin, "radiance", *radiance)?;
            let _ = area_normal(u, v);
            objects.push(Object {
                shape: Shape::Quad { corner, u, v },
                material: None,
                emission: Some(radiance),
            });
            lights.push(Light::Area {
                corner,
                u,
                v,
                radiance,
                object: objects.len() - 1,
            });
        }
    }
    Ok(())
}

fn build_environment(
    e: &EnvironmentDescription,
    base: &Path,
    origin: &str,
    log: &mut PrepareLog,
) -> Result<Environment, RenderError> {
    Ok(match e {
        EnvironmentDescription::Uniform { radiance } => {
            Environment::Uniform(check_rgb(origin, "environment radiance", *radiance)?)
        }
        EnvironmentDescription::Sky {
            zenith,
            horizon,
            ground,
        } => Environment::Sky {
            zenith: check_rgb(origin, "zenith", *zenith)?,
            horizon: check_rgb(origin, "horizon", *horizon)?,
            ground: check_rgb(origin, "ground", *ground)?,
        },
        EnvironmentDescription::Image { path, scale } => {
            let start = Instant::now();
            let p = resolve_path(base, path)?;
            let img = Image::read_exr(&p)?;
            let (w, h) = (img.width, img.height);
            let map =
                EnvironmentMap::new(img, check_positive(origin, "environment scale", *scale)?);
            log.push(
                Action::Prepared,
                format!("environment {}", p.display()),
                format!("{w}x{h}, importance-sampling tables"),
                start.elapsed().as_secs_f64(),
            );
            Environment::Image(Box::new(map))
        }
    })
}
