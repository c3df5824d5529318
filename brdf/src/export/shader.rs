//! Shader source for a fitted BRDF (WGSL and GLSL): the Rusinkiewicz
//! coordinates, the same coordinate map as the library, the basis
//! recurrences and the coefficients inlined as literals. The operations and
//! their order mirror [`crate::CompactBrdf::eval`], the library's f32 path.

use crate::colour::ColourMode;
use crate::compact::{CompactBrdf, CompactChannel};
use crate::reduce::{Coordinates, PhiCoordinate};
use crate::shell::{ShellColour, ThetaDSpacing};
use crate::value_scale::ValueScale;
use crate::BrdfError;
use rational_core::BasisFamily;

/// Target shading language.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Language {
    /// WebGPU shading language.
    Wgsl,
    /// OpenGL shading language (450).
    Glsl,
}

struct Syntax {
    float: &'static str,
    vec3: &'static str,
    atan2: &'static str,
}

fn syntax(l: Language) -> Syntax {
    match l {
        Language::Wgsl => Syntax {
            float: "f32",
            vec3: "vec3<f32>",
            atan2: "atan2",
        },
        Language::Glsl => Syntax {
            float: "float",
            vec3: "vec3",
            atan2: "atan",
        },
    }
}

fn lit(v: f32) -> String {
    format!("({v:e})")
}

fn decl(l: Language, name: &str, ty: &str, mutable: bool) -> String {
    match l {
        Language::Wgsl => format!("{} {name}: {ty}", if mutable { "var" } else { "let" }),
        Language::Glsl => format!("{ty} {name}"),
    }
}

fn fn_header(l: Language, name: &str, args: &[(&str, &str)], ret: &str) -> String {
    match l {
        Language::Wgsl => {
            let a: Vec<String> = args.iter().map(|(n, t)| format!("{n}: {t}")).collect();
            format!("fn {name}({}) -> {ret} {{\n", a.join(", "))
        }
        Language::Glsl => {
            let a: Vec<String> = args.iter().map(|(n, t)| format!("{t} {n}")).collect();
            format!("{ret} {name}({}) {{\n", a.join(", "))
        }
    }
}

fn channel_fn(l: Language, s: &Syntax, c: &CompactChannel, k: usize, prefix: &str) -> String {
    let f = s.float;
    let mut out = fn_header(l, &format!("{prefix}_channel_{k}"), &[("x", s.vec3)], f);
    let comps = ["x", "y", "z"];
    for d in 0..c.lower.len() {
        let w = c.upper[d] - c.lower[d];
        let t = if w > 0.0 {
            format!(
                "(2.0 * (x.{} - {}) / {} - 1.0)",
                comps[d],
                lit(c.lower[d]),
                lit(w)
            )
        } else {
            "0.0".to_string()
        };
        out += &format!("    {} = {t};\n", decl(l, &format!("t{d}"), f, false));
        let deg = c.max_degree(d);
        out += &format!("    {} = 1.0;\n", decl(l, &format!("u{d}_0"), f, false));
        if deg >= 1 {
            out += &format!("    {} = t{d};\n", decl(l, &format!("u{d}_1"), f, false));
        }
        for j in 1..deg {
            let e = match c.family {
                BasisFamily::Monomial => format!("u{d}_{j} * t{d}"),
                BasisFamily::Chebyshev => format!("2.0 * t{d} * u{d}_{j} - u{d}_{}", j - 1),
                BasisFamily::Legendre => format!(
                    "({}.0 * t{d} * u{d}_{j} - {}.0 * u{d}_{}) / {}.0",
                    2 * j + 1,
                    j,
                    j - 1,
                    j + 1
                ),
            };
            out += &format!(
                "    {} = {e};\n",
                decl(l, &format!("u{d}_{}", j + 1), f, false)
            );
        }
    }
    out += &format!(
        "    {} = 0.0;\n    {} = 0.0;\n",
        decl(l, "p", f, true),
        decl(l, "q", f, true)
    );
    for (j, idx) in c.indices.iter().enumerate() {
        let phi: Vec<String> = idx
            .iter()
            .enumerate()
            .map(|(d, &e)| format!("u{d}_{e}"))
            .collect();
        let phi = phi.join(" * ");
        out += &format!("    {} = {phi};\n", decl(l, &format!("phi{j}"), f, false));
        if j < c.num.len() {
            out += &format!("    p = p + {} * phi{j};\n", lit(c.num[j]));
        }
        if j < c.den.len() {
            out += &format!("    q = q + {} * phi{j};\n", lit(c.den[j]));
        }
    }
    out += "    return p / q;\n}\n\n";
    out
}

