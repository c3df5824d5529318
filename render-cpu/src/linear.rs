//! Renders linear in one material's BRDF, recorded once and replayed for
//! many BRDFs.
//!
//! Under direct lighting, with a BRDF sampler that does not depend on the
//! BRDF evaluated (the validation scenes sample every candidate by the
//! table's own inverse CDFs), each pixel is `sum_k f(wi_k, wo_k) * w_k` plus
//! what the background and the other surfaces give, and the directions and
//! weights depend only on the scene and the seed. [`LinearRender::record`]
//! traces the rays and draws the samples once, through the integrator's
//! own steps; [`LinearRender::replay`] then renders any BRDF by evaluating
//! it at the recorded directions: the same estimator on the same samples as
//! [`crate::render`], without tracing or sampling again.

use crate::image::Image;
use crate::integrator::{
    camera_ray, light_samples, pixel_rng, radiance, reach, sample_brdf, shading, Evaluation,
    LightSink, Reached,
};
use crate::math::{add, mul, scale, Vec3};
use crate::scene::{PreparedMaterial, Scene};
use rayon::prelude::*;

/// Which samples' directions `(wi, wo)` take values given beforehand
/// ([`LinearRender::term_values`]).
pub(crate) type Inside = dyn Fn(Vec3, Vec3) -> bool + Sync;

/// A term's value known without evaluating the material: given the term's
/// index in recording order, its directions `(wi, wo)` and its evaluation
/// path, `Some` value or `None` to evaluate it ([`LinearRender::term_values_with`]).
pub(crate) type Known<'a> = dyn Fn(usize, Vec3, Vec3, Evaluation) -> Option<[f64; 3]> + Sync + 'a;

/// Most bytes a recording may take (estimated before recording, from the
/// pixels, samples and lights); larger renders are not recorded.
pub const MAX_RECORD_BYTES: usize = 512 << 20;

/// The samples of one render of a scene that depend on one material's
/// BRDF, and everything else it gives as a constant per pixel.
#[derive(Debug, Clone)]
pub(crate) struct LinearRender {
    width: usize,
    height: usize,
    /// What each pixel gets whatever the BRDF (its mean over the samples).
    constant: Vec<[f64; 3]>,
    /// Each pixel's first group of terms (one more entry than pixels).
    pixel_start: Vec<usize>,
    /// Each group's view direction (local to the shading frame).
    group_wo: Vec<Vec3>,
    /// Each group's first term (one more entry than groups).
    group_start: Vec<usize>,
    /// Each term's incident direction (local).
    wi: Vec<Vec3>,
    /// Each term's weight: `f(wi, wo) * weight` is what it adds to the
    /// pixel's mean.
    weight: Vec<[f64; 3]>,
    /// Each term's evaluation path, the render's.
    evaluation: Vec<Evaluation>,
}

/// One row's recording, before the rows are joined.
#[derive(Default)]
struct Row {
    constant: Vec<[f64; 3]>,
    groups_per_pixel: Vec<usize>,
    group_wo: Vec<Vec3>,
    terms_per_group: Vec<usize>,
    wi: Vec<Vec3>,
    weight: Vec<[f64; 3]>,
    evaluation: Vec<Evaluation>,
}

impl Row {
    /// Starts a group at view `wo`, unless the pixel's last group has the
    /// same view (unjittered samples share one, and evaluate in one batch).
    fn group(&mut self, wo: Vec3, pixel_groups: &mut usize) {
        if *pixel_groups > 0 && self.group_wo.last() == Some(&wo) {
            return;
        }
        self.group_wo.push(wo);
        self.terms_per_group.push(0);
        *pixel_groups += 1;
    }

    fn term(&mut self, wi: Vec3, weight: [f64; 3], evaluation: Evaluation) {
        self.wi.push(wi);
        self.weight.push(weight);
        self.evaluation.push(evaluation);
        *self.terms_per_group.last_mut().expect("a group is open") += 1;
    }
}

/// Light samples recorded as terms, scaled by `1 / spp`.
struct Terms<'a> {
    row: &'a mut Row,
    inv_spp: f64,
}

impl LightSink for Terms<'_> {
    fn push(&mut self, wi: Vec3, weight: [f64; 3], evaluation: Evaluation) {
        self.row.term(wi, scale(weight, self.inv_spp), evaluation);
    }
}

