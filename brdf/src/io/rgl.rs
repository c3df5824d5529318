//! RGL `.bsdf` files (Dupuy and Jakob, "An Adaptive Parameterization for
//! Efficient Material Acquisition and Rendering", ACM TOG 2018): a
//! `tensor_file` container of named arrays, evaluated through the
//! visible-normal (VNDF) warp as in the authors' reference renderer.
//!
//! Evaluation of `(wi, wo)`: the half vector `m` is expressed in the unit
//! square `u_m = (sqrt(theta_m / (pi/2)), (phi_m - phi_i + pi) / 2 pi)`; the
//! inverse of the VNDF warp (a bilinear, piecewise-linear 2-D distribution
//! conditioned on `(phi_i, theta_i)`) gives the sample position at which
//! the RGB table is interpolated; the result is scaled by
//! `ndf(u_m) / (4 sigma(u_i))` when the file says its table is Jacobian-free.

use crate::geometry::{normalize, to_spherical, Vec3};
use crate::{Brdf, BrdfError};
use std::collections::HashMap;
use std::f64::consts::PI;
use std::path::Path;

/// One array of a tensor file.
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    /// Shape, outermost first.
    pub shape: Vec<usize>,
    /// Values converted to f64.
    pub data: Vec<f64>,
}

/// Parses Mitsuba's `tensor_file` container.
///
/// # Errors
/// Wrong magic, truncated header or data, unknown element types.
pub fn parse_tensor_file(bytes: &[u8], path: &Path) -> Result<HashMap<String, Field>, BrdfError> {
    let bad = |r: String| BrdfError::malformed(path, "tensor_file", r);
    if bytes.len() < 18 || &bytes[..12] != b"tensor_file\0" {
        return Err(bad("missing `tensor_file` magic".into()));
    }
    let mut pos = 14; // magic + version (2 bytes)
    let take = |pos: &mut usize, n: usize| -> Result<&[u8], BrdfError> {
        let s = bytes
            .get(*pos..*pos + n)
            .ok_or_else(|| bad(format!("header truncated at byte {}", *pos)))?;
        *pos += n;
        Ok(s)
    };
    let count = u32::from_le_bytes(take(&mut pos, 4)?.try_into().expect("4 bytes")) as usize;
    if count > 1000 {
        return Err(bad(format!("{count} fields")));
    }
    let mut fields = HashMap::new();
    for _ in 0..count {
        let name_len = u16::from_le_bytes(take(&mut pos, 2)?.try_into().expect("2 bytes")) as usize;
        let name = short_name(take(&mut pos, name_len)?);
        let ndim = u16::from_le_bytes(take(&mut pos, 2)?.try_into().expect("2 bytes")) as usize;
        let dtype = take(&mut pos, 1)?[0];
        let offset = u64::from_le_bytes(take(&mut pos, 8)?.try_into().expect("8 bytes")) as usize;
        let mut shape = Vec::with_capacity(ndim);
        for _ in 0..ndim {
            shape
                .push(u64::from_le_bytes(take(&mut pos, 8)?.try_into().expect("8 bytes")) as usize);
        }
        // Mitsuba's Struct::Type: 1 UInt8, 2 Int8, 3 UInt16, 4 Int16,
        // 5 UInt32, 6 Int32, 7 UInt64, 8 Int64, 10 Float32, 11 Float64.
        let width = match dtype {
            1 | 2 => 1,
            3 | 4 => 2,
            5 | 6 | 10 => 4,
            7 | 8 | 11 => 8,
            _ => {
                return Err(bad(format!(
                    "field `{name}`: unsupported element type {dtype}"
                )))
            }
        };
        let n = shape
            .iter()
            .try_fold(1usize, |acc, &d| acc.checked_mul(d))
            .ok_or_else(|| bad(format!("field `{name}`: shape {shape:?} overflows")))?;
        let raw = bytes
            .get(offset..offset.saturating_add(n.saturating_mul(width)))
            .ok_or_else(|| {
                bad(format!(
                    "field `{name}`: data truncated ({n} elements at byte {offset})"
                ))
            })?;
        let data = raw
            .chunks_exact(width)
            .map(|c| match dtype {
                1 => c[0] as f64,
                2 => c[0] as i8 as f64,
                3 => u16::from_le_bytes([c[0], c[1]]) as f64,
                4 => i16::from_le_bytes([c[0], c[1]]) as f64,
                5 => u32::from_le_bytes(c.try_into().expect("4")) as f64,
                6 => i32::from_le_bytes(c.try_into().expect("4")) as f64,
                7 => u64::from_le_bytes(c.try_into().expect("8")) as f64,
                8 => i64::from_le_bytes(c.try_into().expect("8")) as f64,
                10 => f32::from_le_bytes(c.try_into().expect("4")) as f64,
                _ => f64::from_le_bytes(c.try_into().expect("8")),
            })
            .collect();
        fields.insert(name, Field { shape, data });
    }
    Ok(fields)
}