/// Shader source defining `ratfit_brdf(wi, wo)` (RGB, the cosine factor not
/// included; zero below the horizon), with `wi`, `wo` unit vectors in the
/// local frame (z along the normal).
pub fn shader_source(b: &CompactBrdf, l: Language) -> String {
    source_with_prefix(b, l, "ratfit")
}

/// [`shader_source`] with every global name starting with `prefix` instead
/// of `ratfit` (`{prefix}_brdf`, `{prefix}_coords`, upper-case constants),
/// so that several fits can live in one shader. `prefix` must be an
/// identifier: ASCII letters, digits and `_`, not starting with a digit.
///
/// # Errors
/// [`BrdfError::Invalid`] when `prefix` is not such an identifier.
pub fn shader_source_named(
    b: &CompactBrdf,
    l: Language,
    prefix: &str,
) -> Result<String, BrdfError> {
    let identifier = !prefix.is_empty()
        && !prefix.starts_with(|c: char| c.is_ascii_digit())
        && prefix
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !identifier {
        return Err(BrdfError::Invalid {
            name: "shader prefix",
            reason: format!("`{prefix}` is not an identifier"),
        });
    }
    Ok(source_with_prefix(b, l, prefix))
}

/// `{prefix}_to_cut(d)`: beyond the fit's elevation cut, directions move
/// to the cut at the same azimuth (`brdf::clamp_elevation`); empty for a fit
/// of the whole hemisphere.
fn to_cut_fn(b: &CompactBrdf, l: Language, prefix: &str) -> String {
    if !b.has_elevation_cut() {
        return String::new();
    }
    let s = syntax(l);
    let (f, v3) = (s.float, s.vec3);
    let (sin_cut, cos_cut) = b.max_elevation.sin_cos();
    let mut out = fn_header(l, &format!("{prefix}_to_cut"), &[("d", v3)], v3);
    out += &format!("    if (d.z >= {}) {{ return d; }}\n", lit(cos_cut));
    out += &format!("    {} = length(d.xy);\n", decl(l, "s", f, false));
    out += "    if (s <= 0.0) { return d; }\n";
    out += &format!(
        "    return {v3}(d.x * ({} / s), d.y * ({} / s), {});\n}}\n\n",
        lit(sin_cut),
        lit(sin_cut),
        lit(cos_cut)
    );
    out
}

