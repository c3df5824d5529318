//! The parts of a fit's value at the validation samples beyond an
//! elevation cut that its shell factors do not change, computed once per
//! cut for every evaluation [`super::choose_evaluation_cut`] measures there.

use super::{RenderErrors, SampleValues, Validator};
use crate::integrator::Evaluation;
use crate::linear::Inside;
use crate::RenderError;
use brdf::{Brdf, FittedBrdf, HalfDiff};
use std::sync::Arc;
use std::time::Instant;

/// Marks a sample without parts in [`ScenePartsIndex`].
const NO_PARTS: u32 = u32::MAX;

/// One recorded scene's parts: for each sample, the index of its parts in
/// `parts` or [`NO_PARTS`].
struct ScenePartsIndex {
    index: Vec<u32>,
    /// The functions' values within the cut
    /// ([`FittedBrdf::functions_within_cut`]) and the pair's own
    /// `[theta_h, theta_d]`.
    parts: Vec<([f64; 3], [f64; 2])>,
}

/// Per validation scene (`None` for a scene not recorded), the parts of a
/// fit within a cut at its single-evaluation samples above the surface and
/// outside the samples whose values are reused: what every shell factor
/// beside that fit shares. The batched samples (the directional lights',
/// a few per pixel) are evaluated on their own path as the render does.
pub(crate) struct FitParts {
    cut_deg: f64,
    scenes: Vec<Option<ScenePartsIndex>>,
}

impl FitParts {
    /// The parts of `fit` (evaluated within its cut `cut_deg`) at
    /// `validator`'s samples outside `inside`.
    pub(crate) fn new(validator: &Validator, fit: &FittedBrdf, inside: &Inside) -> Self {
        let scenes = validator
            .recorded
            .iter()
            .map(|recorded| {
                recorded.as_ref().map(|r| {
                    let parts: Vec<Option<([f64; 3], [f64; 2])>> = r.map_terms(|wi, wo, e| {
                        let beyond = e == Evaluation::Single
                            && wi[2] > 0.0
                            && wo[2] > 0.0
                            && !inside(wi, wo);
                        beyond.then(|| {
                            let [theta_h, theta_d, _] = HalfDiff::isotropic_angles(wi, wo);
                            (fit.functions_within_cut(wi, wo), [theta_h, theta_d])
                        })
                    });
                    let mut index = Vec::with_capacity(parts.len());
                    let mut dense = Vec::new();
                    for p in parts {
                        match p {
                            Some(p) if dense.len() < NO_PARTS as usize => {
                                index.push(dense.len() as u32);
                                dense.push(p);
                            }
                            _ => index.push(NO_PARTS),
                        }
                    }
                    ScenePartsIndex {
                        index,
                        parts: dense,
                    }
                })
            })
            .collect();
        Self {
            cut_deg: fit.reduction.max_elevation_deg,
            scenes,
        }
    }

    /// The cut (degrees) of the fit the parts were taken from.
    pub(crate) fn cut_deg(&self) -> f64 {
        self.cut_deg
    }
}

impl Validator {
    /// [`Validator::measure_reusing`] of `candidate`, the
    /// [`crate::FitInDomain`] of `variant` on its f64 path, whose functions
    /// and cut are those `parts` were taken from, its shell factor its
    /// own: outside `inside`, a single-evaluation sample's value is
    /// [`FittedBrdf::eval_from_parts`] of its parts, which equals the
    /// render's evaluation to the last bit; the rest as
    /// [`Validator::measure_reusing`] takes them.
    ///
    /// # Errors
    /// As [`Validator::measure`].
    pub(crate) fn measure_with_parts(
        &self,
        candidate: Arc<dyn Brdf>,
        variant: &FittedBrdf,
        base: &SampleValues,
        inside: &Inside,
        parts: &FitParts,
    ) -> Result<RenderErrors, RenderError> {
        debug_assert_eq!(
            variant.reduction.max_elevation_deg.to_bits(),
            parts.cut_deg.to_bits(),
            "the parts are of the variant's cut"
        );
        let start = Instant::now();
        let images = self
            .scenes_with(&candidate)
            .iter()
            .zip(&self.recorded)
            .zip(&base.0)
            .zip(&parts.scenes)
            .map(
                |((((scene, m), recorded), base), parts)| match (recorded, base, parts) {
                    (Some(r), Some(values), Some(p)) => {
                        let known = |k: usize, wi, wo, _| {
                            if inside(wi, wo) {
                                return Some(values[k]);
                            }
                            let at = p.index[k];
                            (at != NO_PARTS).then(|| {
                                let (functions, angles) = p.parts[at as usize];
                                variant
                                    .eval_from_parts(wi, wo, functions, || angles)
                                    .map(|v| v.max(0.0))
                            })
                        };
                        r.image_of(&r.term_values_with(&scene.materials[*m], &known))
                    }
                    (Some(r), _, _) => r.replay(&scene.materials[*m]),
                    (None, _, _) => crate::integrator::render(scene, &|_, _| {}).image,
                },
            )
            .collect();
        self.errors_of(images, start)
    }
}
