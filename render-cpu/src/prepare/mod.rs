//! From a scene description to a renderable [`Scene`], preparing only what
//! the scene needs: materials no object uses are never loaded; a fit is
//! computed only when an object uses a fitted material and no cached fit
//! (keyed by the content hash of the data and the settings) exists; inverse
//! CDFs are tabulated or fitted only when the integrator samples the BRDF.
//! Every decision is written to the [`PrepareLog`].

mod cache;
mod checks;
mod materials;
mod shapes;

pub use cache::content_hash;
pub use checks::resolve_path;
pub use shapes::spiral_directions;

use crate::camera::Camera;
use crate::description::{
    IntegratorKind, LightDescription, MaterialDescription, SamplerKind, SceneDescription,
};
use crate::error::RenderError;
use crate::math::{dot, normalize};
use crate::scene::{IntegratorSettings, Object, PreparedMaterial, Scene};
use cache::Cache;
use checks::{check_positive, check_vec, scene_error};
use materials::{build_sampler, MaterialBuilder};
use shapes::{build_environment, build_light, build_shape};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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
#[non_exhaustive]
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
    apply_swaps(&mut desc, origin, &options.swaps)?;
    let integrator = integrator_settings(&desc, origin, options)?;
    let camera = build_camera(&desc, origin, options)?;
    let exposure = check_positive(origin, "film.exposure", desc.film.exposure)?;
    let used = used_materials(&desc, origin, &mut log)?;
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
        visiting: Vec::new(),
    };
    let materials = prepare_materials(
        &mut builder,
        &used,
        integrator.sampler,
        samples_brdf,
        &mut log,
    )?;
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
            "at each light sample its density is looked up in a grid built once by inverting the fitted map (the weights stay unbiased; each BRDF sample's own weight keeps the map's exact Jacobian)",
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

/// Builds the materials the scene uses, in `used`'s order, each with its
/// sampler of `kind` (a cosine one where nothing samples the BRDF).
fn prepare_materials(
    builder: &mut MaterialBuilder,
    used: &[String],
    kind: SamplerKind,
    samples_brdf: bool,
    log: &mut PrepareLog,
) -> Result<Vec<PreparedMaterial>, RenderError> {
    let mut materials = Vec::new();
    for name in used {
        let materials::Built {
            brdf,
            bytes: brdf_bytes,
            description,
            key,
            closed_form,
        } = builder.build(name, log)?;
        let (sampler, sampler_bytes) =
            build_sampler(name, &brdf, key, kind, samples_brdf, builder.cache, log)?;
        materials.push(PreparedMaterial {
            name: name.clone(),
            description,
            brdf,
            brdf_bytes,
            sampler,
            sampler_bytes,
            closed_form,
        });
    }
    Ok(materials)
}

/// Puts material `to` on every object that uses `from`, for each swap.
fn apply_swaps(
    desc: &mut SceneDescription,
    origin: &str,
    swaps: &[(String, String)],
) -> Result<(), RenderError> {
    for (from, to) in swaps {
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
    Ok(())
}

/// The camera, with the options' resolution, every value checked.
fn build_camera(
    desc: &SceneDescription,
    origin: &str,
    options: &RenderOptions,
) -> Result<Camera, RenderError> {
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
    let forward = crate::math::sub(to, from);
    if dot(forward, forward) <= 0.0 {
        return Err(scene_error(
            origin,
            "camera.from and camera.to coincide".into(),
        ));
    }
    if crate::math::length(crate::math::cross(normalize(forward), normalize(up))) < 1e-9 {
        return Err(scene_error(
            origin,
            "camera.up is parallel to the viewing direction".into(),
        ));
    }
    Ok(Camera::new(from, to, up, cam.fov_deg, width, height))
}

/// The materials objects use, in order of first use (each must be defined);
/// the others are logged as skipped.
fn used_materials(
    desc: &SceneDescription,
    origin: &str,
    log: &mut PrepareLog,
) -> Result<Vec<String>, RenderError> {
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
    Ok(used)
}

/// Most samples per pixel a scene may ask for (about a million: far beyond
/// convergence, and a bound on the time a typo can cost).
pub const MAX_SPP: usize = 1 << 20;

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
        pattern: i.pattern,
        jitter: i.jitter,
        max_depth: i.max_depth,
        shadows: i.shadows,
    };
    if !(1..=MAX_SPP).contains(&s.spp) {
        return Err(scene_error(
            origin,
            format!("integrator.spp {} is outside 1..={MAX_SPP}", s.spp),
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