/// Index of the interval `[v_i, v_{i+1}]` holding `x` (clamped to the ends).
fn find_interval(values: &[f64], x: f64) -> usize {
    let n = values.len();
    let first_not_below = values.partition_point(|&v| v < x);
    first_not_below.saturating_sub(1).min(n.saturating_sub(2))
}

/// A 2-D piecewise-bilinear distribution on `[0, 1]^2` conditioned on
/// parameters (multilinear interpolation between parameter slices).
#[derive(Debug, Clone)]
struct Marginal2D {
    nx: usize,
    ny: usize,
    params: Vec<Vec<f64>>,
    strides: Vec<usize>,
    data: Vec<f64>,
    marginal_cdf: Vec<f64>,
    conditional_cdf: Vec<f64>,
}

impl Marginal2D {
    /// `data` has shape `params... x ny x nx`; with `cdf`, each slice is
    /// normalised to a density and its CDFs are built.
    fn new(data: &[f64], nx: usize, ny: usize, params: Vec<Vec<f64>>, cdf: bool) -> Self {
        let mut strides = vec![0; params.len()];
        let mut slices = 1;
        for i in (0..params.len()).rev() {
            strides[i] = if params[i].len() > 1 { slices } else { 0 };
            slices *= params[i].len();
        }
        let n = nx * ny;
        let mut out = Self {
            nx,
            ny,
            params,
            strides,
            data: data.to_vec(),
            marginal_cdf: Vec::new(),
            conditional_cdf: Vec::new(),
        };
        if cdf {
            out.marginal_cdf = vec![0.0; slices * ny];
            out.conditional_cdf = vec![0.0; slices * n];
            for s in 0..slices {
                let d = &data[s * n..(s + 1) * n];
                let cc = &mut out.conditional_cdf[s * n..(s + 1) * n];
                for y in 0..ny {
                    let mut sum = 0.0;
                    cc[y * nx] = 0.0;
                    for x in 0..nx - 1 {
                        sum += 0.5 * (d[y * nx + x] + d[y * nx + x + 1]);
                        cc[y * nx + x + 1] = sum;
                    }
                }
                let mc = &mut out.marginal_cdf[s * ny..(s + 1) * ny];
                let mut sum = 0.0;
                for y in 0..ny - 1 {
                    sum += 0.5 * (cc[(y + 1) * nx - 1] + cc[(y + 2) * nx - 1]);
                    mc[y + 1] = sum;
                }
                let norm = 1.0 / mc[ny - 1];
                cc.iter_mut().for_each(|v| *v *= norm);
                mc.iter_mut().for_each(|v| *v *= norm);
                out.data[s * n..(s + 1) * n]
                    .iter_mut()
                    .for_each(|v| *v *= norm);
            }
        }
        out
    }

    fn weights(&self, param: &[f64]) -> (usize, Vec<[f64; 2]>) {
        let mut offset = 0;
        let mut w = Vec::with_capacity(self.params.len());
        for (dim, values) in self.params.iter().enumerate() {
            if values.len() == 1 {
                w.push([1.0, 0.0]);
                continue;
            }
            let i = find_interval(values, param[dim]);
            let t = ((param[dim] - values[i]) / (values[i + 1] - values[i])).clamp(0.0, 1.0);
            w.push([1.0 - t, t]);
            offset += self.strides[dim] * i;
        }
        (offset, w)
    }

    fn lookup(&self, arr: &[f64], i0: usize, size: usize, w: &[[f64; 2]], dim: usize) -> f64 {
        if dim == 0 {
            return arr[i0];
        }
        let i1 = i0 + self.strides[dim - 1] * size;
        let v0 = self.lookup(arr, i0, size, w, dim - 1);
        let v1 = if w[dim - 1][1] == 0.0 {
            0.0
        } else {
            self.lookup(arr, i1, size, w, dim - 1)
        };
        v0 * w[dim - 1][0] + v1 * w[dim - 1][1]
    }

