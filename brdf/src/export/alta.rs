//! ALTA's rational function files (`#FUNC rational_function`): for each
//! output channel, `#MIN`/`#MAX` of the input domain, `#NP`/`#NQ`, then one
//! line per coefficient (the multi-index of its tensor Chebyshev polynomial,
//! then the value), numerator first. Inputs are mapped from `[MIN, MAX]` to
//! `[-1, 1]` per coordinate, as in ALTA's `rational_function_chebychev`.

use crate::{BrdfError, Coordinates, FittedBrdf, PhiCoordinate};
use rational_core::BasisFamily;
use std::fmt::Write as _;
use std::path::Path;

/// One output channel of an ALTA rational function.
#[derive(Debug, Clone, PartialEq)]
pub struct AltaChannel {
    /// Domain lower corner.
    pub min: Vec<f64>,
    /// Domain upper corner.
    pub max: Vec<f64>,
    /// Numerator: multi-index and coefficient.
    pub numerator: Vec<(Vec<u32>, f64)>,
    /// Denominator: multi-index and coefficient.
    pub denominator: Vec<(Vec<u32>, f64)>,
}

/// A rational function written by ALTA.
#[derive(Debug, Clone, PartialEq)]
pub struct AltaRational {
    /// Input dimension.
    pub dim_in: usize,
    /// Input parametrisation named in the header.
    pub param_in: String,
    /// One function per output.
    pub channels: Vec<AltaChannel>,
}

/// Largest Chebyshev degree read from a file (each term costs its degree).
const MAX_ALTA_DEGREE: u32 = 1000;

fn chebyshev(k: u32, t: f64) -> f64 {
    let (mut a, mut b) = (1.0, t);
    if k == 0 {
        return 1.0;
    }
    for _ in 1..k {
        let c = 2.0 * t * b - a;
        a = b;
        b = c;
    }
    b
}

impl AltaChannel {
    fn term(&self, idx: &[u32], x: &[f64]) -> f64 {
        idx.iter()
            .enumerate()
            .map(|(k, &d)| {
                let w = self.max[k] - self.min[k];
                let t = if w > 0.0 {
                    2.0 * (x[k] - self.min[k]) / w - 1.0
                } else {
                    0.0
                };
                chebyshev(d, t)
            })
            .product()
    }

    /// `p(x) / q(x)` in the file's own input parametrisation.
    pub fn eval(&self, x: &[f64]) -> f64 {
        let p: f64 = self
            .numerator
            .iter()
            .map(|(i, c)| c * self.term(i, x))
            .sum();
        let q: f64 = self
            .denominator
            .iter()
            .map(|(i, c)| c * self.term(i, x))
            .sum();
        p / q
    }
}

impl AltaRational {
    /// The ALTA form of a fit: the same tensor Chebyshev coefficients on the
    /// same domain boxes, in ALTA's Rusinkiewicz parametrisation
    /// (`RUSIN_TH_TD` or `RUSIN_TH_TD_PD`, radians).
    ///
    /// ALTA evaluates `p / q` as is: our clamps ([`FittedBrdf::coordinates`]
    /// clamps `theta_d` to the grazing cut, [`FittedBrdf::eval_coords`]
    /// negative values to zero and values above the fit's ceiling to it)
    /// are not part of the file.
    ///
    /// # Errors
    /// Fits in coordinates ALTA has no parametrisation for (the sqrt warp of
    /// `theta_h`, cosines: refit with radians), in a basis other than
    /// Chebyshev, with a lobe or a shell factor, or on the log scale.
    pub fn from_fitted(fit: &FittedBrdf) -> Result<Self, BrdfError> {
        if fit.lobe.is_some() {
            return Err(BrdfError::Invalid {
                name: "ALTA export",
                reason: "ALTA rational functions hold p / q alone; this fit multiplies them by an analytic lobe (export the binary, WGSL or GLSL form, or refit without the lobe)".into(),
            });
        }
        if fit.shell.is_some() {
            return Err(BrdfError::Invalid {
                name: "ALTA export",
                reason: "ALTA rational functions hold p / q alone; this fit multiplies them by a tabulated factor beyond its elevation cut (export the binary, WGSL or GLSL form)".into(),
            });
        }
        if !fit.mode.is_rgb() {
            return Err(BrdfError::Invalid {
                name: "ALTA export",
                reason: "ALTA rational functions hold one function per RGB channel; this fit is in the luminance-chroma mode (refit with the rgb mode)".into(),
            });
        }
        if !fit.scale.is_linear() {
            return Err(BrdfError::Invalid {
                name: "ALTA export",
                reason: "ALTA's rational functions are the values; this fit's are their \
                         logarithms (refit on the linear scale)"
                    .into(),
            });
        }
        if fit.reduction.coordinates != Coordinates::Radians {
            return Err(BrdfError::Invalid {
                name: "ALTA export",
                reason: format!(
                    "ALTA has no parametrisation for {:?} coordinates; refit in radians",
                    fit.reduction.coordinates
                ),
            });
        }
        if fit.reduction.dims() == 3 && fit.reduction.phi != PhiCoordinate::Radians {
            return Err(BrdfError::Invalid {
                name: "ALTA export",
                reason: "ALTA has no parametrisation for cos phi_d; refit with phi_d in radians"
                    .into(),
            });
        }
        let dim_in = fit.reduction.dims();
        let mut channels = Vec::with_capacity(fit.channels.len());
        for f in &fit.channels {
            let basis = f.basis();
            if basis.family() != BasisFamily::Chebyshev {
                return Err(BrdfError::Invalid {
                    name: "ALTA export",
                    reason: format!(
                        "ALTA's rational functions are in the Chebyshev basis, this fit is in {}",
                        basis.family()
                    ),
                });
            }
            let terms = |c: &[f64]| -> Vec<(Vec<u32>, f64)> {
                c.iter()
                    .enumerate()
                    .map(|(j, &v)| {
                        (
                            basis.multi_index(j).iter().map(|&e| u32::from(e)).collect(),
                            v,
                        )
                    })
                    .collect()
            };
            channels.push(AltaChannel {
                min: basis.domain().lower.clone(),
                max: basis.domain().upper.clone(),
                numerator: terms(f.numerator()),
                denominator: terms(f.denominator()),
            });
        }
        Ok(Self {
            dim_in,
            param_in: if dim_in == 3 {
                "RUSIN_TH_TD_PD".into()
            } else {
                "RUSIN_TH_TD".into()
            },
            channels,
        })
    }

