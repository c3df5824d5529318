//! Triangle meshes: OBJ input, procedural spheres and tori, and a
//! bounding-volume hierarchy for intersection.

use crate::error::{io, RenderError};
use crate::geometry::{Hit, Ray};
use crate::math::{add, cross, dot, length, normalize, scale, sub, Vec3};
use std::f64::consts::PI;
use std::path::Path;

/// Triangles in a leaf of the hierarchy.
const LEAF_SIZE: usize = 4;

#[derive(Debug, Clone, Copy)]
struct Node {
    min: Vec3,
    max: Vec3,
    /// First triangle (leaf) or the right child (inner; the left is next).
    index: u32,
    /// Triangles in a leaf; 0 for an inner node.
    count: u32,
    /// Split axis of an inner node.
    axis: u8,
}

/// An indexed triangle mesh with optional vertex normals.
#[derive(Debug, Clone)]
pub struct TriangleMesh {
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    triangles: Vec<[u32; 3]>,
    nodes: Vec<Node>,
}

impl TriangleMesh {
    /// A mesh from vertices, optional per-vertex normals and triangles.
    ///
    /// # Errors
    /// No triangles, an index out of range, non-finite positions or a
    /// normal count that differs from the vertex count.
    pub fn new(
        positions: Vec<Vec3>,
        normals: Option<Vec<Vec3>>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<Self, RenderError> {
        let bad = |reason: String| RenderError::Obj {
            path: "mesh".into(),
            line: 0,
            reason,
        };
        if triangles.is_empty() {
            return Err(bad("no triangles".into()));
        }
        if positions.iter().flatten().any(|v| !v.is_finite()) {
            return Err(bad("a vertex position is not finite".into()));
        }
        if let Some(n) = &normals {
            if n.len() != positions.len() {
                return Err(bad(format!(
                    "{} normals for {} vertices",
                    n.len(),
                    positions.len()
                )));
            }
        }
        if let Some(t) = triangles
            .iter()
            .find(|t| t.iter().any(|&i| i as usize >= positions.len()))
        {
            return Err(bad(format!(
                "triangle {t:?} refers past the {} vertices",
                positions.len()
            )));
        }
        let mut mesh = Self {
            positions,
            normals,
            triangles,
            nodes: Vec::new(),
        };
        mesh.build();
        Ok(mesh)
    }

    /// Reads a Wavefront OBJ file: `v`, `vn` and `f` lines (polygons are
    /// fanned into triangles; `i`, `i/j`, `i//k`, `i/j/k` and negative
    /// indices). Vertex normals are used only when every face gives them.
    ///
    /// # Errors
    /// The file cannot be read, or a line is malformed (named by number).
    pub fn read_obj(path: &Path) -> Result<Self, RenderError> {
        let text = std::fs::read_to_string(path).map_err(|e| io(path, e))?;
        Self::parse_obj(&text).map_err(|e| match e {
            RenderError::Obj { line, reason, .. } => RenderError::Obj {
                path: path.display().to_string(),
                line,
                reason,
            },
            other => other,
        })
    }

    /// Parses OBJ text (see [`TriangleMesh::read_obj`]).
    ///
    /// # Errors
    /// A malformed line, named by number.
    pub fn parse_obj(text: &str) -> Result<Self, RenderError> {
        let mut v: Vec<Vec3> = Vec::new();
        let mut vn: Vec<Vec3> = Vec::new();
        let mut corners: Vec<[(u32, Option<u32>); 3]> = Vec::new();
        for (k, raw) in text.lines().enumerate() {
            let line = k + 1;
            let err = |reason: String| RenderError::Obj {
                path: "OBJ".into(),
                line,
                reason,
            };
            let mut it = raw.split_whitespace();
            match it.next() {
                Some("v") | Some("vn") => {
                    let xs: Vec<f64> = it
                        .take(3)
                        .map(str::parse)
                        .collect::<Result<_, _>>()
                        .map_err(|e| err(format!("bad number: {e}")))?;
                    if xs.len() != 3 || xs.iter().any(|x| !x.is_finite()) {
                        return Err(err("needs three finite coordinates".into()));
                    }
                    let p = [xs[0], xs[1], xs[2]];
                    if raw.trim_start().starts_with("vn") {
                        vn.push(normalize(p));
                    } else {
                        v.push(p);
                    }
                }
                Some("f") => {
                    let refs: Vec<(u32, Option<u32>)> = it
                        .map(|c| parse_corner(c, v.len(), vn.len()).map_err(&err))
                        .collect::<Result<_, _>>()?;
                    if refs.len() < 3 {
                        return Err(err(format!("a face needs 3 vertices, has {}", refs.len())));
                    }
                    for i in 1..refs.len() - 1 {
                        corners.push([refs[0], refs[i], refs[i + 1]]);
                    }
                }
                _ => {}
            }
        }
        if corners.is_empty() {
            return Err(RenderError::Obj {
                path: "OBJ".into(),
                line: 0,
                reason: "no faces".into(),
            });
        }
        let all_normals = corners.iter().flatten().all(|c| c.1.is_some());
        if !all_normals {
            let triangles = corners.iter().map(|c| c.map(|x| x.0)).collect();
            return Self::new(v, None, triangles);
        }
        // Split vertices so that each (position, normal) pair is one vertex.
        let mut map = std::collections::HashMap::new();
        let (mut pos, mut nor, mut tris) = (Vec::new(), Vec::new(), Vec::new());
        for c in &corners {
            tris.push(c.map(|(p, n)| {
                *map.entry((p, n)).or_insert_with(|| {
                    pos.push(v[p as usize]);
                    nor.push(vn[n.unwrap_or(0) as usize]);
                    (pos.len() - 1) as u32
                })
            }));
        }
        Self::new(pos, Some(nor), tris)
    }

    /// A UV sphere of about `triangles` triangles with smooth normals.
    pub fn uv_sphere(center: Vec3, radius: f64, triangles: usize) -> Self {
        // 2 * rings * segments triangles (less the degenerate caps), segments = 2 rings.
        let rings = ((triangles as f64 / 4.0).sqrt().round() as usize).max(3);
        let segments = 2 * rings;
        let mut pos = Vec::new();
        let mut nor = Vec::new();
        for i in 0..=rings {
            let theta = PI * i as f64 / rings as f64;
            for j in 0..=segments {
                let phi = 2.0 * PI * j as f64 / segments as f64;
                let n = [
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                ];
                pos.push(add(center, scale(n, radius)));
                nor.push(n);
            }
        }
        let idx = |i: usize, j: usize| (i * (segments + 1) + j) as u32;
        let mut tris = Vec::new();
        for i in 0..rings {
            for j in 0..segments {
                let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
                if i != 0 {
                    tris.push([a, d, c]);
                }
                if i + 1 != rings {
                    tris.push([a, c, b]);
                }
            }
        }
        Self::new(pos, Some(nor), tris).expect("a valid procedural mesh")
    }

    /// A torus around the y axis with about `triangles` triangles.
    pub fn torus(center: Vec3, major: f64, minor: f64, triangles: usize) -> Self {
        let minor_segments = ((triangles as f64 / 6.0).sqrt().round() as usize).max(3);
        let major_segments = 3 * minor_segments;
        let mut pos = Vec::new();
        let mut nor = Vec::new();
        for i in 0..major_segments {
            let u = 2.0 * PI * i as f64 / major_segments as f64;
            let ring = [u.cos(), 0.0, u.sin()];
            for j in 0..minor_segments {
                let v = 2.0 * PI * j as f64 / minor_segments as f64;
                let n = add(scale(ring, v.cos()), [0.0, v.sin(), 0.0]);
                pos.push(add(center, add(scale(ring, major), scale(n, minor))));
                nor.push(n);
            }
        }
        let idx = |i: usize, j: usize| {
            ((i % major_segments) * minor_segments + j % minor_segments) as u32
        };
        let mut tris = Vec::new();
        for i in 0..major_segments {
            for j in 0..minor_segments {
                let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
                tris.push([a, c, b]);
                tris.push([a, d, c]);
            }
        }
        Self::new(pos, Some(nor), tris).expect("a valid procedural mesh")
    }

    /// Scales about the origin, then translates.
    pub fn transformed(mut self, factor: f64, offset: Vec3) -> Self {
        for p in &mut self.positions {
            *p = add(scale(*p, factor), offset);
        }
        if factor < 0.0 {
            if let Some(n) = &mut self.normals {
                n.iter_mut().for_each(|v| *v = scale(*v, -1.0));
            }
        }
        self.build();
        self
    }

    /// Vertex positions.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Per-vertex shading normals, when the mesh has them.
    pub fn normals(&self) -> Option<&[Vec3]> {
        self.normals.as_deref()
    }

    /// Vertex indices of each triangle.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Total area.
    pub fn area(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize]);
                0.5 * length(cross(sub(b, a), sub(c, a)))
            })
            .sum()
    }

    fn bounds(&self, tris: &[[u32; 3]]) -> (Vec3, Vec3) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for t in tris {
            for &i in t {
                let p = self.positions[i as usize];
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        (lo, hi)
    }

    fn centroid(&self, t: &[u32; 3]) -> Vec3 {
        let [a, b, c] = t.map(|i| self.positions[i as usize]);
        scale(add(add(a, b), c), 1.0 / 3.0)
    }

    /// Builds the hierarchy: median split along the widest centroid axis.
    fn build(&mut self) {
        self.nodes.clear();
        let mut tris = std::mem::take(&mut self.triangles);
        self.build_range(&mut tris, 0);
        self.triangles = tris;
    }

    fn build_range(&mut self, tris: &mut [[u32; 3]], first: usize) -> usize {
        let (min, max) = self.bounds(tris);
        let me = self.nodes.len();
        self.nodes.push(Node {
            min,
            max,
            index: first as u32,
            count: tris.len() as u32,
            axis: 0,
        });
        if tris.len() <= LEAF_SIZE {
            return me;
        }
        let mut clo = [f64::INFINITY; 3];
        let mut chi = [f64::NEG_INFINITY; 3];
        for t in tris.iter() {
            let c = self.centroid(t);
            for k in 0..3 {
                clo[k] = clo[k].min(c[k]);
                chi[k] = chi[k].max(c[k]);
            }
        }
        let axis = (0..3)
            .max_by(|&a, &b| (chi[a] - clo[a]).total_cmp(&(chi[b] - clo[b])))
            .unwrap_or(0);
        let mid = tris.len() / 2;
        tris.select_nth_unstable_by(mid, |a, b| {
            self.centroid(a)[axis].total_cmp(&self.centroid(b)[axis])
        });
        let (left, right) = tris.split_at_mut(mid);
        self.build_range(left, first);
        let r = self.build_range(right, first + mid);
        self.nodes[me].index = r as u32;
        self.nodes[me].count = 0;
        self.nodes[me].axis = axis as u8;
        me
    }

    /// The nearest hit of `ray` with the mesh.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let inv = ray.dir.map(|d| 1.0 / d);
        let mut t_max = ray.t_max;
        let mut best: Option<(usize, f64, f64, f64)> = None;
        let mut stack = [0usize; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let me = stack[top];
            let node = self.nodes[me];
            if !slab(&node, ray, inv, t_max) {
                continue;
            }
            if node.count > 0 {
                let start = node.index as usize;
                for k in start..start + node.count as usize {
                    if let Some((t, u, v)) = self.intersect_triangle(k, ray, t_max) {
                        t_max = t;
                        best = Some((k, t, u, v));
                    }
                }
            } else {
                // Visit the nearer child first.
                // The left child is stored right after its parent.
                let (left, right) = (me + 1, node.index as usize);
                let (near, far) = if ray.dir[node.axis as usize] >= 0.0 {
                    (left, right)
                } else {
                    (right, left)
                };
                if top + 2 > stack.len() {
                    continue;
                }
                stack[top] = far;
                stack[top + 1] = near;
                top += 2;
            }
        }
        let (k, t, u, v) = best?;
        let [a, b, c] = self.triangles[k].map(|i| self.positions[i as usize]);
        let ng = normalize(cross(sub(b, a), sub(c, a)));
        let ns = match &self.normals {
            Some(n) => {
                let [na, nb, nc] = self.triangles[k].map(|i| n[i as usize]);
                let s = add(add(scale(na, 1.0 - u - v), scale(nb, u)), scale(nc, v));
                let s = normalize(s);
                if dot(s, ng) < 0.0 {
                    scale(s, -1.0)
                } else {
                    s
                }
            }
            None => ng,
        };
        // Orient the geometric normal like the shading normal.
        let ng = if dot(ng, ns) < 0.0 {
            scale(ng, -1.0)
        } else {
            ng
        };
        Some(Hit {
            t,
            point: ray.at(t),
            geometric_normal: ng,
            shading_normal: ns,
        })
    }

    /// Moeller-Trumbore: `(t, u, v)` of a hit nearer than `t_max`.
    fn intersect_triangle(&self, k: usize, ray: &Ray, t_max: f64) -> Option<(f64, f64, f64)> {
        let [a, b, c] = self.triangles[k].map(|i| self.positions[i as usize]);
        let e1 = sub(b, a);
        let e2 = sub(c, a);
        let p = cross(ray.dir, e2);
        let det = dot(e1, p);
        if det.abs() < 1e-300 {
            return None;
        }
        let inv = 1.0 / det;
        let s = sub(ray.origin, a);
        let u = dot(s, p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = cross(s, e1);
        let v = dot(ray.dir, q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        let t = dot(e2, q) * inv;
        (t > ray.t_min && t < t_max).then_some((t, u, v))
    }
}

fn slab(node: &Node, ray: &Ray, inv: Vec3, t_max: f64) -> bool {
    let mut t0 = ray.t_min;
    let mut t1 = t_max;
    for k in 0..3 {
        let a = (node.min[k] - ray.origin[k]) * inv[k];
        let b = (node.max[k] - ray.origin[k]) * inv[k];
        let (a, b) = if a <= b { (a, b) } else { (b, a) };
        t0 = t0.max(a);
        t1 = t1.min(b);
        if t0 > t1 {
            return false;
        }
    }
    true
}

fn parse_corner(c: &str, nv: usize, nn: usize) -> Result<(u32, Option<u32>), String> {
    let mut parts = c.split('/');
    let resolve = |s: &str, n: usize, what: &str| -> Result<u32, String> {
        let i: i64 = s
            .parse()
            .map_err(|_| format!("bad {what} index `{s}` in `{c}`"))?;
        let k = if i > 0 { i - 1 } else { n as i64 + i };
        if i == 0 || k < 0 || k >= n as i64 {
            return Err(format!("{what} index {i} out of range (1..={n})"));
        }
        Ok(k as u32)
    };
    let p = resolve(parts.next().unwrap_or(""), nv, "vertex")?;
    let _texture = parts.next();
    let n = match parts.next() {
        Some(s) if !s.is_empty() => Some(resolve(s, nn, "normal")?),
        _ => None,
    };
    Ok((p, n))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    fn brute_force(mesh: &TriangleMesh, ray: &Ray) -> Option<f64> {
        (0..mesh.triangles.len())
            .filter_map(|k| mesh.intersect_triangle(k, ray, ray.t_max).map(|h| h.0))
            .min_by(f64::total_cmp)
    }

    #[test]
    fn hierarchy_finds_the_same_nearest_hit_as_brute_force() {
        let mesh = TriangleMesh::torus([0.1, -0.2, 0.3], 1.0, 0.35, 2000);
        assert!((1500..2500).contains(&mesh.triangle_count()));
        let mut rng = Rng::new(5, 0);
        let mut hits = 0;
        for _ in 0..2000 {
            let o = [0, 1, 2].map(|_| 4.0 * rng.uniform() - 2.0);
            let target = [0, 1, 2].map(|_| 1.2 * rng.uniform() - 0.6);
            let ray = Ray::new(o, normalize(sub(target, o)));
            let a = mesh.intersect(&ray).map(|h| h.t);
            let b = brute_force(&mesh, &ray);
            match (a, b) {
                (Some(a), Some(b)) => {
                    hits += 1;
                    assert!((a - b).abs() < 1e-12, "{a} vs {b}");
                }
                (None, None) => {}
                other => panic!("{other:?}"),
            }
        }
        assert!(hits > 200, "{hits} hits");
    }

    #[test]
    fn sphere_mesh_is_closed_and_close_to_the_sphere() {
        let mesh = TriangleMesh::uv_sphere([0.0; 3], 1.0, 1000);
        assert!(
            (900..1100).contains(&mesh.triangle_count()),
            "{}",
            mesh.triangle_count()
        );
        let area = mesh.area();
        assert!((area / (4.0 * PI) - 1.0).abs() < 0.02, "{area}");
        let h = mesh
            .intersect(&Ray::new([0.0, 0.0, 5.0], [0.0, 0.0, -1.0]))
            .unwrap();
        assert!((h.t - 4.0).abs() < 0.02 && h.shading_normal[2] > 0.99);
    }

    #[test]
    fn obj_faces_fan_and_errors_name_the_line() {
        let text = "# quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\n";
        let m = TriangleMesh::parse_obj(text).unwrap();
        assert_eq!(m.triangle_count(), 2);
        assert!((m.area() - 1.0).abs() < 1e-12);
        let m = TriangleMesh::parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n").unwrap();
        assert_eq!(m.triangle_count(), 1);
        for (bad, line, what) in [
            ("v 0 0\nf 1 1 1\n", 1, "three"),
            ("v 0 0 0\nv 1 0 0\nf 1 2\n", 3, "3 vertices"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", 4, "out of range"),
            ("v 0 0 nan\n", 1, "finite"),
            ("v 0 0 0\n", 0, "no faces"),
        ] {
            match TriangleMesh::parse_obj(bad) {
                Err(RenderError::Obj {
                    line: l, reason, ..
                }) => {
                    assert_eq!(l, line, "{bad}: {reason}");
                    assert!(reason.contains(what), "{bad}: {reason}");
                }
                other => panic!("{bad}: {other:?}"),
            }
        }
    }
}