/// `{prefix}_lobe(wi, wo)`: the factors [`crate::LobeF32::factors`]
/// computes, in its order; empty for a fit without a lobe.
fn lobe_fn(b: &CompactBrdf, l: Language, prefix: &str) -> String {
    let Some(lobe) = &b.lobe else {
        return String::new();
    };
    let s = syntax(l);
    let (f, v3) = (s.float, s.vec3);
    let a2 = lobe.alpha * lobe.alpha;
    let mut out = fn_header(l, &format!("{prefix}_lobe"), &[("wi", v3), ("wo", v3)], v3);
    out += &format!("    {} = normalize(wi + wo);\n", decl(l, "h", v3, false));
    out += &format!(
        "    {} = h.z * h.z * ({} - 1.0) + 1.0;\n",
        decl(l, "t", f, false),
        lit(a2)
    );
    out += &format!(
        "    {} = {} / ({} * t * t);\n",
        decl(l, "d", f, false),
        lit(a2),
        lit(std::f32::consts::PI)
    );
    for (name, dir) in [("gi", "wi"), ("go", "wo")] {
        out += &format!(
            "    {} = max({dir}.z, 0.0);\n",
            decl(l, &format!("c_{name}"), f, false)
        );
        out += &format!(
            "    {} = 2.0 / (c_{name} + sqrt({} + (1.0 - {}) * c_{name} * c_{name}));\n",
            decl(l, name, f, false),
            lit(a2),
            lit(a2)
        );
    }
    out += &format!("    {} = 0.25 * d * gi * go;\n", decl(l, "spec", f, false));
    out += &format!(
        "    {} = 1.0 - clamp(dot(wi, h), 0.0, 1.0);\n",
        decl(l, "u", f, false)
    );
    out += &format!("    {} = u * u;\n", decl(l, "u2", f, false));
    out += &format!("    {} = u2 * u2 * u;\n", decl(l, "m", f, false));
    let terms: Vec<String> = (0..3)
        .map(|c| {
            format!(
                "{} + spec * ({} + (1.0 - {}) * m)",
                lit(lobe.kd_over_pi[c]),
                lit(lobe.f0[c]),
                lit(lobe.f0[c])
            )
        })
        .collect();
    out += &format!(
        "    {} = {v3}({});\n",
        decl(l, "v", v3, false),
        terms.join(", ")
    );
    match b.mode {
        ColourMode::Rgb => out += "    return v;\n}\n\n",
        ColourMode::LuminanceChroma => {
            let [wr, wg, wb] = crate::colour::LUMINANCE_WEIGHTS.map(|w| lit(w as f32));
            out += &format!(
                "    return {v3}({wr} * v.x + {wg} * v.y + {wb} * v.z, 1.0, 1.0);\n}}\n\n"
            );
        }
    }
    out
}

/// Statements that declare `h` (the half vector), `theta_h`, and `d`
/// (`wi` in the half vector's frame) from `wi` and `wo`, as
/// [`super::compact::half_diff_f32`] computes them: rotations by the
/// half vector's own sines and cosines, no trigonometry.
fn half_frame_statements(l: Language, prefix: &str) -> String {
    let s = syntax(l);
    let (f, v3) = (s.float, s.vec3);
    let mut out = String::new();
    out += &format!("    {} = normalize(wi + wo);\n", decl(l, "h", v3, false));
    out += &format!("    {} = {prefix}_elev(h);\n", decl(l, "theta_h", f, false));
    out += &format!("    {} = length(h.xy);\n", decl(l, "s", f, false));
    out += &format!(
        "    {} = 1.0;\n    {} = 0.0;\n",
        decl(l, "cp", f, true),
        decl(l, "sp", f, true)
    );
    out += "    if (s > 0.0) { cp = h.x / s; sp = h.y / s; }\n";
    out += &format!(
        "    {} = {v3}(wi.x * cp + wi.y * sp, wi.y * cp - wi.x * sp, wi.z);\n",
        decl(l, "a", v3, false)
    );
    out += &format!(
        "    {} = {v3}(a.x * h.z - a.z * s, a.y, a.x * s + a.z * h.z);\n",
        decl(l, "d", v3, false)
    );
    out
}

