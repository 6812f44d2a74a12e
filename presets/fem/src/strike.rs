//! Strike points on the outer surface and the surface-normal gains of the modes there.

use std::collections::HashMap;
use std::f64::consts::PI;

use super::element::EDGES;
use super::geom::{cross, dot, sub};
use super::mesh::{Geometry, TetMesh};

/// A strike location before evaluation: position (m), drawing coordinates, label.
#[derive(Clone, Debug)]
pub struct PathPoint {
    /// Position on the object, m.
    pub position: [f64; 3],
    /// Drawing coordinates in [0, 1]².
    pub xy: [f64; 2],
    /// Display label.
    pub label: String,
}

/// A boundary face of the mesh as a 6-node triangle: corners then mid-edges (01, 12, 02),
/// with the outward unit normal of its corner triangle.
struct Face {
    nodes: [u32; 6],
    normal: [f64; 3],
}

/// The boundary of a tetrahedral mesh (faces that belong to one element only).
pub struct Surface {
    faces: Vec<Face>,
}

fn edge_local(i: usize, j: usize) -> usize {
    let (a, b) = (i.min(j), i.max(j));
    4 + EDGES.iter().position(|&e| e == (a, b)).unwrap_or(0)
}

impl Surface {
    /// The boundary faces of `mesh` (faces of one element only), with outward normals.
    pub fn new(mesh: &TetMesh) -> Surface {
        let mut count: HashMap<[u32; 3], (usize, usize)> = HashMap::with_capacity(mesh.tets.len() * 2);
        for (e, t) in mesh.tets.iter().enumerate() {
            for opp in 0..4 {
                let mut key = [0u32; 3];
                let mut k = 0;
                for c in 0..4 {
                    if c != opp {
                        key[k] = t[c];
                        k += 1;
                    }
                }
                key.sort_unstable();
                count.entry(key).and_modify(|v| v.1 = usize::MAX).or_insert((e, opp));
            }
        }
        let mut faces = Vec::new();
        for (_, (e, opp)) in count {
            if opp == usize::MAX {
                continue;
            }
            let t = &mesh.tets[e];
            let loc: Vec<usize> = (0..4).filter(|&c| c != opp).collect();
            let (a, b, c) = (loc[0], loc[1], loc[2]);
            let x = |l: usize| mesh.nodes[t[l] as usize];
            let mut n = cross(sub(x(b), x(a)), sub(x(c), x(a)));
            // Outward: away from the opposite corner.
            if dot(n, sub(x(opp), x(a))) > 0.0 {
                n = [-n[0], -n[1], -n[2]];
            }
            let len = dot(n, n).sqrt();
            if len <= 0.0 {
                continue;
            }
            faces.push(Face {
                nodes: [t[a], t[b], t[c], t[edge_local(a, b)], t[edge_local(b, c)], t[edge_local(a, c)]],
                normal: [n[0] / len, n[1] / len, n[2] / len],
            });
        }
        // Deterministic order (HashMap iteration is not).
        faces.sort_by_key(|f| f.nodes);
        Surface { faces }
    }

    /// The boundary's corner triangles as a drawing surface (outward winding, only the
    /// vertices they use), or `None` above `max_triangles`.
    pub fn drawing(&self, mesh: &TetMesh, max_triangles: usize) -> Option<presets::DrawSurface> {
        if self.faces.len() > max_triangles {
            return None;
        }
        let mut index: HashMap<u32, u32> = HashMap::new();
        let mut vertices = Vec::new();
        let mut triangles = Vec::with_capacity(self.faces.len());
        for f in &self.faces {
            let x = |k: usize| mesh.nodes[f.nodes[k] as usize];
            let n = cross(sub(x(1), x(0)), sub(x(2), x(0)));
            let order = if dot(n, f.normal) >= 0.0 { [0, 1, 2] } else { [0, 2, 1] };
            let mut tri = [0u32; 3];
            for (slot, &k) in tri.iter_mut().zip(&order) {
                let node = f.nodes[k];
                *slot = *index.entry(node).or_insert_with(|| {
                    let p = mesh.nodes[node as usize];
                    vertices.push([p[0] as f32, p[1] as f32, p[2] as f32]);
                    (vertices.len() - 1) as u32
                });
            }
            triangles.push(tri);
        }
        Some(presets::DrawSurface { vertices, triangles })
    }