impl LinearRender {
    /// Records `scene`'s render (its seed, samples and integrator) as
    /// linear in the BRDF of material `material`. `None` where the render
    /// is not linear in it (path tracing) or the recording would pass
    /// [`MAX_RECORD_BYTES`].
    pub(crate) fn record(scene: &Scene, material: usize) -> Option<Self> {
        if scene.integrator.kind != crate::description::IntegratorKind::Direct {
            return None;
        }
        let (w, h) = (scene.camera.width(), scene.camera.height());
        let spp = scene.integrator.spp;
        // Per sample: every light, one environment sample, one BRDF sample.
        let terms = w
            .saturating_mul(h)
            .saturating_mul(spp)
            .saturating_mul(scene.lights.len() + 2);
        let term_bytes = std::mem::size_of::<Vec3>()
            + std::mem::size_of::<[f64; 3]>()
            + std::mem::size_of::<Evaluation>();
        if terms.saturating_mul(term_bytes) > MAX_RECORD_BYTES {
            return None;
        }
        let inv_spp = 1.0 / spp as f64;
        let rows: Vec<Row> = (0..h)
            .into_par_iter()
            .map(|y| {
                let mut row = Row::default();
                for x in 0..w {
                    let mut rng = pixel_rng(scene, x, y, spp);
                    let mut constant = [0.0; 3];
                    let mut groups = 0;
                    for s in 0..spp {
                        let ray = camera_ray(scene, x, y, spp, s, &mut rng);
                        let (hit, m) = match reach(scene, &ray, None) {
                            Reached::Surface(hit, mi, m) if mi == material => (hit, m),
                            // The same steps as the render (and the same
                            // random numbers): nothing here reads the BRDF.
                            _ => {
                                let l = radiance(scene, ray, &mut rng);
                                constant = add(constant, scale(l, inv_spp));
                                continue;
                            }
                        };
                        let Some(sh) = shading(&ray, &hit, m) else {
                            continue;
                        };
                        row.group(sh.wo, &mut groups);
                        let mut sink = Terms {
                            row: &mut row,
                            inv_spp,
                        };
                        light_samples(scene, &sh, &mut rng, &mut sink);
                        // Direct lighting: the BRDF sample counts only where
                        // it reaches a light (the path ends at its next hit).
                        if let Some(b) = sample_brdf(&sh, &mut rng) {
                            if let Reached::Light(le) = reach(scene, &b.ray, Some(b.mis_pdf)) {
                                row.term(
                                    b.wi,
                                    scale(le, b.cos_over_pdf * inv_spp),
                                    Evaluation::Single,
                                );
                            }
                        }
                    }
                    row.constant.push(constant);
                    row.groups_per_pixel.push(groups);
                }
                row
            })
            .collect();
        let mut out = Self {
            width: w,
            height: h,
            constant: Vec::with_capacity(w * h),
            pixel_start: vec![0],
            group_wo: Vec::new(),
            group_start: vec![0],
            wi: Vec::new(),
            weight: Vec::new(),
            evaluation: Vec::new(),
        };
        for row in rows {
            out.constant.extend(row.constant);
            for g in row.groups_per_pixel {
                out.pixel_start
                    .push(out.pixel_start.last().copied().unwrap_or(0) + g);
            }
            out.group_wo.extend(row.group_wo);
            for t in row.terms_per_group {
                out.group_start
                    .push(out.group_start.last().copied().unwrap_or(0) + t);
            }
            out.wi.extend(row.wi);
            out.weight.extend(row.weight);
            out.evaluation.extend(row.evaluation);
        }
        Some(out)
    }

    /// The render with `material` (the recorded material's slot) in place:
    /// each pixel's constant plus its terms, each evaluated as the render
    /// evaluates it (the batched ones in one batch per view).
    pub(crate) fn replay(&self, material: &PreparedMaterial) -> Image {
        self.image_of(&self.term_values(material, None))
    }