    /// The file text (`#MIN`/`#MAX` repeated before each channel, as each
    /// channel has its own domain box), coefficients to full precision.
    pub fn to_text(&self, command: &str) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "#ALTA FUNC HEADER");
        let _ = writeln!(s, "#CMD {command}");
        let _ = writeln!(s, "#DIM {} {}", self.dim_in, self.channels.len());
        let _ = writeln!(s, "#PARAM_IN  {}", self.param_in);
        let _ = writeln!(s, "#PARAM_OUT RGB_COLOR");
        let _ = writeln!(s, "#ALTA HEADER END\n");
        let _ = writeln!(s, "#FUNC rational_function");
        let join = |v: &[f64]| {
            v.iter()
                .map(|x| format!("{x:.17e}"))
                .collect::<Vec<_>>()
                .join(" ")
        };
        for c in &self.channels {
            let _ = writeln!(s, "#MIN {}", join(&c.min));
            let _ = writeln!(s, "#MAX {}", join(&c.max));
            let _ = writeln!(s, "#NP {}", c.numerator.len());
            let _ = writeln!(s, "#NQ {}", c.denominator.len());
            for (idx, v) in c.numerator.iter().chain(&c.denominator) {
                let i: Vec<String> = idx.iter().map(u32::to_string).collect();
                let _ = writeln!(s, "{}\t{v:.17e}", i.join("\t"));
            }
        }
        s
    }

    /// Reads an ALTA rational function file.
    ///
    /// # Errors
    /// Unreadable file, missing `#DIM`/`#NP`/`#NQ`/`#MIN`/`#MAX`, coefficient
    /// lines of the wrong shape, non-finite values.
    pub fn read(path: &Path) -> Result<Self, BrdfError> {
        let text = std::fs::read_to_string(path).map_err(|e| BrdfError::io(path, e))?;
        Self::parse(&text, path)
    }

    /// Parses the text of an ALTA rational function file; `path` names it
    /// in errors.
    ///
    /// # Errors
    /// As [`AltaRational::read`], but for the file's own reading.
    pub fn parse(text: &str, path: &Path) -> Result<Self, BrdfError> {
        let bad = |r: String| BrdfError::malformed(path, "ALTA rational function", r);
        let mut dim = None;
        let mut param_in = String::new();
        let mut channels = Vec::new();
        let (mut min, mut max) = (Vec::new(), Vec::new());
        let (mut np, mut nq) = (None::<usize>, None::<usize>);
        let mut coeffs: Vec<(Vec<u32>, f64)> = Vec::new();
        let parse_vec =
            |it: std::str::SplitWhitespace<'_>, no: usize| -> Result<Vec<f64>, BrdfError> {
                it.map(|v| {
                    v.parse::<f64>()
                        .map_err(|_| bad(format!("line {no}: `{v}` is not a number")))
                })
                .collect()
            };
        // Closes one channel: its first `np` coefficients are the numerator.
        let mut flush =
            |min: &Vec<f64>, max: &Vec<f64>, np: usize, coeffs: &mut Vec<(Vec<u32>, f64)>| {
                let den = coeffs.split_off(np);
                channels.push(AltaChannel {
                    min: min.clone(),
                    max: max.clone(),
                    numerator: std::mem::take(coeffs),
                    denominator: den,
                });
            };
        for (i, line) in text.lines().enumerate() {
            let no = i + 1;
            let t = line.trim();
            if t.is_empty() {
                continue;
            }
            if let Some(h) = t.strip_prefix('#') {
                let mut it = h.split_whitespace();
                match it.next() {
                    Some("DIM") => {
                        dim = it.next().and_then(|v| v.parse::<usize>().ok());
                        // Checked here, before the coefficient lines size by it.
                        if let Some(d) =
                            dim.filter(|d| !(1..=rational_core::MAX_DIMENSION).contains(d))
                        {
                            return Err(bad(format!(
                                "line {no}: `#DIM` {d} is outside 1..={}",
                                rational_core::MAX_DIMENSION
                            )));
                        }
                    }
                    Some("PARAM_IN") => param_in = it.collect::<Vec<_>>().join(" "),
                    Some("MIN") => min = parse_vec(it, no)?,
                    Some("MAX") => max = parse_vec(it, no)?,
                    Some("NP") => {
                        if let (Some(p), Some(q)) = (np, nq) {
                            if Some(coeffs.len()) != p.checked_add(q) {
                                return Err(bad(format!(
                                    "line {no}: {} coefficients before, expected {p} + {q}",
                                    coeffs.len(),
                                )));
                            }
                            flush(&min, &max, p, &mut coeffs);
                        }
                        np = it.next().and_then(|v| v.parse().ok());
                        nq = None;
                    }
                    Some("NQ") => nq = it.next().and_then(|v| v.parse().ok()),
                    _ => {}
                }
                continue;
            }
            let d = dim.ok_or_else(|| bad("coefficients before `#DIM`".into()))?;
            coeffs.push(coefficient_line(t, d, no, &bad)?);
        }
        let d = dim.ok_or_else(|| bad("no `#DIM`".into()))?;
        let (p, q) = (
            np.ok_or_else(|| bad("no `#NP`".into()))?,
            nq.ok_or_else(|| bad("no `#NQ`".into()))?,
        );
        if Some(coeffs.len()) != p.checked_add(q) {
            return Err(bad(format!(
                "last channel has {} coefficients, expected {p} + {q}",
                coeffs.len(),
            )));
        }
        if min.len() != d || max.len() != d {
            return Err(bad(format!("`#MIN`/`#MAX` need {d} values")));
        }
        flush(&min, &max, p, &mut coeffs);
        if !(1..=rational_core::MAX_DIMENSION).contains(&d) {
            return Err(bad(format!(
                "`#DIM` {d} is outside 1..={}",
                rational_core::MAX_DIMENSION
            )));
        }
        check_channels(&channels, d, &bad)?;
        Ok(Self {
            dim_in: d,
            param_in,
            channels,
        })
    }
}