/// `{prefix}_shell(wi, wo)`: the shell factor's multipliers of the three
/// functions at the unclamped pair ([`super::compact::ShellF32::multipliers`],
/// its angles computed as [`super::compact::half_diff_f32`] does); empty for
/// a fit without a shell.
fn shell_fn(b: &CompactBrdf, l: Language, prefix: &str) -> String {
    let Some(shell) = &b.shell else {
        return String::new();
    };
    let s = syntax(l);
    let (f, v3) = (s.float, s.vec3);
    let n = shell.factors.len();
    let values: Vec<String> = shell.factors.iter().map(|&v| lit(v)).collect();
    let mut out = fn_header(l, &format!("{prefix}_shell"), &[("wi", v3), ("wo", v3)], v3);
    out += &format!(
        "    if (wi.z >= {c} && wo.z >= {c}) {{ return {v3}(1.0, 1.0, 1.0); }}\n",
        c = lit(b.max_elevation.cos())
    );
    out += &half_frame_statements(l, prefix);
    out += &format!("    {} = {prefix}_elev(d);\n", decl(l, "theta_d", f, false));
    let (nh, nd) = (shell.n_theta_h, shell.n_theta_d);
    let index = |var: &str, x: String, bins: usize| match l {
        Language::Wgsl => format!("    let {var} = min(u32({x}), {}u);\n", bins - 1),
        Language::Glsl => format!("    uint {var} = min(uint({x}), {}u);\n", bins - 1),
    };
    out += &index(
        "ih",
        format!("sqrt(max(theta_h, 0.0) / 1.5707963267949) * {nh}.0"),
        nh,
    );
    let spaced = match shell.spacing {
        ThetaDSpacing::Uniform => "max(theta_d, 0.0) / 1.5707963267949".to_string(),
        ThetaDSpacing::Cosine => "(1.0 - cos(clamp(theta_d, 0.0, 1.5707963267949)))".to_string(),
    };
    out += &index("id", format!("{spaced} * {nd}.0"), nd);
    let per_cell = shell.colour.factors_per_cell();
    out += &match l {
        Language::Wgsl => format!(
            "    var table = array<f32, {n}>({});\n    let cell = (ih * {nd}u + id) * {per_cell}u;\n",
            values.join(", ")
        ),
        Language::Glsl => format!(
            "    float table[{n}] = float[{n}]({});\n    uint cell = (ih * {nd}u + id) * {per_cell}u;\n",
            values.join(", ")
        ),
    };
    out += &match (shell.colour, b.mode) {
        (ShellColour::PerFunction, _) => {
            format!("    return {v3}(table[cell], table[cell + 1u], table[cell + 2u]);\n}}\n\n")
        }
        (ShellColour::Luminance, ColourMode::Rgb) => {
            format!("    return {v3}(table[cell], table[cell], table[cell]);\n}}\n\n")
        }
        (ShellColour::Luminance, ColourMode::LuminanceChroma) => {
            format!("    return {v3}(table[cell], 1.0, 1.0);\n}}\n\n")
        }
    };
    out
}

fn source_with_prefix(b: &CompactBrdf, l: Language, prefix: &str) -> String {
    let upper = prefix.to_ascii_uppercase();
    let s = syntax(l);
    let mut out = format!(
        "// Generated by ratfit: {} channels, {} coordinates.\n",
        b.channels.len(),
        b.dims
    );
    out += &match l {
        Language::Wgsl => format!(
            "const {upper}_MAX_THETA_D: f32 = {};\n\n",
            lit(b.max_theta_d)
        ),
        Language::Glsl => format!(
            "const float {upper}_MAX_THETA_D = {};\n\n",
            lit(b.max_theta_d)
        ),
    };
    out += &coords_fn(b, l, prefix);
    for (k, c) in b.channels.iter().enumerate() {
        out += &channel_fn(l, &s, c, k, prefix);
    }
    out += &to_cut_fn(b, l, prefix);
    out += &lobe_fn(b, l, prefix);
    out += &shell_fn(b, l, prefix);
    out += &brdf_fn(b, l, prefix);
    out
}

/// `{prefix}_elev` and `{prefix}_coords`: the fitting coordinates of a
/// direction pair (Rusinkiewicz angles, `theta_d` clamped to the cut,
/// `phi_d` folded by mirror symmetry).
fn coords_fn(b: &CompactBrdf, l: Language, prefix: &str) -> String {
    let upper = prefix.to_ascii_uppercase();
    let s = syntax(l);
    let (f, v3) = (s.float, s.vec3);
    let mut out = String::new();
    out += &fn_header(l, &format!("{prefix}_elev"), &[("v", v3)], f);
    out += &format!("    return {}(length(v.xy), v.z);\n}}\n\n", s.atan2);
    out += &fn_header(
        l,
        &format!("{prefix}_coords"),
        &[("wi", v3), ("wo", v3)],
        v3,
    );
    out += &half_frame_statements(l, prefix);
    out += &format!(
        "    {} = min({prefix}_elev(d), {upper}_MAX_THETA_D);\n",
        decl(l, "theta_d", f, false)
    );
    out += &format!(
        "    {} = {}(d.y, d.x);\n",
        decl(l, "phi_d", f, true),
        s.atan2
    );
    out += "    phi_d = abs(phi_d);\n";
    let (a, bb) = match b.coordinates {
        Coordinates::Radians => ("theta_h".to_string(), "theta_d".to_string()),
        Coordinates::SqrtThetaH => (
            "sqrt(max(theta_h, 0.0) / 1.5707963267949)".to_string(),
            "theta_d".to_string(),
        ),
        Coordinates::Cosines => ("cos(theta_h)".to_string(), "cos(theta_d)".to_string()),
    };
    let p = match b.phi {
        PhiCoordinate::Radians => "phi_d",
        PhiCoordinate::Cosine => "cos(phi_d)",
    };
    out += &format!("    return {v3}({a}, {bb}, {p});\n}}\n\n");
    out
}

