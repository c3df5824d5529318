//! Render error of a BRDF representation against its table, on the two
//! validation scenes every fidelity figure of the project uses: a sphere
//! under three directional lights and a sphere under a sky with a ground
//! plane (direct lighting at the pixel centres; the sky sampled by the
//! table's own tabulated distributions and by the sky's, combined by MIS,
//! on scrambled Sobol' points).
//!
//! The table is rendered once per scene; each candidate is rendered with the
//! same seed, and the mean and 99th-percentile CIEDE2000 over the object's
//! pixels are reported: those whose pixel centre sees the sphere and that
//! are not black in both images. The sky and the ground around the sphere
//! are left out: they do not depend on its material, are identical in every
//! render with one seed, and would dilute the mean (the sphere covers about
//! 64% of the frame). A second render of the table with another seed
//! measures the noise floor of the comparison.

use crate::compare::compare;
use crate::description::SceneDescription;
use crate::image::Image;
use crate::integrator::render;
use crate::linear::LinearRender;
pub use crate::linear::MAX_RECORD_BYTES;
use crate::math::dot;
use crate::prepare::{prepare, RenderOptions};
use crate::scene::Scene;
use crate::RenderError;
use brdf::Brdf;
use serde::Serialize;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

mod cut;
mod fit_beside;
mod fit_parts;
mod split;
mod target;
mod target_choices;
mod target_grid;
mod target_larger_budget;
mod target_point;
mod target_report;
mod target_search;
mod target_searches;
mod target_walk;
mod target_within_cut;
pub use cut::{
    choose_evaluation_cut, render_check_choosing_cut, CutChoice, CutTried, EVALUATION_CUTS,
    LOWER_CUTS,
};
pub use split::{colour_split, ColourSplit};
pub use target::fit_to_target;
pub use target_choices::{
    on_target_grid, target_settings, TargetChoices, TargetCoefficients, TargetColour,
    TargetReduction, TargetScale, LARGER_BUDGET_FACTOR, LARGER_BUDGET_REACH, TARGET_GRID_3D,
    TARGET_MAX_COEFFS, TARGET_PHI, TARGET_SEARCH_REVISION, TARGET_SLICE, TARGET_TIME_BUDGET_S,
};
pub use target_grid::{GridChoice, TargetGrid, FINE_GRID_FLOOR_FACTOR, TARGET_FINE_GRID_3D};
pub use target_report::{
    GridFloor, PointChoice, SliceFloor, TargetAttempt, TargetBudget, TargetReport,
};

/// The two validation scenes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum ValidationScene {
    /// The sphere of `scenes/sphere-lights.toml`: three directional lights.
    Lights,
    /// The sphere of `scenes/sphere-sky.toml`: a sky and a grey ground.
    Sky,
}

impl ValidationScene {
    /// Both scenes.
    pub const ALL: [ValidationScene; 2] = [ValidationScene::Lights, ValidationScene::Sky];

    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            ValidationScene::Lights => "lights",
            ValidationScene::Sky => "sky",
        }
    }

    fn toml(self, size: usize, spp: usize) -> String {
        let common = "[materials.probe]\nkind = \"lambert\"\nalbedo = [0.5, 0.5, 0.5]\n\
             [[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"probe\"\n";
        match self {
            ValidationScene::Lights => format!(
                "[camera]\nfrom = [0.0, 0.0, 4.0]\nto = [0.0, 0.0, 0.0]\nfov_deg = 32.0\nwidth = {size}\nheight = {size}\n\
                 [integrator]\nkind = \"direct\"\nspp = {spp}\npattern = \"lattice\"\n{common}\
                 [[lights]]\nkind = \"directional\"\ndirection = [0.5, 0.6, 0.8]\nirradiance = [5.0, 5.0, 5.0]\n\
                 [[lights]]\nkind = \"directional\"\ndirection = [-0.7, 0.1, 0.6]\nirradiance = [1.6, 1.6, 1.6]\n\
                 [[lights]]\nkind = \"directional\"\ndirection = [0.1, -0.8, 0.3]\nirradiance = [1.2, 1.2, 1.2]\n"
            ),
            ValidationScene::Sky => format!(
                "[camera]\nfrom = [0.0, 0.4, 4.0]\nto = [0.0, 0.0, 0.0]\nfov_deg = 32.0\nwidth = {size}\nheight = {size}\n\
                 [integrator]\nkind = \"direct\"\nspp = {spp}\npattern = \"lattice\"\njitter = false\nsampler = \"tabulated\"\nmis = true\n{common}\
                 [materials.ground]\nkind = \"lambert\"\nalbedo = [0.4, 0.4, 0.4]\n\
                 [[objects]]\nshape = \"plane\"\npoint = [0.0, -1.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\nmaterial = \"ground\"\n\
                 [environment]\nkind = \"sky\"\nzenith = [0.9, 1.0, 1.3]\nhorizon = [1.6, 1.5, 1.3]\nground = [0.2, 0.18, 0.15]\n"
            ),
        }
    }
}