    /// Bilinear interpolation of the (possibly normalised) table.
    fn eval(&self, pos: [f64; 2], param: &[f64]) -> f64 {
        let (slice, w) = self.weights(param);
        let d = self.params.len();
        let n = self.nx * self.ny;
        let px = pos[0].clamp(0.0, 1.0) * (self.nx - 1) as f64;
        let py = pos[1].clamp(0.0, 1.0) * (self.ny - 1) as f64;
        let ox = (px as usize).min(self.nx - 2);
        let oy = (py as usize).min(self.ny - 2);
        let (w1x, w1y) = (px - ox as f64, py - oy as f64);
        let i = ox + oy * self.nx + slice * n;
        let v = |k: usize| self.lookup(&self.data, i + k, n, &w, d);
        (1.0 - w1y) * ((1.0 - w1x) * v(0) + w1x * v(1))
            + w1y * ((1.0 - w1x) * v(self.nx) + w1x * v(self.nx + 1))
    }

    /// Inverse of the continuous warp: the uniform sample that maps to `pos`.
    fn invert(&self, pos: [f64; 2], param: &[f64]) -> [f64; 2] {
        let (slice, w) = self.weights(param);
        let d = self.params.len();
        let n = self.nx * self.ny;
        let sx = pos[0].clamp(0.0, 1.0) * (self.nx - 1) as f64;
        let sy = pos[1].clamp(0.0, 1.0) * (self.ny - 1) as f64;
        let px = (sx as usize).min(self.nx - 2);
        let py = (sy as usize).min(self.ny - 2);
        let (mut x, mut y) = (sx - px as f64, sy - py as f64);
        let offset = px + py * self.nx + slice * n;
        let data = |k: usize| self.lookup(&self.data, offset + k, n, &w, d);
        let (v00, v10, v01, v11) = (data(0), data(1), data(self.nx), data(self.nx + 1));
        let c0 = (1.0 - y) * v00 + y * v01;
        let c1 = (1.0 - y) * v10 + y * v11;
        x *= c0 + 0.5 * x * (c1 - c0);
        let v0 = self.lookup(&self.conditional_cdf, offset, n, &w, d);
        let v1 = self.lookup(&self.conditional_cdf, offset + self.nx, n, &w, d);
        x += (1.0 - y) * v0 + y * v1;
        let row = py * self.nx + slice * n;
        let r0 = self.lookup(&self.conditional_cdf, row + self.nx - 1, n, &w, d);
        let r1 = self.lookup(&self.conditional_cdf, row + 2 * self.nx - 1, n, &w, d);
        let row_mass = (1.0 - y) * r0 + y * r1;
        // A row without mass (every RGL file in the test data has 64) has
        // no warp: any position in it is as good, so keep the given one.
        x = if row_mass > 0.0 {
            x / row_mass
        } else {
            pos[0].clamp(0.0, 1.0)
        };
        y *= r0 + 0.5 * y * (r1 - r0);
        y += self.lookup(&self.marginal_cdf, py + slice * self.ny, self.ny, &w, d);
        [x, y]
    }
}

/// An isotropic RGB material of the RGL database.
#[derive(Debug, Clone)]
pub struct RglBrdf {
    name: String,
    description: String,
    ndf: Marginal2D,
    sigma: Marginal2D,
    vndf: Marginal2D,
    rgb: Marginal2D,
    jacobian: bool,
    view_as_incident: bool,
}

/// A field name as text for messages: a corrupt file may hold kilobytes of
/// raw bytes there, so at most 24 bytes, printable ASCII as is and the rest
/// as `\xNN`.
fn short_name(raw: &[u8]) -> String {
    let mut out: String = raw
        .iter()
        .take(24)
        .map(|&b| {
            if b.is_ascii_graphic() || b == b' ' {
                char::from(b).to_string()
            } else {
                format!("\\x{b:02x}")
            }
        })
        .collect();
    if raw.len() > 24 {
        out.push_str(&format!("... ({} bytes)", raw.len()));
    }
    out
}

/// Checks an angle axis: finite, strictly increasing, inside `range`.
fn check_axis(name: &str, v: &[f64], range: (f64, f64)) -> Result<(), String> {
    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
        return Err(format!("`{name}` holds a non-finite value ({x})"));
    }
    if let Some(w) = v.windows(2).find(|w| w[1] <= w[0]) {
        return Err(format!(
            "`{name}` is not increasing ({} then {})",
            w[0], w[1]
        ));
    }
    let slack = 1e-6;
    if let Some(x) = v
        .iter()
        .find(|&&x| x < range.0 - slack || x > range.1 + slack)
    {
        return Err(format!(
            "`{name}` value {x} is outside [{:.4}, {:.4}] rad",
            range.0, range.1
        ));
    }
    Ok(())
}