    /// Number of boundary faces.
    pub fn len(&self) -> usize {
        self.faces.len()
    }

    /// Whether the mesh has no boundary (never for a valid mesh).
    pub fn is_empty(&self) -> bool {
        self.faces.is_empty()
    }

    /// Locates `p` on the nearest boundary face: the six node ids, their quadratic triangle
    /// shape-function weights at the projection of `p`, and the outward normal.
    pub fn locate(&self, mesh: &TetMesh, p: [f64; 3]) -> Option<([u32; 6], [f64; 6], [f64; 3])> {
        let mut best: Option<(f64, usize, [f64; 3])> = None;
        for (fi, f) in self.faces.iter().enumerate() {
            let a = mesh.nodes[f.nodes[0] as usize];
            let b = mesh.nodes[f.nodes[1] as usize];
            let c = mesh.nodes[f.nodes[2] as usize];
            let (l, q) = closest_on_triangle(p, a, b, c);
            let d = sub(p, q);
            let dist = dot(d, d);
            if best.is_none_or(|(bd, _, _)| dist < bd) {
                best = Some((dist, fi, l));
            }
        }
        let (_, fi, l) = best?;
        let f = &self.faces[fi];
        let w = [
            l[0] * (2.0 * l[0] - 1.0),
            l[1] * (2.0 * l[1] - 1.0),
            l[2] * (2.0 * l[2] - 1.0),
            4.0 * l[0] * l[1],
            4.0 * l[1] * l[2],
            4.0 * l[0] * l[2],
        ];
        Some((f.nodes, w, f.normal))
    }
}