/// Image size and samples of the validation renders.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ValidationSettings {
    /// Width and height in pixels.
    pub size: usize,
    /// Samples per pixel of the lights scene (pixel jitter only).
    pub lights_spp: usize,
    /// Samples per pixel of the sky scene.
    pub sky_spp: usize,
    /// Seed of the candidates' renders (the table's second render uses
    /// `seed + 1`).
    pub seed: u64,
}

impl Default for ValidationSettings {
    /// 96 x 96 pixels, 1 spp at the pixel centres under the lights (no
    /// noise at all), 256 under the sky (two renders of a table with
    /// different seeds differ by 0.2 to 0.6 mean CIEDE2000; 1024 brings it
    /// to 0.1 to 0.25).
    fn default() -> Self {
        Self {
            size: 96,
            lights_spp: 1,
            sky_spp: 256,
            seed: 1,
        }
    }
}

/// Render error on one scene.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SceneError {
    /// Mean CIEDE2000 over the object's pixels where either image is not
    /// black.
    pub mean_de: f64,
    /// 99th percentile of CIEDE2000 over the same pixels.
    pub p99_de: f64,
    /// Mean CIEDE2000 over the silhouette: those of the pixels that view
    /// the sphere more than [`SILHOUETTE_DEG`] from its normal (about 12%
    /// of them), where a fit meets the table's least trusted values.
    pub silhouette_mean_de: f64,
    /// Pixels of the candidate's render that are not finite (a pole of a
    /// fit, say); they count as white, far from any measured colour.
    pub non_finite_pixels: usize,
}

/// A candidate's render errors, lights first.
#[derive(Debug, Clone, Serialize)]
pub struct RenderErrors {
    /// Per scene, in [`ValidationScene::ALL`] order.
    pub scenes: Vec<SceneError>,
    /// The candidate's renders, same order.
    #[serde(skip)]
    pub images: Vec<Image>,
    /// Render time in seconds (both scenes).
    pub seconds: f64,
    /// Which part of the error is the luminance's and which the colour's,
    /// when measured ([`colour_split`]; the render checks measure it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub colour_split: Option<ColourSplit>,
}

impl RenderErrors {
    /// The larger mean CIEDE2000 of the two scenes.
    pub fn worst_mean(&self) -> f64 {
        self.scenes.iter().map(|s| s.mean_de).fold(0.0, f64::max)
    }
}

/// A candidate's values at the samples of each validation render
/// ([`Validator::sample_values`]; `None` for a render not recorded).
pub(crate) struct SampleValues(Vec<Option<Vec<[f64; 3]>>>);

/// The table's renders on both scenes, against which candidates are measured.
///
/// Every candidate is rendered with the same seed and the table's sampler,
/// so both renders are linear in the candidate: they are recorded once
/// (the directions each sample evaluates and their weights, about 60 MB
/// at the default settings, at most [`MAX_RECORD_BYTES`]) and each
/// [`Validator::measure`] evaluates the candidate at those directions
/// instead of rendering again, with the render's own estimator and
/// evaluation paths: the same images, in 0.26 s instead of 1.25 s for
/// cm_military_green's fits (median of 43 candidates, 2 cores).
pub struct Validator {
    scenes: Vec<Scene>,
    /// Per scene, what each pixel's centre sees.
    masks: Vec<Vec<PixelKind>>,
    references: Vec<Image>,
    /// Per scene, the candidates' render recorded as linear in the
    /// sphere's BRDF (`None` where it is too large to hold).
    recorded: Vec<Option<LinearRender>>,
    /// Render error of the table against itself with another seed: the
    /// comparison's noise floor.
    pub noise: Vec<SceneError>,
    /// The settings used.
    pub settings: ValidationSettings,
}

