//! Generated WGSL: the fitted functions come from `brdf`'s shader export,
//! with their coefficients as literals (no per-coefficient buffer reads);
//! this module adds the kernels and the renderer's material code.

use crate::GpuError;
use brdf::shader::{shader_source, shader_source_named, Language};
use brdf::CompactBrdf;
use render_cpu::ClosedForm;
use std::fmt::Write;

/// Work-group size of the evaluation kernel.
pub(crate) const WORKGROUP: u32 = 64;

/// The batch evaluation kernel: `values[i] = ratfit_brdf(wi_i, wo_i)`, with
/// the pairs as two `vec4`s each (`xyz` used).
pub fn batch_shader(fit: &CompactBrdf) -> String {
    let mut s = shader_source(fit, Language::Wgsl);
    let _ = write!(
        s,
        r#"
struct Params {{
    count: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> pairs: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> values: array<vec4<f32>>;

@compute @workgroup_size({WORKGROUP})
fn eval_main(@builtin(global_invocation_id) id: vec3<u32>) {{
    let i = id.x;
    if (i >= params.count) {{
        return;
    }}
    values[i] = vec4<f32>(ratfit_brdf(pairs[2u * i].xyz, pairs[2u * i + 1u].xyz), 0.0);
}}
"#
    );
    s
}

/// WGSL of material `k`: `material_{k}(wi, wo)`, the BRDF in the local
/// frame, negative values set to zero as render-cpu does.
pub fn material_source(k: usize, form: &ClosedForm) -> Result<String, GpuError> {
    Ok(match form {
        ClosedForm::Lambert { albedo } => format!(
            "fn material_{k}(wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {{\n    return vec3<f32>({:e}, {:e}, {:e});\n}}\n\n",
            albedo[0] / std::f64::consts::PI,
            albedo[1] / std::f64::consts::PI,
            albedo[2] / std::f64::consts::PI,
        ),
        ClosedForm::Fit(fit) => {
            let prefix = format!("fit{k}");
            let mut s = shader_source_named(fit.compact(), Language::Wgsl, &prefix)?;
            // The generated function applies the fit's elevation cut itself.
            let _ = write!(
                s,
                "fn material_{k}(wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {{\n    return max({prefix}_brdf(wi, wo), vec3<f32>(0.0));\n}}\n\n"
            );
            s
        }
        other => {
            return Err(GpuError::Unsupported(format!(
                "material {k} ({other:?}): the GPU renderer draws Lambert and rational fits"
            )))
        }
    })
}

/// The renderer's shader for `materials` and `lights` lights.
pub fn render_shader(materials: &[ClosedForm], lights: usize) -> Result<String, GpuError> {
    let mut s = format!("const LIGHTS: u32 = {}u;\n\n", lights.max(1));
    s += RENDER_PRELUDE;
    for (k, m) in materials.iter().enumerate() {
        s += &material_source(k, m)?;
    }
    s += "fn material(id: u32, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {\n    switch id {\n";
    for k in 0..materials.len() {
        let _ = writeln!(s, "        case {k}u: {{ return material_{k}(wi, wo); }}");
    }
    s += "        default: { return vec3<f32>(0.0); }\n    }\n}\n";
    s += RENDER_MAIN;
    Ok(s)
}

const RENDER_PRELUDE: &str = r#"
struct Globals {
    origin: vec4<f32>,
    forward: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    // 1 / (tan(fov/2) aspect), 1 / tan(fov/2), near, far
    projection: vec4<f32>,
    // number of lights
    counts: vec4<u32>,
}

// xyz: direction towards the light (w = 0) or position (w = 1).
struct Light {
    where_: vec4<f32>,
    power: vec4<f32>,
}

@group(0) @binding(0) var<uniform> globals: Globals;
@group(0) @binding(1) var<uniform> lights: array<Light, LIGHTS>;

"#;

const RENDER_MAIN: &str = r#"
struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) shading_normal: vec3<f32>,
    @location(2) geometric_normal: vec3<f32>,
    @location(3) material: u32,
}

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) shading_normal: vec3<f32>,
    @location(2) @interpolate(flat) geometric_normal: vec3<f32>,
    @location(3) @interpolate(flat) material: u32,
}

// The pinhole camera of render-cpu: a pixel centre's ray passes through
// forward + sx right + sy up.
@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    let rel = v.position - globals.origin.xyz;
    let z = dot(rel, globals.forward.xyz);
    let near = globals.projection.z;
    let far = globals.projection.w;
    var out: VertexOut;
    out.clip = vec4<f32>(
        dot(rel, globals.right.xyz) * globals.projection.x,
        dot(rel, globals.up.xyz) * globals.projection.y,
        far / (far - near) * (z - near),
        z,
    );
    out.world = v.position;
    out.shading_normal = v.shading_normal;
    out.geometric_normal = v.geometric_normal;
    out.material = v.material;
    return out;
}

// Duff et al.'s orthonormal basis, as render_cpu::Frame::from_normal.
fn to_local(v: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = vec3<f32>(b, sign + n.y * n.y * a, -n.y);
    return vec3<f32>(dot(v, t), dot(v, bt), dot(v, n));
}

@fragment
fn fs_main(f: VertexOut) -> @location(0) vec4<f32> {
    let view = normalize(globals.origin.xyz - f.world);
    var ng = f.geometric_normal;
    var ns = normalize(f.shading_normal);
    if (dot(ns, ng) < 0.0) {
        ns = -ns;
    }
    // Two-sided surfaces: face the normals towards the viewer.
    if (dot(view, ng) < 0.0) {
        ng = -ng;
        ns = -ns;
    }
    let wo = to_local(view, ns);
    if (wo.z <= 0.0) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    var radiance = vec3<f32>(0.0);
    for (var i = 0u; i < globals.counts.x; i = i + 1u) {
        let light = lights[i];
        var dir = light.where_.xyz;
        var power = light.power.xyz;
        if (light.where_.w > 0.5) {
            let d = light.where_.xyz - f.world;
            let d2 = dot(d, d);
            dir = d / sqrt(d2);
            power = power / d2;
        }
        let wi = to_local(dir, ns);
        if (wi.z <= 0.0 || dot(dir, ng) <= 0.0) {
            continue;
        }
        radiance = radiance + power * material(f.material, wi, wo) * wi.z;
    }
    return vec4<f32>(radiance, 1.0);
}
"#;