/// `{prefix}_brdf`: the channels (times the lobe) combined into RGB, zero
/// below the horizon.
fn brdf_fn(b: &CompactBrdf, l: Language, prefix: &str) -> String {
    let s = syntax(l);
    let v3 = s.vec3;
    let mut out = String::new();
    out += &fn_header(l, &format!("{prefix}_brdf"), &[("wi", v3), ("wo", v3)], v3);
    out += &format!("    if (wi.z <= 0.0 || wo.z <= 0.0) {{ return {v3}(0.0, 0.0, 0.0); }}\n");
    let (wi, wo) = if b.has_elevation_cut() {
        (
            format!("{prefix}_to_cut(wi)"),
            format!("{prefix}_to_cut(wo)"),
        )
    } else {
        ("wi".to_string(), "wo".to_string())
    };
    out += &format!("    {} = {wi};\n", decl(l, "wi_c", v3, false));
    out += &format!("    {} = {wo};\n", decl(l, "wo_c", v3, false));
    out += &format!(
        "    {} = {prefix}_coords(wi_c, wo_c);\n",
        decl(l, "x", v3, false)
    );
    let components = ["x", "y", "z"];
    let calls: Vec<String> = (0..b.channels.len())
        .map(|k| {
            let mut call = format!("{prefix}_channel_{k}(x)");
            if b.scale.of(b.mode, k) == ValueScale::Log {
                // The exponent limit of `ValueScale::value_f32`.
                call = format!(
                    "exp(min({call}, {}))",
                    lit(crate::value_scale::LOG_EXPONENT_LIMIT as f32)
                );
            }
            if b.lobe.is_some() {
                call = format!("({call} * lobe.{})", components[k]);
            }
            if b.shell.is_some() {
                call = format!("({call} * shell.{})", components[k]);
            }
            call
        })
        .collect();
    if b.shell.is_some() {
        out += &format!(
            "    {} = {prefix}_shell(wi, wo);\n",
            decl(l, "shell", v3, false)
        );
    }
    if b.lobe.is_some() {
        out += &format!(
            "    {} = {prefix}_lobe(wi_c, wo_c);\n",
            decl(l, "lobe", v3, false)
        );
    }
    // The ceiling ([`CompactBrdf::ceiling`]) last, as the f32 path.
    let ceiled = |rgb: &str| match b.ceiling {
        Some(c) => format!(
            "min({rgb}, {v3}({}, {}, {}))",
            lit(c[0]),
            lit(c[1]),
            lit(c[2])
        ),
        None => rgb.to_string(),
    };
    match b.mode {
        ColourMode::Rgb => {
            out += &format!(
                "    return {};\n}}\n",
                ceiled(&format!(
                    "max({v3}({}), {v3}(0.0, 0.0, 0.0))",
                    calls.join(", ")
                ))
            );
        }
        ColourMode::LuminanceChroma => {
            // Luminance, then the ratios r / Y and b / Y; green from Y.
            let [wr, wg, wb] = crate::colour::LUMINANCE_WEIGHTS.map(|w| lit(w as f32));
            let f = s.float;
            out += &format!("    {} = max({}, 0.0);\n", decl(l, "y", f, false), calls[0]);
            out += &format!(
                "    {} = y * max({}, 0.0);\n",
                decl(l, "r", f, false),
                calls[1]
            );
            out += &format!(
                "    {} = y * max({}, 0.0);\n",
                decl(l, "b", f, false),
                calls[2]
            );
            out += &format!(
                "    return {};\n}}\n",
                ceiled(&format!(
                    "{v3}(r, max((y - {wr} * r - {wb} * b) / {wg}, 0.0), b)"
                ))
            );
        }
    }
    out
}