/// Barycentric coordinates of the point of triangle (a, b, c) closest to p, and that point
/// (Ericson, *Real-Time Collision Detection* §5.1.5).
pub(crate) fn closest_on_triangle(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return ([1.0, 0.0, 0.0], a);
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return ([0.0, 1.0, 0.0], b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return ([1.0 - v, v, 0.0], lerp(a, ab, v));
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return ([0.0, 0.0, 1.0], c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return ([1.0 - w, 0.0, w], lerp(a, ac, w));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return ([0.0, 1.0 - w, w], lerp(b, sub(c, b), w));
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    let q = [a[0] + ab[0] * v + ac[0] * w, a[1] + ab[1] * v + ac[1] * w, a[2] + ab[2] * v + ac[2] * w];
    ([1.0 - v - w, v, w], q)
}

fn lerp(a: [f64; 3], d: [f64; 3], t: f64) -> [f64; 3] {
    [a[0] + d[0] * t, a[1] + d[1] * t, a[2] + d[2] * t]
}

/// Exactly `n` (at least 1) strike points along a path over the outer surface of `geom`,
/// neighbours close together.
pub(crate) fn strike_path(geom: &Geometry, n: usize) -> Vec<PathPoint> {
    let n = n.max(1);
    match geom {
        Geometry::Box { lx, ly, lz, line } => {
            let (lx, ly, lz) = (*lx, *ly, *lz);
            if *line {
                // Along the top-face centre line.
                (0..n)
                    .map(|i| {
                        let f = (i as f64 + 0.5) / n as f64;
                        PathPoint { position: [f * lx, 0.5 * ly, lz], xy: [f, 0.5], label: format!("x = {f:.3} L") }
                    })
                    .collect()
            } else {
                // Serpentine rows over the top face, exactly n points: rows of n / rows
                // points, the first n % rows rows one more (so a count that is no product
                // of rows and columns is neither rounded up nor left with a short last row).
                let rows = ((n as f64 * ly / lx).sqrt().round() as usize).clamp(1, n);
                let mut out = Vec::with_capacity(n);
                for r in 0..rows {
                    let fy = (r as f64 + 0.5) / rows as f64;
                    let cols = n / rows + usize::from(r < n % rows);
                    for c0 in 0..cols {
                        let c = if r % 2 == 0 { c0 } else { cols - 1 - c0 };
                        let fx = (c as f64 + 0.5) / cols as f64;
                        out.push(PathPoint {
                            position: [fx * lx, fy * ly, lz],
                            xy: [fx, fy],
                            label: format!("x = {fx:.2} L, y = {fy:.2} W"),
                        });
                    }
                }
                out
            }
        }
        Geometry::Revolution { rev, outer_t, top_view } => {
            let (s0, s1) = (0.02 * rev.len, 0.98 * rev.len);
            // Outer extent, for drawing.
            let mut rmax: f64 = 0.0;
            for i in 0..=100 {
                let q = [0.0, rev.len * i as f64 / 100.0, *outer_t];
                let x = rev.map(q);
                rmax = rmax.max((x[0] * x[0] + x[1] * x[1]).sqrt());
            }
            let circ = 2.0 * PI * rmax.max(1e-12);
            if *top_view {
                // Archimedean spiral from the pole outwards, equal spacing along it:
                // s ∝ √(arc), about √(n/π) turns (spacing along ≈ spacing across turns).
                let turns = (n as f64 / PI).sqrt().max(1.0);
                (0..n)
                    .map(|i| {
                        let f = ((i as f64 + 0.5) / n as f64).sqrt();
                        let s = s0 + (s1 - s0) * f;
                        let th = 2.0 * PI * turns * f;
                        let x = rev.map([th, s, *outer_t]);
                        PathPoint {
                            position: x,
                            xy: [(0.5 + 0.5 * x[0] / rmax).clamp(0.0, 1.0), (0.5 + 0.5 * x[1] / rmax).clamp(0.0, 1.0)],
                            label: format!("r = {:.2}, {:.0} deg", s / rev.len, th.to_degrees() % 360.0),
                        }
                    })
                    .collect()
            } else {
                // Helix: turns chosen so spacing along the path ≈ spacing between turns.
                let turns = (n as f64 * (s1 - s0) / circ).sqrt().max(1.0);
                (0..n)
                    .map(|i| {
                        let f = (i as f64 + 0.5) / n as f64;
                        let s = s0 + (s1 - s0) * f;
                        let th = 2.0 * PI * turns * f;
                        let x = rev.map([th, s, *outer_t]);
                        let a = (th / (2.0 * PI)).fract();
                        PathPoint { position: x, xy: [a, f], label: format!("s = {f:.2}, {:.0} deg", a * 360.0) }
                    })
                    .collect()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A box's serpentine has exactly the asked number of points (it rounded up to a full
    /// grid: `--points 8` on a square face gave 9), each inside the top face, rows evenly
    /// spaced and each row's points in order.
    #[test]
    fn a_box_is_struck_at_exactly_the_points_asked() {
        for (lx, ly) in [(0.05, 0.05), (0.4, 0.3), (0.2, 0.08), (0.3, 0.02), (0.01, 0.3)] {
            let geom = Geometry::Box { lx, ly, lz: 0.01, line: false };
            for n in (1..=70).chain([127, 128, 500, presets::MAX_BANK_POINTS]) {
                let path = strike_path(&geom, n);
                assert_eq!(path.len(), n, "{lx} x {ly} m, {n} points");
                let mut rows: Vec<f64> = path.iter().map(|p| p.xy[1]).collect();
                rows.dedup();
                for p in &path {
                    assert!(p.xy.iter().all(|v| *v > 0.0 && *v < 1.0), "{lx} x {ly}, {n}: {:?}", p.xy);
                    assert!((p.position[2] - 0.01).abs() < 1e-15);
                }
                // Rows in order, evenly spaced, the serpentine running back and forth.
                for (r, y) in rows.iter().enumerate() {
                    assert!((y - (r as f64 + 0.5) / rows.len() as f64).abs() < 1e-12, "{n}: rows {rows:?}");
                }
                let counts: Vec<usize> = rows.iter().map(|y| path.iter().filter(|p| p.xy[1] == *y).count()).collect();
                assert!(counts.iter().max().unwrap() - counts.iter().min().unwrap() <= 1, "{n}: {counts:?}");
                // Even rows run in +x, odd rows in −x; a step along the path is at most a
                // row's spacing across plus a column's along (no jump back over the face).
                let dy = ly / rows.len() as f64;
                let dx = lx / *counts.iter().min().unwrap() as f64;
                for w in path.windows(2) {
                    let (a, b) = (w[0].position, w[1].position);
                    if a[1] == b[1] {
                        let row = rows.iter().position(|y| *y == w[0].xy[1]).unwrap();
                        assert_eq!(b[0] > a[0], row % 2 == 0, "{n}: row {row} runs the wrong way");
                    }
                    let step = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
                    assert!(step <= 1.0001 * (dx * dx + dy * dy).sqrt(), "{lx} x {ly}, {n}: step {step}");
                }
            }
        }
    }
}
