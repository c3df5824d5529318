//! The compact binary format of the f32 form (`RFB1`): writing it, and
//! reading it back with every field checked.

use super::{CompactBrdf, CompactChannel, ShellF32, MAX_COEFFICIENT};
use crate::colour::ColourMode;
use crate::lobe::LobeF32;
use crate::reduce::{Coordinates, PhiCoordinate};
use crate::shell::{ShellColour, ThetaDSpacing};
use crate::value_scale::ValueScale;
use crate::BrdfError;
use rational_core::BasisFamily;
use std::f32::consts::PI;

impl CompactBrdf {
    /// The compact binary form: magic `RFB1`, header (coordinates, dims,
    /// channels, flags; `max_theta_d`; the elevation cut when flag bit 2 is
    /// set), then every channel (family, `n_p`, `n_q`, one byte per
    /// coordinate's degree weight when flag bit 0 is set, domain and
    /// coefficients as f32). Unweighted RGB fits of the whole hemisphere
    /// leave the flags 0; bit 1 marks the luminance-chroma mode; bit 3 a
    /// lobe, whose seven f32 (`kd / pi`, `f0`, `alpha`) follow the header;
    /// bit 4 a ceiling, three f32 after the lobe; bit 5 (with bit 2) a
    /// shell factor after the ceiling: one byte each for its `theta_h` and
    /// `theta_d` bins, then one f32 per cell, or three with bit 7 (one per
    /// function); bit 6 spaces its `theta_d` bins uniformly in
    /// `1 - cos theta_d`. Bits 6 and 7 of the coordinates byte give the
    /// functions' scale: 0 linear, 1 ([`ValueScale::Log`]) every function
    /// on the log scale, 2 ([`ValueScale::LogLight`]) those that carry
    /// light; its bit 5 marks `cos phi_d` as the third coordinate
    /// ([`PhiCoordinate::Cosine`]).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = b"RFB1".to_vec();
        let coords = match self.coordinates {
            Coordinates::Radians => 0u8,
            Coordinates::SqrtThetaH => 1,
            Coordinates::Cosines => 2,
        } | (match self.scale {
            ValueScale::Log => 1u8,
            ValueScale::LogLight => 2,
            _ => 0,
        } << 6)
            | (u8::from(self.phi == PhiCoordinate::Cosine) << 5);
        let weighted = self
            .channels
            .iter()
            .any(|c| c.weights.iter().any(|&w| w != 1));
        let cut = self.has_elevation_cut();
        let flags = u8::from(weighted)
            | (u8::from(self.mode == ColourMode::LuminanceChroma) << 1)
            | (u8::from(cut) << 2)
            | (u8::from(self.lobe.is_some()) << 3)
            | (u8::from(self.ceiling.is_some()) << 4)
            | (u8::from(self.shell.is_some()) << 5)
            | (u8::from(
                self.shell
                    .as_ref()
                    .is_some_and(|sh| sh.spacing == ThetaDSpacing::Cosine),
            ) << 6)
            | (u8::from(
                self.shell
                    .as_ref()
                    .is_some_and(|sh| sh.colour == ShellColour::PerFunction),
            ) << 7);
        out.extend_from_slice(&[coords, self.dims as u8, self.channels.len() as u8, flags]);
        out.extend_from_slice(&self.max_theta_d.to_le_bytes());
        if cut {
            out.extend_from_slice(&self.max_elevation.to_le_bytes());
        }
        if let Some(l) = &self.lobe {
            for v in l.kd_over_pi.iter().chain(&l.f0).chain([&l.alpha]) {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        for v in self.ceiling.iter().flatten() {
            out.extend_from_slice(&v.to_le_bytes());
        }
        if let Some(sh) = &self.shell {
            // Bins are at most MAX_SHELL_BINS, so one byte each.
            out.extend_from_slice(&[sh.n_theta_h as u8, sh.n_theta_d as u8]);
            for v in &sh.factors {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        for c in &self.channels {
            let fam = match c.family {
                BasisFamily::Monomial => 0u8,
                BasisFamily::Chebyshev => 1,
                BasisFamily::Legendre => 2,
            };
            out.push(fam);
            out.extend_from_slice(&(c.num.len() as u16).to_le_bytes());
            out.extend_from_slice(&(c.den.len() as u16).to_le_bytes());
            if weighted {
                // Weights are at most MAX_DEGREE_WEIGHT, so one byte each.
                out.extend(c.weights.iter().map(|&w| w as u8));
            }
            for v in c.lower.iter().chain(&c.upper).chain(&c.num).chain(&c.den) {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        out
    }

    /// Parses [`CompactBrdf::to_bytes`] output.
    ///
    /// # Errors
    /// Wrong magic, truncated data, unknown codes.
    pub fn from_bytes(b: &[u8]) -> Result<Self, BrdfError> {
        let p = std::path::Path::new("<compact>");
        let bad = |r: &str| BrdfError::malformed(p, "compact binary", r.to_string());
        if b.len() < 12 || &b[..4] != b"RFB1" {
            return Err(bad("missing RFB1 magic"));
        }
        let scale = match b[4] >> 6 {
            0 => ValueScale::Linear,
            1 => ValueScale::Log,
            2 => ValueScale::LogLight,
            _ => return Err(bad("unknown value scale code")),
        };
        let phi = if b[4] & 0x20 == 0 {
            PhiCoordinate::Radians
        } else {
            PhiCoordinate::Cosine
        };
        let coordinates = match b[4] & 0x1f {
            0 => Coordinates::Radians,
            1 => Coordinates::SqrtThetaH,
            2 => Coordinates::Cosines,
            _ => return Err(bad("unknown coordinates code")),
        };
        let dims = b[5] as usize;
        let nch = b[6] as usize;
        if !(2..=3).contains(&dims) {
            return Err(bad(&format!("{dims} coordinates (2 or 3 expected)")));
        }
        if nch != 3 {
            return Err(bad(&format!("{nch} channels (3 expected)")));
        }
        let weighted = b[7] & 1 == 1;
        let mode = if b[7] & 2 == 2 {
            ColourMode::LuminanceChroma
        } else {
            ColourMode::Rgb
        };
        let angle = |at: usize, what: &str| -> Result<f32, BrdfError> {
            let v = b
                .get(at..at + 4)
                .map(|w| f32::from_le_bytes(w.try_into().expect("4 bytes")))
                .ok_or_else(|| bad(&format!("truncated header ({what})")))?;
            if v > 0.0 && v <= PI / 2.0 + 1e-6 {
                Ok(v)
            } else {
                Err(bad(&format!("{what} {v} rad is outside (0, pi/2]")))
            }
        };
        let max_theta_d = angle(8, "grazing cut")?;
        let (max_elevation, mut pos) = if b[7] & 4 == 4 {
            (angle(12, "elevation cut")?, 16)
        } else {
            (PI / 2.0, 12)
        };
        let (lobe, next) = read_lobe(b, pos, b[7]).map_err(|r| bad(&r))?;
        pos = next;
        let ceiling = if b[7] & 16 == 16 {
            let raw = b
                .get(pos..pos + 12)
                .ok_or_else(|| bad("truncated ceiling"))?;
            pos += 12;
            let c: [f32; 3] = std::array::from_fn(|k| {
                f32::from_le_bytes(raw[4 * k..4 * k + 4].try_into().expect("4"))
            });
            if !c.iter().all(|v| v.is_finite() && *v > 0.0) {
                return Err(bad(&format!(
                    "ceiling {c:?} is not three positive, finite values"
                )));
            }
            Some(c)
        } else {
            None
        };
        let (shell, next) = read_shell(b, pos, b[7]).map_err(|r| bad(&r))?;
        pos = next;
        let mut channels = Vec::with_capacity(nch);
        for _ in 0..nch {
            let (channel, next) = read_channel(b, pos, dims, weighted).map_err(|r| bad(&r))?;
            channels.push(channel);
            pos = next;
        }
        if pos != b.len() {
            return Err(bad("trailing bytes"));
        }
        Ok(Self {
            mode,
            scale,
            lobe,
            ceiling,
            shell,
            coordinates,
            phi,
            dims,
            max_theta_d,
            max_elevation,
            channels,
        })
    }
}

/// The lobe of the compact binary at `pos` that header `flags` announce
/// (bit 3), if any, and the position after it, or what is wrong.
fn read_lobe(b: &[u8], pos: usize, flags: u8) -> Result<(Option<LobeF32>, usize), String> {
    if flags & 8 == 0 {
        return Ok((None, pos));
    }
    let raw = b.get(pos..pos + 28).ok_or("truncated lobe")?;
    let v: Vec<f32> = raw
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().expect("4")))
        .collect();
    let lobe = LobeF32 {
        kd_over_pi: [v[0], v[1], v[2]],
        f0: [v[3], v[4], v[5]],
        alpha: v[6],
    };
    lobe.validate().map_err(|e| format!("lobe: {e}"))?;
    Ok((Some(lobe), pos + 28))
}

/// The shell factor of the compact binary at `pos` that header `flags`
/// announce (bit 5, with bits 6 and 7 for its layout), if any, and the
/// position after it, or what is wrong.
fn read_shell(b: &[u8], pos: usize, flags: u8) -> Result<(Option<ShellF32>, usize), String> {
    if flags & 32 == 0 {
        if flags & 192 != 0 {
            return Err(format!(
                "flags {flags:#04x}: shell bits 6-7 without a shell factor"
            ));
        }
        return Ok((None, pos));
    }
    if flags & 4 == 0 {
        return Err("a shell factor without an elevation cut".into());
    }
    let spacing = if flags & 64 == 64 {
        ThetaDSpacing::Cosine
    } else {
        ThetaDSpacing::Uniform
    };
    let colour = if flags & 128 == 128 {
        ShellColour::PerFunction
    } else {
        ShellColour::Luminance
    };
    let head = b.get(pos..pos + 2).ok_or("truncated shell factor")?;
    let (n_theta_h, n_theta_d) = (head[0] as usize, head[1] as usize);
    if [n_theta_h, n_theta_d]
        .iter()
        .any(|&n| n == 0 || n > crate::MAX_SHELL_BINS)
    {
        return Err(format!(
            "shell factor bins {n_theta_h} x {n_theta_d} (each in 1..={})",
            crate::MAX_SHELL_BINS
        ));
    }
    let values = n_theta_h * n_theta_d * colour.factors_per_cell();
    let raw = b
        .get(pos + 2..pos + 2 + 4 * values)
        .ok_or("truncated shell factor")?;
    let factors: Vec<f32> = raw
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().expect("4")))
        .collect();
    if let Some(v) = factors
        .iter()
        .find(|v| !(v.is_finite() && (0.0..=crate::MAX_SHELL_FACTOR as f32).contains(*v)))
    {
        return Err(format!(
            "shell factor {v} is not in [0, {:e}]",
            crate::MAX_SHELL_FACTOR
        ));
    }
    Ok((
        Some(ShellF32 {
            n_theta_h,
            n_theta_d,
            spacing,
            colour,
            factors,
        }),
        pos + 2 + 4 * values,
    ))
}

/// One channel of the compact binary at `pos`: the channel and the position
/// after it, or what is wrong.
fn read_channel(
    b: &[u8],
    mut pos: usize,
    dims: usize,
    weighted: bool,
) -> Result<(CompactChannel, usize), String> {
    let head = b.get(pos..pos + 5).ok_or("truncated channel header")?;
    let family = match head[0] {
        0 => BasisFamily::Monomial,
        1 => BasisFamily::Chebyshev,
        2 => BasisFamily::Legendre,
        _ => return Err("unknown basis family code".into()),
    };
    let n_p = u16::from_le_bytes([head[1], head[2]]) as usize;
    let n_q = u16::from_le_bytes([head[3], head[4]]) as usize;
    if n_p == 0 || n_q == 0 {
        return Err("a channel with no numerator or denominator coefficient".into());
    }
    pos += 5;
    let weights: Vec<u16> = if weighted {
        let w = b.get(pos..pos + dims).ok_or("truncated degree weights")?;
        pos += dims;
        w.iter().map(|&w| u16::from(w)).collect()
    } else {
        vec![1; dims]
    };
    if weights
        .iter()
        .any(|&w| !(1..=rational_core::MAX_DEGREE_WEIGHT).contains(&w))
    {
        return Err("degree weight out of range".into());
    }
    let count = 2 * dims + n_p + n_q;
    let raw = b
        .get(pos..pos + 4 * count)
        .ok_or("truncated coefficients")?;
    pos += 4 * count;
    let v: Vec<f32> = raw
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().expect("4")))
        .collect();
    if v.iter().any(|x| !x.is_finite()) {
        return Err("a domain bound or coefficient is not finite".into());
    }
    if let Some(c) = v[2 * dims..].iter().find(|c| c.abs() > MAX_COEFFICIENT) {
        return Err(format!(
            "coefficient {c:e} is beyond {MAX_COEFFICIENT:e} in magnitude (f32 sums of such terms overflow; no fit has them)"
        ));
    }
    if (0..dims).any(|k| v[k] >= v[dims + k]) {
        return Err("an empty domain (lower bound not below upper)".into());
    }
    let indices = rational_core::weighted_graded_indices(&weights, n_p.max(n_q));
    let channel = CompactChannel {
        degrees: CompactChannel::degrees_of(&indices, dims),
        family,
        lower: v[..dims].to_vec(),
        upper: v[dims..2 * dims].to_vec(),
        weights,
        indices,
        num: v[2 * dims..2 * dims + n_p].to_vec(),
        den: v[2 * dims + n_p..].to_vec(),
    };
    Ok((channel, pos))
}
