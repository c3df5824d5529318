//! How the three fitted functions of a BRDF make RGB.
//!
//! Most materials change colour slowly: fitting red, green and blue each at
//! full budget spends bytes three times on the same shape, and independent
//! errors in the three channels show as colour shifts. The
//! luminance-chroma mode fits the luminance `Y` with the full budget and
//! the ratios `r / Y` and `b / Y` (smooth where the colour is) as separate
//! functions; green follows from `Y`.

use serde::{Deserialize, Serialize};

/// Luminance weights of linear sRGB (Rec. 709).
pub const LUMINANCE_WEIGHTS: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// The smallest factor [`ColourMode::perceptual_factors`] gives a chroma
/// ratio's half-width.
pub const MIN_CHROMA_FACTOR: f64 = 0.1;

/// Luminance of the reference colour of [`ColourMode::perceptual_factors`].
const MID_GREY_Y: f64 = 0.18;

/// Relative step of the finite differences of
/// [`ColourMode::perceptual_factors`].
const SENSITIVITY_STEP: f64 = 1e-3;

/// Luminance of a linear sRGB triple.
pub fn luminance(v: [f64; 3]) -> f64 {
    LUMINANCE_WEIGHTS[0] * v[0] + LUMINANCE_WEIGHTS[1] * v[1] + LUMINANCE_WEIGHTS[2] * v[2]
}

/// What the three fitted functions are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum ColourMode {
    /// Red, green and blue.
    #[default]
    Rgb,
    /// Luminance `Y`, then `r / Y` and `b / Y`.
    LuminanceChroma,
}

impl ColourMode {
    /// Whether this is [`ColourMode::Rgb`] (serialisation skips the default).
    pub fn is_rgb(&self) -> bool {
        *self == ColourMode::Rgb
    }

    /// RGB from the three functions' values, negative parts clamped to zero.
    pub fn combine(self, v: [f64; 3]) -> [f64; 3] {
        match self {
            ColourMode::Rgb => v.map(|x| x.max(0.0)),
            ColourMode::LuminanceChroma => {
                let y = v[0].max(0.0);
                let (r, b) = (y * v[1].max(0.0), y * v[2].max(0.0));
                let [wr, wg, wb] = LUMINANCE_WEIGHTS;
                [r, ((y - wr * r - wb * b) / wg).max(0.0), b]
            }
        }
    }

    /// [`ColourMode::combine`] in f32, in the order the shaders use.
    pub fn combine_f32(self, v: [f32; 3]) -> [f32; 3] {
        match self {
            ColourMode::Rgb => v.map(|x| x.max(0.0)),
            ColourMode::LuminanceChroma => {
                let y = v[0].max(0.0);
                let (r, b) = (y * v[1].max(0.0), y * v[2].max(0.0));
                let w = LUMINANCE_WEIGHTS.map(|x| x as f32);
                [r, ((y - w[0] * r - w[2] * b) / w[1]).max(0.0), b]
            }
        }
    }

    /// The three functions' target values for an RGB triple; `None` for
    /// the chroma ratios where the luminance is not positive.
    pub fn split(self, rgb: [f64; 3]) -> [Option<f64>; 3] {
        match self {
            ColourMode::Rgb => rgb.map(Some),
            ColourMode::LuminanceChroma => {
                let y = luminance(rgb);
                let ratio = |v: f64| (y > 0.0 && y.is_finite()).then(|| v / y);
                [Some(y), ratio(rgb[0]), ratio(rgb[2])]
            }
        }
    }

    /// Factors on the luminance's relative half-width, one per function,
    /// so that a relative error of each function's half-width moves the
    /// colour `reference` (linear sRGB) by about the same CIEDE2000 as the
    /// luminance's: 1 for the luminance and for RGB channels; for the
    /// chroma ratios, the luminance's sensitivity over the ratio's at the
    /// reference brought to mid grey (`Y = 0.18`, L* about 50), within
    /// `[MIN_CHROMA_FACTOR, 1]`. Near-neutral colours get the smallest
    /// factors: CIEDE2000 stretches a* there (its G term), and a ratio
    /// error of 8% moves a grey by about 3.6 units against 1.5 for the
    /// same error of the luminance.
    pub fn perceptual_factors(self, reference: [f64; 3]) -> [f64; 3] {
        let y = luminance(reference);
        if self == ColourMode::Rgb || !(y > 0.0 && y.is_finite()) {
            return [1.0; 3];
        }
        let grey = reference.map(|v| v.max(0.0) * MID_GREY_Y / y);
        let lab = crate::lab::linear_srgb_to_lab(grey);
        let moved = |v: [f64; 3]| -> f64 {
            let rgb = self.combine(v);
            crate::lab::delta_e2000(lab, crate::lab::linear_srgb_to_lab(rgb)) / SENSITIVITY_STEP
        };
        let v = self.split(grey).map(|x| x.unwrap_or(0.0));
        let step = |k: usize| {
            let mut w = v;
            w[k] *= 1.0 + SENSITIVITY_STEP;
            moved(w)
        };
        let luminance_sensitivity = step(0);
        [
            1.0,
            (luminance_sensitivity / step(1)),
            (luminance_sensitivity / step(2)),
        ]
        .map(|f| {
            if f.is_finite() {
                f.clamp(MIN_CHROMA_FACTOR, 1.0)
            } else {
                1.0
            }
        })
    }

