//! [`colour_split`]: which part of a candidate's render error comes from
//! its luminance and which from its colour.

use super::Validator;
use crate::RenderError;
use brdf::{luminance, Brdf, Vec3};
use serde::Serialize;
use std::sync::Arc;

/// One material's luminance with another's colour: at each pair, the
/// colour source's RGB scaled to the luminance source's luminance (grey
/// where the colour source is black).
struct LuminanceWithColour {
    luminance: Arc<dyn Brdf>,
    colour: Arc<dyn Brdf>,
}

impl Brdf for LuminanceWithColour {
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        let y = luminance(self.luminance.eval(wi, wo));
        let c = self.colour.eval(wi, wo);
        let yc = luminance(c);
        if yc > 0.0 && yc.is_finite() {
            c.map(|v| v * y / yc)
        } else {
            [y; 3]
        }
    }

    fn name(&self) -> String {
        format!(
            "{}'s luminance with {}'s colour",
            self.luminance.name(),
            self.colour.name()
        )
    }
}

/// The render error of a candidate's luminance alone and of its colour
/// alone, per validation scene (lights first).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ColourSplit {
    /// Mean CIEDE2000 of the candidate's luminance with the table's colour.
    pub luminance_mean_de: Vec<f64>,
    /// Mean CIEDE2000 of the table's luminance with the candidate's colour.
    pub colour_mean_de: Vec<f64>,
}

impl ColourSplit {
    /// One line for reports.
    pub fn describe(&self, what: &str) -> String {
        let pair = |v: &[f64]| {
            v.iter()
                .map(|x| format!("{x:.2}"))
                .collect::<Vec<_>>()
                .join(" / ")
        };
        format!(
            "error by part (mean CIEDE2000, lights / sky): {what}'s luminance with the table's colour {}, the table's luminance with {what}'s colour {}",
            pair(&self.luminance_mean_de),
            pair(&self.colour_mean_de)
        )
    }
}

/// Renders `candidate`'s luminance with `table`'s colour, and `table`'s
/// luminance with `candidate`'s colour, on `validator`'s scenes (whose
/// references are `table`'s renders): which of the two a candidate must
/// improve. In a luminance-chroma fit these are its luminance function and
/// its two chroma ratios.
///
/// # Errors
/// As [`Validator::measure`].
pub fn colour_split(
    validator: &Validator,
    table: Arc<dyn Brdf>,
    candidate: Arc<dyn Brdf>,
) -> Result<ColourSplit, RenderError> {
    let means = |luminance: &Arc<dyn Brdf>, colour: &Arc<dyn Brdf>| {
        let hybrid = LuminanceWithColour {
            luminance: luminance.clone(),
            colour: colour.clone(),
        };
        validator
            .measure(Arc::new(hybrid))
            .map(|e| e.scenes.iter().map(|s| s.mean_de).collect::<Vec<f64>>())
    };
    Ok(ColourSplit {
        luminance_mean_de: means(&candidate, &table)?,
        colour_mean_de: means(&table, &candidate)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fidelity::{ValidationSettings, RENDER_CHECK};

    /// `inner`'s values scaled per channel, then, with `keep_luminance`,
    /// brought back to `inner`'s luminance (another colour, same
    /// luminance).
    struct Modified {
        inner: brdf::BlinnPhong,
        k: [f64; 3],
        keep_luminance: bool,
    }

    impl Brdf for Modified {
        fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
            let v = self.inner.eval(wi, wo);
            let m = [v[0] * self.k[0], v[1] * self.k[1], v[2] * self.k[2]];
            if self.keep_luminance && luminance(m) > 0.0 {
                m.map(|x| x * luminance(v) / luminance(m))
            } else {
                m
            }
        }
        fn name(&self) -> String {
            "modified".into()
        }
    }

    #[test]
    fn each_part_carries_only_its_own_error() {
        let glossy = brdf::BlinnPhong {
            kd: [0.3, 0.2, 0.1],
            ks: [0.3, 0.3, 0.3],
            exponent: 30.0,
        };
        let table: Arc<dyn Brdf> = Arc::new(glossy);
        let validator = Validator::new(
            table.clone(),
            ValidationSettings {
                size: 24,
                sky_spp: 4,
                ..RENDER_CHECK
            },
        )
        .unwrap();
        // Brighter, same colour: all of the error is the luminance's;
        // another colour, same luminance: all of it is the colour's.
        for (k, keep_luminance) in [([1.3; 3], false), ([1.25, 1.0, 0.7], true)] {
            let candidate: Arc<dyn Brdf> = Arc::new(Modified {
                inner: glossy,
                k,
                keep_luminance,
            });
            let whole = validator.measure(candidate.clone()).unwrap();
            let split = colour_split(&validator, table.clone(), candidate).unwrap();
            let (own, other) = if keep_luminance {
                (&split.colour_mean_de, &split.luminance_mean_de)
            } else {
                (&split.luminance_mean_de, &split.colour_mean_de)
            };
            assert_eq!(own.len(), 2);
            for s in 0..2 {
                assert!(whole.scenes[s].mean_de > 0.5, "{whole:?}");
                assert!(
                    (own[s] - whole.scenes[s].mean_de).abs() < 1e-6 * whole.scenes[s].mean_de,
                    "{split:?} {whole:?}"
                );
                assert!(other[s] < 1e-6, "{split:?}");
            }
            assert!(split.describe("the fit").contains("lights / sky"));
        }
    }
}