/// One coefficient line: `d` exponent indices and a finite value.
fn coefficient_line(
    t: &str,
    d: usize,
    no: usize,
    bad: &dyn Fn(String) -> BrdfError,
) -> Result<(Vec<u32>, f64), BrdfError> {
    let f: Vec<&str> = t.split_whitespace().collect();
    if f.len() != d + 1 {
        return Err(bad(format!(
            "line {no}: {} fields, expected {} indices and a value",
            f.len(),
            d
        )));
    }
    let idx = f[..d]
        .iter()
        .map(|v| {
            v.parse::<u32>()
                .map_err(|_| bad(format!("line {no}: index `{v}`")))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let c: f64 = f[d]
        .parse()
        .map_err(|_| bad(format!("line {no}: value `{}`", f[d])))?;
    if !c.is_finite() {
        return Err(bad(format!("line {no}: non-finite coefficient")));
    }
    Ok((idx, c))
}

/// Every channel's ranges (`d` finite, ordered), non-empty numerator and
/// denominator, and degrees at most [`MAX_ALTA_DEGREE`].
fn check_channels(
    channels: &[AltaChannel],
    d: usize,
    bad: &dyn Fn(String) -> BrdfError,
) -> Result<(), BrdfError> {
    for (k, c) in channels.iter().enumerate() {
        if c.min.len() != d || c.max.len() != d {
            return Err(bad(format!("channel {k}: `#MIN`/`#MAX` need {d} values")));
        }
        if let Some(j) = (0..d).find(|&j| !(c.min[j].is_finite() && c.max[j] >= c.min[j])) {
            return Err(bad(format!(
                "channel {k}: coordinate {j} has the range [{}, {}]",
                c.min[j], c.max[j]
            )));
        }
        if c.numerator.is_empty() || c.denominator.is_empty() {
            return Err(bad(format!(
                "channel {k}: an empty numerator or denominator"
            )));
        }
        if c.denominator.iter().all(|(_, v)| *v == 0.0) {
            return Err(bad(format!(
                "channel {k}: the denominator is identically zero"
            )));
        }
        let too_high = c
            .numerator
            .iter()
            .chain(&c.denominator)
            .flat_map(|(i, _)| i.iter())
            .find(|&&deg| deg > MAX_ALTA_DEGREE);
        if let Some(deg) = too_high {
            return Err(bad(format!(
                "channel {k}: degree {deg} is above {MAX_ALTA_DEGREE}"
            )));
        }
    }
    Ok(())
}