fn field<'a>(
    f: &'a HashMap<String, Field>,
    name: &str,
    path: &Path,
) -> Result<&'a Field, BrdfError> {
    f.get(name)
        .ok_or_else(|| BrdfError::malformed(path, "RGL .bsdf", format!("no `{name}` field")))
}

impl RglBrdf {
    /// Reads an isotropic RGB `.bsdf` file.
    ///
    /// # Errors
    /// Unreadable file, missing fields, inconsistent shapes, anisotropic or
    /// spectral-only files.
    pub fn read(path: &Path) -> Result<Self, BrdfError> {
        let (bytes, name) = crate::error::read_named(path)?;
        Self::from_bytes(&bytes, path, name)
    }

    /// Parses the bytes of a `.bsdf` file.
    ///
    /// # Errors
    /// As [`RglBrdf::read`].
    pub fn from_bytes(bytes: &[u8], path: &Path, name: String) -> Result<Self, BrdfError> {
        let f = parse_tensor_file(bytes, path)?;
        let bad = |r: String| BrdfError::malformed(path, "RGL .bsdf", r);
        let theta_i = field(&f, "theta_i", path)?;
        let phi_i = field(&f, "phi_i", path)?;
        let ndf = field(&f, "ndf", path)?;
        let sigma = field(&f, "sigma", path)?;
        let vndf = field(&f, "vndf", path)?;
        let rgb = f
            .get("rgb")
            .ok_or_else(|| bad("no `rgb` field (only RGB files are supported)".into()))?;
        let jacobian = field(&f, "jacobian", path)?;
        let description = f
            .get("description")
            .map(|d| d.data.iter().map(|&c| c as u8 as char).collect())
            .unwrap_or_default();
        let (nt, np) = (theta_i.data.len(), phi_i.data.len());
        if nt == 0 || np == 0 {
            return Err(bad(format!(
                "{nt} theta_i and {np} phi_i values: need at least one each"
            )));
        }
        if np > 2 {
            return Err(bad(format!(
                "{np} phi_i values: anisotropic files are not supported"
            )));
        }
        let shape_ok = ndf.shape.len() == 2
            && sigma.shape.len() == 2
            && vndf.shape.len() == 4
            && vndf.shape[..2] == [np, nt]
            && rgb.shape.len() == 5
            && rgb.shape[..3] == [np, nt, 3]
            && ndf
                .shape
                .iter()
                .chain(&sigma.shape)
                .chain(&vndf.shape[2..])
                .chain(&rgb.shape[3..])
                .all(|&s| s >= 2)
            && !jacobian.data.is_empty();
        if !shape_ok {
            return Err(bad(format!(
                "inconsistent shapes: theta_i {nt}, phi_i {np}, ndf {:?}, sigma {:?}, vndf {:?}, rgb {:?}",
                ndf.shape, sigma.shape, vndf.shape, rgb.shape
            )));
        }
        check_axis("theta_i", &theta_i.data, (0.0, PI / 2.0)).map_err(&bad)?;
        check_axis("phi_i", &phi_i.data, (-PI, 2.0 * PI)).map_err(&bad)?;
        for (n, fl) in [("ndf", ndf), ("sigma", sigma), ("vndf", vndf), ("rgb", rgb)] {
            if let Some(v) = fl.data.iter().find(|v| !v.is_finite()) {
                return Err(bad(format!("`{n}` holds a non-finite value ({v})")));
            }
        }
        if jacobian.data[0] != 0.0 && sigma.data.iter().any(|v| *v <= 0.0) {
            return Err(bad(
                "`sigma` holds a value at or below zero (it divides the NDF)".into(),
            ));
        }
        // The VNDF is a density per (phi_i, theta_i) slice: its warp needs
        // non-negative values with a positive integral.
        let slice = vndf.shape[2] * vndf.shape[3];
        if let Some(k) = vndf
            .data
            .chunks(slice)
            .position(|c| c.iter().any(|v| *v < 0.0) || c.iter().sum::<f64>() <= 0.0)
        {
            return Err(bad(format!(
                "`vndf` slice {k} is not a density (negative values or zero integral)"
            )));
        }
        let params2 = vec![phi_i.data.clone(), theta_i.data.clone()];
        Ok(Self {
            view_as_incident: false,
            name,
            description,
            ndf: Marginal2D::new(&ndf.data, ndf.shape[1], ndf.shape[0], vec![], false),
            sigma: Marginal2D::new(&sigma.data, sigma.shape[1], sigma.shape[0], vec![], false),
            vndf: Marginal2D::new(
                &vndf.data,
                vndf.shape[3],
                vndf.shape[2],
                params2.clone(),
                true,
            ),
            rgb: Marginal2D::new(
                &rgb.data,
                rgb.shape[4],
                rgb.shape[3],
                vec![
                    phi_i.data.clone(),
                    theta_i.data.clone(),
                    vec![0.0, 1.0, 2.0],
                ],
                false,
            ),
            jacobian: jacobian.data[0] != 0.0,
        })
    }