/// The material slot of a validation scene's sphere (its first object).
fn sphere_material(scene: &Scene) -> usize {
    scene.objects[0]
        .material
        .expect("the sphere has a material")
}

/// The validation scenes at `settings`' size and samples, lights first.
fn validation_scenes(settings: ValidationSettings) -> Result<Vec<Scene>, RenderError> {
    let mut scenes = Vec::new();
    for kind in ValidationScene::ALL {
        let spp = match kind {
            ValidationScene::Lights => settings.lights_spp,
            ValidationScene::Sky => settings.sky_spp,
        };
        let text = kind.toml(settings.size, spp);
        let desc = SceneDescription::parse(&text, kind.name())?;
        let options = RenderOptions {
            no_cache: true,
            seed: Some(settings.seed),
            ..Default::default()
        };
        let (scene, _) = prepare(desc, Path::new("."), kind.name(), &options)?;
        scenes.push(scene);
    }
    Ok(scenes)
}

/// View elevation (degrees from the normal) beyond which a pixel of the
/// sphere counts as its silhouette.
pub const SILHOUETTE_DEG: f64 = 70.0;

/// What a pixel's centre sees.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PixelKind {
    /// Anything but the sphere: the same in every render.
    Off,
    /// The sphere, viewed within [`SILHOUETTE_DEG`] of its normal.
    Interior,
    /// The sphere, viewed further from its normal.
    Silhouette,
}

/// What each pixel centre of `scene` sees (both scenes render at the pixel
/// centres; the sphere is the first object).
fn object_mask(scene: &Scene) -> Vec<PixelKind> {
    let (w, h) = (scene.camera.width(), scene.camera.height());
    let grazing = SILHOUETTE_DEG.to_radians().cos();
    (0..w * h)
        .map(|n| {
            let ray = scene.camera.ray((n % w) as f64 + 0.5, (n / w) as f64 + 0.5);
            match scene.intersect(&ray) {
                Some((hit, 0)) => {
                    if -dot(ray.dir, hit.shading_normal) < grazing {
                        PixelKind::Silhouette
                    } else {
                        PixelKind::Interior
                    }
                }
                _ => PixelKind::Off,
            }
        })
        .collect()
}

fn scene_error(a: &Image, b: &Image, mask: &[PixelKind]) -> Result<SceneError, RenderError> {
    // A non-finite pixel would make every mean NaN: it is counted, and
    // compared as a bright white (as a display would clip it).
    let non_finite_pixels = b
        .pixels
        .iter()
        .filter(|p| p.iter().any(|v| !v.is_finite()))
        .count();
    let sanitised;
    let b = if non_finite_pixels > 0 {
        sanitised = Image::new(
            b.width,
            b.height,
            b.pixels
                .iter()
                .map(|p| {
                    if p.iter().all(|v| v.is_finite()) {
                        *p
                    } else {
                        [1e3; 3]
                    }
                })
                .collect(),
        );
        &sanitised
    } else {
        b
    };
    // Over the object's pixels that are not black in both images.
    let (_, map) = compare(a, b, 1.0)?;
    if mask.len() != map.len() {
        return Err(crate::error::invalid(
            "object mask",
            format!("{} pixels for an image of {}", mask.len(), map.len()),
        ));
    }
    let on_sphere: Vec<(f64, PixelKind)> = map
        .iter()
        .zip(a.pixels.iter().zip(&b.pixels))
        .zip(mask)
        .filter(|((_, (p, q)), &kind)| {
            kind != PixelKind::Off && p.iter().chain(q.iter()).any(|v| *v > 0.0)
        })
        .map(|((d, _), &kind)| (*d, kind))
        .collect();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let silhouette: Vec<f64> = on_sphere
        .iter()
        .filter(|(_, kind)| *kind == PixelKind::Silhouette)
        .map(|(d, _)| *d)
        .collect();
    let mut covered: Vec<f64> = on_sphere.iter().map(|(d, _)| *d).collect();
    covered.sort_by(f64::total_cmp);
    let mean_de = mean(&covered);
    let p99 = covered
        .get(((covered.len().max(1) - 1) as f64 * 0.99).round() as usize)
        .copied()
        .unwrap_or(0.0);
    Ok(SceneError {
        mean_de,
        p99_de: p99,
        silhouette_mean_de: mean(&silhouette),
        non_finite_pixels,
    })
}