    /// Whether function `c` carries the light (a channel, or the
    /// luminance), rather than a colour ratio: its perceptual floor follows
    /// the tolerance ([`crate::PerceptualBounds::light_floor`]).
    pub fn carries_light(self, c: usize) -> bool {
        match self {
            ColourMode::Rgb => c < 3,
            ColourMode::LuminanceChroma => c == 0,
        }
    }

    /// The functions' names, for reports.
    pub fn names(self) -> [char; 3] {
        match self {
            ColourMode::Rgb => ['r', 'g', 'b'],
            ColourMode::LuminanceChroma => ['Y', 'r', 'b'],
        }
    }
}

/// The name [`ColourMode`]'s `FromStr` reads: `rgb`, `luminance-chroma`.
impl std::fmt::Display for ColourMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ColourMode::Rgb => "rgb",
            ColourMode::LuminanceChroma => "luminance-chroma",
        })
    }
}

impl std::str::FromStr for ColourMode {
    type Err = crate::BrdfError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "rgb" => Ok(ColourMode::Rgb),
            "luminance-chroma" | "luminance_chroma" => Ok(ColourMode::LuminanceChroma),
            other => Err(crate::BrdfError::Invalid {
                name: "colour mode",
                reason: format!("unknown mode `{other}` (rgb, luminance-chroma)"),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_then_combine_is_the_identity() {
        for rgb in [[0.2, 0.5, 0.1], [1.0, 1.0, 1.0], [0.01, 0.3, 0.9]] {
            let mode = ColourMode::LuminanceChroma;
            let v = mode.split(rgb).map(Option::unwrap);
            let back = mode.combine(v);
            let back32 = mode.combine_f32(v.map(|x| x as f32));
            assert_eq!(mode.to_string().parse::<ColourMode>().ok(), Some(mode));
            for c in 0..3 {
                assert!((back[c] - rgb[c]).abs() < 1e-12, "{rgb:?} {back:?}");
                assert!((f64::from(back32[c]) - rgb[c]).abs() < 1e-6);
            }
        }
        assert_eq!(ColourMode::LuminanceChroma.split([0.0; 3])[1], None);
        assert_eq!("rgb".parse::<ColourMode>().unwrap(), ColourMode::Rgb);
        assert!("hsv".parse::<ColourMode>().is_err());
    }

    #[test]
    fn chroma_factors_equalise_the_colour_difference_of_each_function() {
        let mode = ColourMode::LuminanceChroma;
        let ones = |f: [f64; 3]| f.iter().all(|v| (v - 1.0).abs() < f64::EPSILON);
        assert!(ones(ColourMode::Rgb.perceptual_factors([0.2, 0.5, 0.1])));
        assert!(ones(mode.perceptual_factors([0.0; 3])));
        for reference in [[0.5, 0.5, 0.5], [0.05, 0.08, 0.04], [0.6, 0.3, 0.05]] {
            let f = mode.perceptual_factors(reference);
            assert!((f[0] - 1.0).abs() < f64::EPSILON);
            // A 5% error scaled by each factor moves the mid-grey colour by
            // the same CIEDE2000 (within the factors' clamp).
            let y = luminance(reference);
            let grey = reference.map(|v| v * 0.18 / y);
            let lab = crate::lab::linear_srgb_to_lab(grey);
            let v = mode.split(grey).map(Option::unwrap);
            let de = |k: usize| {
                let mut w = v;
                w[k] *= 1.0 + 0.05 * f[k];
                crate::lab::delta_e2000(lab, crate::lab::linear_srgb_to_lab(mode.combine(w)))
            };
            for k in 1..3 {
                assert!(
                    (MIN_CHROMA_FACTOR..=1.0).contains(&f[k]),
                    "{reference:?} {f:?}"
                );
                if f[k] > MIN_CHROMA_FACTOR && f[k] < 1.0 {
                    assert!(
                        (de(k) / de(0) - 1.0).abs() < 0.05,
                        "{reference:?} {f:?} {} {}",
                        de(k),
                        de(0)
                    );
                }
            }
        }
        // Greys are the most sensitive to a chroma ratio.
        let grey = mode.perceptual_factors([0.5, 0.5, 0.5]);
        assert!(grey[1] < 0.6 && grey[2] < 0.8, "{grey:?}");
    }
}