    /// The file's own description.
    pub fn description(&self) -> &str {
        &self.description
    }
}

fn theta2u(theta: f64) -> f64 {
    (theta * (2.0 / PI)).sqrt()
}

fn phi2u(phi: f64) -> f64 {
    (phi + PI) / (2.0 * PI)
}

impl RglBrdf {
    /// The other convention: the viewer in the table's incident slot, as
    /// Mitsuba 3's path tracer evaluates these files (`eval(wi, wo)` then
    /// looks the table up at `(wo, wi)`). The default keeps the measured
    /// illumination direction at `wi`, the light.
    pub fn with_view_as_incident(mut self, on: bool) -> Self {
        self.view_as_incident = on;
        self
    }
}

impl Brdf for RglBrdf {
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            return [0.0; 3];
        }
        let (wi, wo) = if self.view_as_incident {
            (wo, wi)
        } else {
            (wi, wo)
        };
        let m = normalize([wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]]);
        let (theta_i, phi_i) = to_spherical(wi);
        let (theta_m, phi_m) = to_spherical(m);
        let u_wi = [theta2u(theta_i), phi2u(phi_i)];
        let mut u_m = [theta2u(theta_m), phi2u(phi_m - phi_i)];
        u_m[1] -= u_m[1].floor();
        let params = [phi_i, theta_i];
        let sample = self.vndf.invert(u_m, &params);
        let scale = if self.jacobian {
            self.ndf.eval(u_m, &[]) / (4.0 * self.sigma.eval(u_wi, &[]))
        } else {
            1.0
        };
        // The tables hold the BRDF times the foreshortening cosine of wo.
        let scale = scale / wo[2];
        [0, 1, 2].map(|c| self.rgb.eval(sample, &[phi_i, theta_i, c as f64]) * scale)
    }

    fn name(&self) -> String {
        format!("RGL {}", self.name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn find_interval_clamps() {
        let v = [0.0, 1.0, 2.0, 3.0];
        assert_eq!(find_interval(&v, -1.0), 0);
        assert_eq!(find_interval(&v, 0.5), 0);
        assert_eq!(find_interval(&v, 1.0), 0);
        assert_eq!(find_interval(&v, 1.5), 1);
        assert_eq!(find_interval(&v, 9.0), 2);
    }

    #[test]
    fn invert_of_a_uniform_density_is_identity() {
        let m = Marginal2D::new(&[1.0; 16], 4, 4, vec![], true);
        for &(x, y) in &[(0.1, 0.2), (0.5, 0.9), (0.99, 0.01)] {
            let s = m.invert([x, y], &[]);
            assert!(
                (s[0] - x).abs() < 1e-12 && (s[1] - y).abs() < 1e-12,
                "{s:?}"
            );
        }
    }

    #[test]
    fn truncated_and_foreign_files_are_rejected() {
        let p = Path::new("<memory>");
        assert!(parse_tensor_file(b"not a tensor file at all", p).is_err());
        let mut b = b"tensor_file\0\x01\x00\x01\x00\x00\x00".to_vec();
        b.extend_from_slice(&3u16.to_le_bytes());
        b.extend_from_slice(b"abc");
        b.extend_from_slice(&1u16.to_le_bytes());
        b.push(10);
        b.extend_from_slice(&1000u64.to_le_bytes());
        b.extend_from_slice(&4u64.to_le_bytes());
        let e = parse_tensor_file(&b, p).unwrap_err().to_string();
        assert!(e.contains("truncated"), "{e}");
    }
}