impl Validator {
    /// Renders `table` on both scenes (twice, with two seeds).
    ///
    /// # Errors
    /// Invalid settings (zero size or samples).
    pub fn new(table: Arc<dyn Brdf>, settings: ValidationSettings) -> Result<Self, RenderError> {
        if settings.size == 0 || settings.lights_spp == 0 || settings.sky_spp == 0 {
            return Err(crate::error::invalid(
                "validation settings",
                format!("{settings:?}: size and samples must be positive"),
            ));
        }
        let scenes = validation_scenes(settings)?;
        let mut v = Self {
            masks: scenes.iter().map(object_mask).collect(),
            scenes,
            references: Vec::new(),
            recorded: Vec::new(),
            noise: Vec::new(),
            settings,
        };
        // The sky is importance-sampled by the table's own tabulated
        // inverse CDFs, combined with sky sampling by MIS, for every
        // candidate alike (unbiased for any BRDF: the sky's density covers
        // every direction); the same seed gives every candidate the same
        // sample directions, so differences are not sampling noise.
        // Finer than the default table (1.8 degrees between views, 0.7
        // degree cells): a sharp lobe sampled from a neighbouring view's
        // distribution leaves fireflies wherever the two disagree.
        let cdf_table = cdf::TableSettings::default()
            .with_views(46)
            .and_then(|s| s.with_cells(128, 128))
            .and_then(|s| cdf::CdfTable::new(table.as_ref(), s))
            .map_err(|e| crate::error::invalid("validation sampler", e.to_string()))?;
        let sampler: Arc<dyn cdf::Sampler> = Arc::new(cdf::TabulatedSampler::new(cdf_table));
        let sky = &mut v.scenes[1];
        let m = sky.objects[0].material.expect("the sphere has a material");
        sky.materials[m].sampler = sampler;
        // Every candidate is rendered with the same seed and sampler, so
        // its renders are recorded once and replayed for each candidate
        // (`LinearRender`); the table's own renders go through the renderer.
        v.recorded = v
            .scenes
            .iter()
            .map(|s| {
                let mut scene = s.clone();
                scene.integrator.seed = settings.seed;
                LinearRender::record(&scene, sphere_material(&scene))
            })
            .collect();
        v.references = v.render_all(&table, settings.seed);
        let again = v.render_all(&table, settings.seed + 1);
        v.noise = v
            .references
            .iter()
            .zip(&again)
            .zip(&v.masks)
            .map(|((a, b), mask)| scene_error(a, b, mask))
            .collect::<Result<_, _>>()?;
        Ok(v)
    }

    fn render_all(&self, brdf: &Arc<dyn Brdf>, seed: u64) -> Vec<Image> {
        self.scenes
            .iter()
            .map(|s| {
                let mut scene = s.clone();
                scene.integrator.seed = seed;
                let m = sphere_material(&scene);
                scene.materials[m].brdf = brdf.clone();
                render(&scene, &|_, _| {}).image
            })
            .collect()
    }

    /// Each scene with `brdf` on the sphere and the references' seed.
    fn scenes_with(&self, brdf: &Arc<dyn Brdf>) -> Vec<(Scene, usize)> {
        self.scenes
            .iter()
            .map(|s| {
                let mut scene = s.clone();
                scene.integrator.seed = self.settings.seed;
                let m = sphere_material(&scene);
                scene.materials[m].brdf = brdf.clone();
                (scene, m)
            })
            .collect()
    }

    /// The candidate's renders with the references' seed: replayed from
    /// the recordings where there are some, rendered otherwise.
    fn render_candidate(&self, brdf: &Arc<dyn Brdf>) -> Vec<Image> {
        self.scenes_with(brdf)
            .iter()
            .zip(&self.recorded)
            .map(|((scene, m), recorded)| match recorded {
                Some(r) => r.replay(&scene.materials[*m]),
                None => render(scene, &|_, _| {}).image,
            })
            .collect()
    }

    /// The values `candidate` takes at each recorded scene's samples
    /// (`None` for a scene rendered without a recording), for
    /// [`Validator::measure_reusing`].
    pub(crate) fn sample_values(&self, candidate: &Arc<dyn Brdf>) -> SampleValues {
        let scenes = self.scenes_with(candidate);
        SampleValues(
            scenes
                .iter()
                .zip(&self.recorded)
                .map(|((scene, m), recorded)| {
                    recorded
                        .as_ref()
                        .map(|r| r.term_values(&scene.materials[*m], None))
                })
                .collect(),
        )
    }