    /// Each term's value under `material`, in recording order, evaluated as
    /// the render evaluates it (single terms one by one, batched ones in one
    /// batch per view); where `reuse` is given as
    /// `(values, inside)`, a term whose directions satisfy `inside` takes
    /// the value `values` holds for it instead (the caller vouches that
    /// `material` evaluates to exactly that there).
    pub(crate) fn term_values(
        &self,
        material: &PreparedMaterial,
        reuse: Option<(&[[f64; 3]], &Inside)>,
    ) -> Vec<[f64; 3]> {
        match reuse {
            Some((values, inside)) => {
                self.term_values_with(material, &|k, wi, wo, _| inside(wi, wo).then(|| values[k]))
            }
            None => self.term_values_with(material, &|_, _, _, _| None),
        }
    }

    /// Each term's value under `material`, in recording order, evaluated
    /// as the render evaluates it (single terms one by one, batched ones in
    /// one batch per view) where `known` gives none (the caller vouches
    /// that `material` evaluates to exactly what it gives).
    pub(crate) fn term_values_with(
        &self,
        material: &PreparedMaterial,
        known: &Known<'_>,
    ) -> Vec<[f64; 3]> {
        let mut values = vec![[0.0; 3]; self.wi.len()];
        // Each pixel's terms are contiguous: one slice per pixel.
        let mut pixels: Vec<(usize, &mut [[f64; 3]])> =
            Vec::with_capacity(self.width * self.height);
        let mut rest = values.as_mut_slice();
        for p in 0..self.width * self.height {
            let first = self.group_start[self.pixel_start[p]];
            let end = self.group_start[self.pixel_start[p + 1]];
            let (mine, tail) = rest.split_at_mut(end - first);
            pixels.push((p, mine));
            rest = tail;
        }
        pixels.into_par_iter().for_each_init(
            || (Vec::new(), Vec::new(), Vec::new()),
            |(wi, at, f), (p, out)| {
                let offset = self.group_start[self.pixel_start[p]];
                for g in self.pixel_start[p]..self.pixel_start[p + 1] {
                    let wo = self.group_wo[g];
                    wi.clear();
                    at.clear();
                    for k in self.group_start[g]..self.group_start[g + 1] {
                        if let Some(v) = known(k, self.wi[k], wo, self.evaluation[k]) {
                            out[k - offset] = v;
                            continue;
                        }
                        match self.evaluation[k] {
                            Evaluation::Single => {
                                out[k - offset] = material.eval(self.wi[k], wo);
                            }
                            Evaluation::Batched => {
                                wi.push(self.wi[k]);
                                at.push(k - offset);
                            }
                        }
                    }
                    f.clear();
                    f.resize(wi.len(), [0.0; 3]);
                    material.eval_incident(wi, wo, f);
                    for (&k, v) in at.iter().zip(f.iter()) {
                        out[k] = *v;
                    }
                }
            },
        );
        values
    }

    /// `f` of each term's directions `(wi, wo)` and evaluation path, in
    /// recording order.
    pub(crate) fn map_terms<T: Send>(
        &self,
        f: impl Fn(Vec3, Vec3, Evaluation) -> T + Sync,
    ) -> Vec<T> {
        let f = &f;
        (0..self.group_wo.len())
            .into_par_iter()
            .flat_map_iter(|g| {
                let wo = self.group_wo[g];
                (self.group_start[g]..self.group_start[g + 1])
                    .map(move |k| f(self.wi[k], wo, self.evaluation[k]))
            })
            .collect()
    }