    /// [`Validator::measure`] for a candidate that equals the one `base`
    /// was taken from wherever `inside` holds for a sample's directions:
    /// there its values are reused, elsewhere evaluated. The renders are
    /// [`Validator::measure`]'s to the last bit when that equality holds.
    ///
    /// # Errors
    /// As [`Validator::measure`].
    pub(crate) fn measure_reusing(
        &self,
        candidate: Arc<dyn Brdf>,
        base: &SampleValues,
        inside: &crate::linear::Inside,
    ) -> Result<RenderErrors, RenderError> {
        let start = Instant::now();
        let images: Vec<Image> = self
            .scenes_with(&candidate)
            .iter()
            .zip(&self.recorded)
            .zip(&base.0)
            .map(|(((scene, m), recorded), base)| match (recorded, base) {
                (Some(r), Some(values)) => {
                    let reuse = Some((values.as_slice(), inside));
                    r.image_of(&r.term_values(&scene.materials[*m], reuse))
                }
                (Some(r), None) => r.replay(&scene.materials[*m]),
                (None, _) => render(scene, &|_, _| {}).image,
            })
            .collect();
        self.errors_of(images, start)
    }

    /// The table's renders, lights first.
    pub fn references(&self) -> &[Image] {
        &self.references
    }

    /// Renders `candidate` with the references' seed and compares.
    ///
    /// # Errors
    /// Never in practice (images of one size); kept for the comparison's
    /// checks.
    pub fn measure(&self, candidate: Arc<dyn Brdf>) -> Result<RenderErrors, RenderError> {
        let start = Instant::now();
        let images = self.render_candidate(&candidate);
        self.errors_of(images, start)
    }

    /// The errors of a candidate's renders against the references.
    fn errors_of(&self, images: Vec<Image>, start: Instant) -> Result<RenderErrors, RenderError> {
        let scenes = self
            .references
            .iter()
            .zip(&images)
            .zip(&self.masks)
            .map(|((a, b), mask)| scene_error(a, b, mask))
            .collect::<Result<_, _>>()?;
        Ok(RenderErrors {
            scenes,
            images,
            seconds: start.elapsed().as_secs_f64(),
            colour_split: None,
        })
    }
}

/// The validation renders of the check `ratfit fit` runs after a fit
/// (and the Python package's `render_check`): both scenes, small and quick.
pub const RENDER_CHECK: ValidationSettings = ValidationSettings {
    size: 64,
    lights_spp: 1,
    sky_spp: 64,
    seed: 1,
};

/// A fit's render errors against its table on the validation scenes at
/// [`RENDER_CHECK`]'s size (images dropped), with the part its luminance
/// and its colour each cause ([`colour_split`]): what a user judges,
/// measured in seconds.
///
/// # Errors
/// As [`Validator::new`] and [`Validator::measure`].
pub fn render_check(
    table: Arc<dyn Brdf>,
    fitted: &brdf::FittedBrdf,
) -> Result<RenderErrors, RenderError> {
    let validator = Validator::new(table.clone(), RENDER_CHECK)?;
    let candidate: Arc<dyn Brdf> = Arc::new(crate::FitInDomain::new(fitted.clone()));
    let mut errors = validator.measure(candidate.clone())?;
    errors.images.clear();
    errors.colour_split = Some(colour_split(&validator, table, candidate)?);
    Ok(errors)
}

/// The reference, the candidate and their CIEDE2000 map (false colour,
/// white at `de_full_scale`) side by side as one sRGB image of three times
/// the width: `(width, height, rgb8)`, tone-mapped as `Image::write` does at
/// unit exposure.
///
/// # Errors
/// Images of different sizes.
pub fn side_by_side(
    reference: &Image,
    candidate: &Image,
    de_full_scale: f64,
) -> Result<(usize, usize, Vec<u8>), RenderError> {
    let (_, map) = compare(reference, candidate, 1.0)?;
    let panels = [
        reference.to_srgb8(1.0),
        candidate.to_srgb8(1.0),
        crate::false_colour(&map, de_full_scale),
    ];
    let (w, h) = (reference.width, reference.height);
    let mut rgb = Vec::with_capacity(panels.iter().map(Vec::len).sum());
    for y in 0..h {
        for panel in &panels {
            rgb.extend_from_slice(&panel[3 * w * y..3 * w * (y + 1)]);
        }
    }
    Ok((3 * w, h, rgb))
}

#[cfg(test)]
mod tests;