    /// The image of term values ([`LinearRender::term_values`]): each
    /// pixel's constant plus its terms, summed in the render's order (a
    /// group's single terms, then its batched ones), so that the image is
    /// the render's to the last bit.
    pub(crate) fn image_of(&self, values: &[[f64; 3]]) -> Image {
        let pixels: Vec<[f32; 3]> = (0..self.width * self.height)
            .into_par_iter()
            .map(|p| {
                let mut l = self.constant[p];
                for g in self.pixel_start[p]..self.pixel_start[p + 1] {
                    let terms = self.group_start[g]..self.group_start[g + 1];
                    for k in terms.clone() {
                        if self.evaluation[k] == Evaluation::Single {
                            l = add(l, mul(values[k], self.weight[k]));
                        }
                    }
                    for k in terms {
                        if self.evaluation[k] == Evaluation::Batched {
                            l = add(l, mul(values[k], self.weight[k]));
                        }
                    }
                }
                l.map(|c| c as f32)
            })
            .collect();
        Image::new(self.width, self.height, pixels)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::description::SceneDescription;
    use crate::prepare::{prepare, RenderOptions};
    use std::path::Path;
    use std::sync::Arc;

    /// Every kind of light, an environment under MIS, jittered independent
    /// samples and a second surface (the ground) in the sphere's view.
    fn scene(integrator: &str) -> Scene {
        let text = format!(
            "[camera]\nfrom = [0.0, 0.6, 4.0]\nto = [0.0, 0.0, 0.0]\nfov_deg = 40.0\nwidth = 20\nheight = 16\n\
             [integrator]\nkind = \"{integrator}\"\nspp = 6\nmis = true\n\
             [materials.shiny]\nkind = \"ggx\"\nkd = [0.2, 0.3, 0.1]\nf0 = [0.04, 0.04, 0.04]\nalpha = 0.15\n\
             [materials.ground]\nkind = \"lambert\"\nalbedo = [0.4, 0.4, 0.4]\n\
             [[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"shiny\"\n\
             [[objects]]\nshape = \"plane\"\npoint = [0.0, -1.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\nmaterial = \"ground\"\n\
             [[lights]]\nkind = \"directional\"\ndirection = [0.5, 0.6, 0.8]\nirradiance = [3.0, 3.0, 3.0]\n\
             [[lights]]\nkind = \"point\"\nposition = [-2.0, 2.0, 2.0]\nintensity = [4.0, 4.0, 4.0]\n\
             [[lights]]\nkind = \"area\"\ncorner = [-0.5, 2.5, -0.5]\nu = [1.0, 0.0, 0.0]\nv = [0.0, 0.0, 1.0]\nradiance = [2.0, 2.0, 2.0]\n\
             [environment]\nkind = \"sky\"\nzenith = [0.9, 1.0, 1.3]\nhorizon = [1.6, 1.5, 1.3]\nground = [0.2, 0.18, 0.15]\n"
        );
        let desc = SceneDescription::parse(&text, "linear").unwrap();
        let options = RenderOptions {
            no_cache: true,
            ..Default::default()
        };
        prepare(desc, Path::new("."), "linear", &options).unwrap().0
    }

    fn assert_same(a: &Image, b: &Image) {
        let mut largest = 0.0f64;
        for (p, q) in a.pixels.iter().zip(&b.pixels) {
            for c in 0..3 {
                let d = f64::from((p[c] - q[c]).abs()) / f64::from(p[c].abs()).max(1e-3);
                largest = largest.max(d);
            }
        }
        assert!(largest < 1e-5, "largest relative difference {largest:e}");
    }

    #[test]
    fn a_replay_is_the_render_it_recorded_for_any_brdf() {
        let mut scene = scene("direct");
        let sphere = scene.objects[0].material.unwrap();
        let recorded = LinearRender::record(&scene, sphere).expect("direct lighting records");
        let rendered = crate::render(&scene, &|_, _| {}).image;
        assert_same(&rendered, &recorded.replay(&scene.materials[sphere]));
        // Another BRDF in the slot: the recording's samples still give its
        // render (the sampler is the scene's, whatever the BRDF).
        scene.materials[sphere].brdf = Arc::new(brdf::CookTorranceGgx {
            kd: [0.5, 0.1, 0.1],
            f0: [0.9, 0.6, 0.3],
            alpha: 0.05,
        });
        let rendered = crate::render(&scene, &|_, _| {}).image;
        assert_same(&rendered, &recorded.replay(&scene.materials[sphere]));
        // The terms are the sphere's samples alone: at most every light, one
        // environment and one BRDF sample per sample of its pixels.
        let per_sample = scene.lights.len() + 2;
        assert!(!recorded.wi.is_empty());
        assert!(recorded.wi.len() <= 20 * 16 * 6 * per_sample);
    }

    #[test]
    fn path_tracing_and_oversized_renders_are_not_recorded() {
        let scene_path = scene("path");
        assert!(LinearRender::record(&scene_path, 0).is_none());
        let mut big = scene("direct");
        big.integrator.spp = MAX_RECORD_BYTES;
        assert!(LinearRender::record(&big, 0).is_none());
    }
}
