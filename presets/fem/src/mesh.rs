//! Tetrahedral meshes of the parametric solids, built without an external mesher.
//!
//! Every built-in shape is a triangulated base surface extruded through the thickness in
//! layers of prisms. Each prism is split into three tetrahedra by the minimum-global-index
//! rule (Dompierre, Labbé, Vallet & Camarero 1999, "How to subdivide pyramids, prisms and
//! hexahedra into tetrahedra"), which makes neighbouring elements conform without any
//! bookkeeping. The linear tetrahedra are then promoted to 10-node tetrahedra whose mid-edge
//! nodes are placed by the shape's own map, so curved boundaries are followed exactly at the
//! nodes (isoparametric elements).

use std::collections::HashMap;
use std::f64::consts::PI;

use super::element::EDGES;
use super::geom::{mid, signed_volume};
use super::{FemError, Shape};

/// A mesh of 10-node tetrahedra. Positions in metres.
#[derive(Clone, Debug)]
pub struct TetMesh {
    /// Node positions (m). The first `corners` are element corners, the rest mid-edge nodes.
    pub nodes: Vec<[f64; 3]>,
    /// Number of corner vertices (the first entries of `nodes`).
    pub corners: usize,
    /// Elements: corners 0–3 (positive orientation), then mid-edge nodes on the corner pairs
    /// (0,1), (1,2), (0,2), (0,3), (1,3), (2,3).
    pub tets: Vec<[u32; 10]>,
}

impl TetMesh {
    /// Builds a 10-node mesh from corner positions and 4-node tetrahedra, putting each
    /// mid-edge node at the midpoint of its edge (straight-sided elements). Tetrahedra with
    /// negative orientation are flipped.
    ///
    /// # Errors
    /// [`FemError::Mesh`] for an index out of range or a degenerate (zero-volume) element.
    pub fn from_linear(corners: Vec<[f64; 3]>, tets: &[[u32; 4]]) -> Result<TetMesh, FemError> {
        let params: Vec<[f64; 3]> = corners.clone();
        promote(params, tets, &|q| q, &|a, b| mid(a, b))
    }

    /// Total volume (m³) from the corner tetrahedra (exact for straight-sided elements).
    pub fn volume(&self) -> f64 {
        self.tets.iter().map(|t| signed_volume(&self.nodes, &[t[0], t[1], t[2], t[3]])).sum()
    }

    /// Axis-aligned bounding box (min, max), m.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.nodes {
            for i in 0..3 {
                lo[i] = lo[i].min(p[i]);
                hi[i] = hi[i].max(p[i]);
            }
        }
        (lo, hi)
    }
}

/// Promotes 4-node tetrahedra over parameter-space nodes `params` to 10-node tetrahedra:
/// mid-edge parameters come from `mid`, all positions from `map`.
pub(crate) fn promote(
    params: Vec<[f64; 3]>,
    tets: &[[u32; 4]],
    map: &dyn Fn([f64; 3]) -> [f64; 3],
    mid: &dyn Fn([f64; 3], [f64; 3]) -> [f64; 3],
) -> Result<TetMesh, FemError> {
    let nc = params.len();
    let mut nodes: Vec<[f64; 3]> = params.iter().map(|&q| map(q)).collect();
    let mut edge_node: HashMap<(u32, u32), u32> = HashMap::with_capacity(tets.len() * 2);
    let mut out = Vec::with_capacity(tets.len());
    let scale = {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in &nodes {
            for i in 0..3 {
                lo[i] = lo[i].min(p[i]);
                hi[i] = hi[i].max(p[i]);
            }
        }
        (0..3).map(|i| (hi[i] - lo[i]).max(0.0)).fold(0.0, f64::max)
    };
    for (e, t) in tets.iter().enumerate() {
        if t.iter().any(|&i| i as usize >= nc) {
            return Err(FemError::Mesh(format!("element {e} refers to a node that does not exist")));
        }
        let mut t = *t;
        let v = signed_volume(&nodes, &t);
        if !(v.abs() > 1e-14 * scale * scale * scale) {
            return Err(FemError::Mesh(format!(
                "element {e} has (nearly) zero volume ({v:.3e} m^3); the mesh is degenerate"
            )));
        }
        if v < 0.0 {
            t.swap(1, 2);
        }
        let mut full = [0u32; 10];
        full[..4].copy_from_slice(&t);
        for (k, &(i, j)) in EDGES.iter().enumerate() {
            let (a, b) = (t[i].min(t[j]), t[i].max(t[j]));
            let id = *edge_node.entry((a, b)).or_insert_with(|| {
                let q = mid(params[a as usize], params[b as usize]);
                nodes.push(map(q));
                (nodes.len() - 1) as u32
            });
            full[4 + k] = id;
        }
        out.push(full);
    }
    Ok(TetMesh { nodes, corners: nc, tets: out })
}

/// Splits the prism with bottom (p0, p1, p2) and top (p3, p4, p5) (p3 above p0, …) into three
/// tetrahedra; Dompierre et al. 1999, Table 2 and §3.2.
pub(crate) fn split_prism(p: [u32; 6], out: &mut Vec<[u32; 4]>) {
    const ROT: [[usize; 6]; 6] = [
        [0, 1, 2, 3, 4, 5],
        [1, 2, 0, 4, 5, 3],
        [2, 0, 1, 5, 3, 4],
        [3, 5, 4, 0, 2, 1],
        [4, 3, 5, 1, 0, 2],
        [5, 4, 3, 2, 1, 0],
    ];
    let imin = (0..6).min_by_key(|&i| p[i]).unwrap_or(0);
    let v: [u32; 6] = std::array::from_fn(|i| p[ROT[imin][i]]);
    if v[1].min(v[5]) < v[2].min(v[4]) {
        out.push([v[0], v[1], v[2], v[5]]);
        out.push([v[0], v[1], v[5], v[4]]);
        out.push([v[0], v[4], v[5], v[3]]);
    } else {
        out.push([v[0], v[1], v[2], v[4]]);
        out.push([v[0], v[4], v[2], v[5]]);
        out.push([v[0], v[4], v[5], v[3]]);
    }
}

/// A triangulated base surface in a 2-D parameter space, extruded in `layers` through
/// t ∈ [0, 1]. Node parameters are (p₀, p₁, t).
pub(crate) struct Layered {
    pub base: Vec<[f64; 2]>,
    pub tris: Vec<[u32; 3]>,
    pub layers: usize,
}

impl Layered {
    pub fn build(
        &self,
        map: &dyn Fn([f64; 3]) -> [f64; 3],
        mid: &dyn Fn([f64; 3], [f64; 3]) -> [f64; 3],
    ) -> Result<TetMesh, FemError> {
        let nb = self.base.len();
        let mut params = Vec::with_capacity(nb * (self.layers + 1));
        for l in 0..=self.layers {
            let t = l as f64 / self.layers as f64;
            params.extend(self.base.iter().map(|b| [b[0], b[1], t]));
        }
        let mut tets = Vec::with_capacity(self.tris.len() * self.layers * 3);
        for l in 0..self.layers {
            let (o0, o1) = ((l * nb) as u32, ((l + 1) * nb) as u32);
            for t in &self.tris {
                split_prism([t[0] + o0, t[1] + o0, t[2] + o0, t[0] + o1, t[1] + o1, t[2] + o1], &mut tets);
            }
        }
        promote(params, &tets, map, mid)
    }
}

/// Structured rectangle [0, lx] × [0, ly] with nx × ny cells, each split into two triangles
/// with alternating diagonals (no preferred direction).
pub(crate) fn rect_base(lx: f64, ly: f64, nx: usize, ny: usize) -> (Vec<[f64; 2]>, Vec<[u32; 3]>) {
    let mut base = Vec::with_capacity((nx + 1) * (ny + 1));
    for j in 0..=ny {
        for i in 0..=nx {
            base.push([lx * i as f64 / nx as f64, ly * j as f64 / ny as f64]);
        }
    }
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    let mut tris = Vec::with_capacity(2 * nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if (i + j) % 2 == 0 {
                tris.push([a, b, c]);
                tris.push([a, c, d]);
            } else {
                tris.push([a, b, d]);
                tris.push([b, c, d]);
            }
        }
    }
    (base, tris)
}

/// Rings of nodes around an axis: ring k at profile parameter `s[k]` with `counts[k]` nodes
/// (1 = a pole on the axis, angle NaN), triangulated ring to ring by angle. Parameters (θ, s).
pub(crate) fn rings_base(s: &[f64], counts: &[usize]) -> (Vec<[f64; 2]>, Vec<[u32; 3]>) {
    let mut base = Vec::new();
    let mut start = Vec::with_capacity(s.len());
    for (k, (&sk, &n)) in s.iter().zip(counts).enumerate() {
        start.push(base.len() as u32);
        if n == 1 {
            base.push([f64::NAN, sk]);
        } else {
            let off = 0.5 * (k % 2) as f64;
            for j in 0..n {
                base.push([2.0 * PI * (j as f64 + off) / n as f64, sk]);
            }
        }
    }
    let mut tris = Vec::new();
    for k in 0..s.len() - 1 {
        let (na, nb) = (counts[k], counts[k + 1]);
        let (a0, b0) = (start[k], start[k + 1]);
        let (oa, ob) = (0.5 * (k % 2) as f64, 0.5 * ((k + 1) % 2) as f64);
        if na == 1 {
            for j in 0..nb {
                tris.push([a0, b0 + j as u32, b0 + ((j + 1) % nb) as u32]);
            }
            continue;
        }
        if nb == 1 {
            for i in 0..na {
                tris.push([a0 + i as u32, a0 + ((i + 1) % na) as u32, b0]);
            }
            continue;
        }
        let (mut i, mut j) = (0usize, 0usize);
        while i < na || j < nb {
            let ta = 2.0 * PI * (i as f64 + 1.0 + oa) / na as f64;
            let tb = 2.0 * PI * (j as f64 + 1.0 + ob) / nb as f64;
            if j == nb || (i < na && ta <= tb) {
                tris.push([a0 + (i % na) as u32, a0 + ((i + 1) % na) as u32, b0 + (j % nb) as u32]);
                i += 1;
            } else {
                tris.push([a0 + (i % na) as u32, b0 + ((j + 1) % nb) as u32, b0 + (j % nb) as u32]);
                j += 1;
            }
        }
    }
    (base, tris)
}

/// A wall of revolution: reference curve P(s) = (r, z) in the meridian plane, s ∈ [0, len]
/// by arc length, and thickness `wall` along the unit normal N = (−T_z, T_r) (T the unit
/// tangent). Node parameters (θ, s, t): x = (P + t·wall·N) rotated by θ about z.
pub(crate) struct Revolution {
    /// Samples of the curve at uniform arc length (linear interpolation between them is only
    /// used for the parameter; positions come from `curve`).
    curve: Box<dyn Fn(f64) -> [f64; 2]>,
    /// Arc-length table: (arc length, curve parameter u).
    table: Vec<(f64, f64)>,
    pub len: f64,
    pub wall: f64,
}

impl Revolution {
    /// `curve(u)`, u ∈ [0, 1], smooth; reparameterised by arc length.
    pub fn new(curve: Box<dyn Fn(f64) -> [f64; 2]>, wall: f64) -> Revolution {
        let n = 4000;
        let mut table = Vec::with_capacity(n + 1);
        let mut acc = 0.0;
        let mut prev = curve(0.0);
        table.push((0.0, 0.0));
        for i in 1..=n {
            let u = i as f64 / n as f64;
            let p = curve(u);
            acc += ((p[0] - prev[0]).powi(2) + (p[1] - prev[1]).powi(2)).sqrt();
            table.push((acc, u));
            prev = p;
        }
        Revolution { curve, table, len: acc, wall }
    }

    fn u_of(&self, s: f64) -> f64 {
        let s = s.clamp(0.0, self.len);
        let i = self.table.partition_point(|&(a, _)| a < s).clamp(1, self.table.len() - 1);
        let (s0, u0) = self.table[i - 1];
        let (s1, u1) = self.table[i];
        if s1 > s0 {
            u0 + (u1 - u0) * (s - s0) / (s1 - s0)
        } else {
            u0
        }
    }

    /// Point and unit normal of the reference curve at arc length s.
    pub fn point_normal(&self, s: f64) -> ([f64; 2], [f64; 2]) {
        let u = self.u_of(s);
        let h = 1e-6;
        let (ua, ub) = ((u - h).max(0.0), (u + h).min(1.0));
        let (pa, pb) = ((self.curve)(ua), (self.curve)(ub));
        let (tr, tz) = (pb[0] - pa[0], pb[1] - pa[1]);
        let nrm = (tr * tr + tz * tz).sqrt().max(f64::MIN_POSITIVE);
        ((self.curve)(u), [-tz / nrm, tr / nrm])
    }

    pub fn map(&self, q: [f64; 3]) -> [f64; 3] {
        let (p, n) = self.point_normal(q[1]);
        let r = p[0] + q[2] * self.wall * n[0];
        let z = p[1] + q[2] * self.wall * n[1];
        let th = if q[0].is_nan() { 0.0 } else { q[0] };
        [r.max(0.0) * th.cos(), r.max(0.0) * th.sin(), z]
    }

    pub fn mid(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        let th = if a[0].is_nan() {
            b[0]
        } else if b[0].is_nan() {
            a[0]
        } else {
            let t = (a[0].sin() + b[0].sin()).atan2(a[0].cos() + b[0].cos());
            if t < 0.0 {
                t + 2.0 * PI
            } else {
                t
            }
        };
        [th, 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])]
    }

    /// Ring layout along the curve: `segments` + 1 rings, `around` nodes each, growing as 6k
    /// away from a pole (a curve end on the axis) so elements keep their shape there.
    pub fn rings(&self, segments: usize, around: usize) -> (Vec<f64>, Vec<usize>) {
        let pole0 = (self.curve)(0.0)[0].abs() < 1e-9 * self.len;
        let pole1 = (self.curve)(1.0)[0].abs() < 1e-9 * self.len;
        let mut s = Vec::with_capacity(segments + 1);
        let mut c = Vec::with_capacity(segments + 1);
        for k in 0..=segments {
            s.push(self.len * k as f64 / segments as f64);
            let mut n = around;
            if pole0 {
                n = n.min((6 * k).max(1));
            }
            if pole1 {
                n = n.min((6 * (segments - k)).max(1));
            }
            c.push(n);
        }
        (s, c)
    }
}

/// Where a shape is struck and how its strike points are drawn.
pub(crate) enum Geometry {
    /// Box [0, lx] × [0, ly] × [0, lz]; strikes on the top face z = lz.
    Box { lx: f64, ly: f64, lz: f64, line: bool },
    /// Wall of revolution; strikes on the side t = `outer_t`.
    Revolution { rev: Revolution, outer_t: f64, top_view: bool },
}

/// Finest resolution accepted (elements along the largest dimension); the corner-vertex
/// limit ([`crate::MAX_IMPORT_VERTICES`]) refuses most shapes well before it.
pub const MAX_RESOLUTION: usize = 20_000;

/// Refuses a mesh of `vertices` corner vertices over [`crate::MAX_IMPORT_VERTICES`], naming the
/// finest resolution that fits (found by bisection on `count`, the vertices at a resolution,
/// which grow with it).
fn check_vertices(
    vertices: usize,
    (resolution, min_layers, limit): (usize, usize, usize),
    count: impl Fn(usize) -> usize,
) -> Result<(), FemError> {
    if vertices <= limit {
        return Ok(());
    }
    let (mut lo, mut hi) = (2, resolution);
    if count(lo) > limit {
        return Err(FemError::InvalidOptions(format!(
            "this shape has {} corner vertices even at resolution 2 with {min_layers} element layer(s) through its walls, over the limit of {limit}; check its dimensions",
            count(lo)
        )));
    }
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if count(mid) <= limit {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Err(FemError::InvalidOptions(format!(
        "resolution {resolution} would mesh this shape with {vertices} corner vertices, over the limit of {limit}; use a resolution of at most {lo}"
    )))
}

/// Chooses the element size: `resolution` elements along the largest dimension.
fn divisions(len: f64, h: f64) -> usize {
    ((len / h).ceil() as usize).max(1)
}

/// Meshes `shape` and returns the geometry used to place strike points.
pub(crate) fn mesh_with_geometry(shape: &Shape, resolution: usize) -> Result<(TetMesh, Geometry), FemError> {
    mesh_with_layers(shape, resolution, 1)
}

/// [`mesh_with_geometry`] with at least `min_layers` elements through the wall of the shells
/// of revolution (tube, bowl, sphere shell, cup, bell): for reference solves.
pub(crate) fn mesh_with_layers(
    shape: &Shape,
    resolution: usize,
    min_layers: usize,
) -> Result<(TetMesh, Geometry), FemError> {
    mesh_or_count(shape, resolution, min_layers, None, crate::MAX_IMPORT_VERTICES)
}

/// [`mesh_with_layers`] with no limit on the corner vertices (for writing large meshes to
/// files, e.g. the `big_mesh` example; a bank build refuses them).
///
/// # Errors
/// As [`mesh_with_layers`] but the vertex limit.
pub fn mesh_shape_unlimited(shape: &Shape, resolution: usize, min_layers: usize) -> Result<TetMesh, FemError> {
    Ok(mesh_or_count(shape, resolution, min_layers.max(1), None, usize::MAX)?.0)
}

/// Corner vertices of [`mesh_with_layers`]'s mesh, counted without building it.
fn count_vertices(shape: &Shape, resolution: usize, min_layers: usize) -> usize {
    let counted = std::cell::Cell::new(usize::MAX);
    let _ = mesh_or_count(shape, resolution, min_layers, Some(&counted), usize::MAX);
    counted.get()
}

/// [`mesh_with_layers`]; with `count`, only counts the corner vertices into it (returning
/// an error once counted, before anything is built).
fn mesh_or_count(
    shape: &Shape,
    resolution: usize,
    min_layers: usize,
    count: Option<&std::cell::Cell<usize>>,
    limit: usize,
) -> Result<(TetMesh, Geometry), FemError> {
    shape.validate()?;
    if resolution < 2 {
        return Err(FemError::InvalidOptions(format!(
            "resolution {resolution} is too coarse; use at least 2 elements along the largest dimension"
        )));
    }
    if resolution > MAX_RESOLUTION {
        return Err(FemError::InvalidOptions(format!(
            "resolution {resolution} is too fine; the largest is {MAX_RESOLUTION} elements along the largest dimension"
        )));
    }
    let res = resolution as f64;
    // Counted before anything is allocated: a resolution too fine for the shape is refused
    // with the resolution that would fit, not by running out of memory.
    let fits = |vertices: usize| match count {
        Some(c) => {
            c.set(vertices);
            Err(FemError::InvalidOptions("counted".into()))
        }
        None => check_vertices(vertices, (resolution, min_layers, limit), |r| count_vertices(shape, r, min_layers)),
    };
    let boxed = |lx: f64, ly: f64, lz: f64, line: bool| -> Result<(TetMesh, Geometry), FemError> {
        let h = lx.max(ly).max(lz) / res;
        let (nx, ny, nz) = (divisions(lx, h), divisions(ly, h), divisions(lz, h).max(min_layers));
        fits((nx + 1).saturating_mul(ny + 1).saturating_mul(nz + 1))?;
        let (base, tris) = rect_base(lx, ly, nx, ny);
        let lay = Layered { base, tris, layers: nz };
        let mesh = lay.build(&|q| [q[0], q[1], q[2] * lz], &mid)?;
        Ok((mesh, Geometry::Box { lx, ly, lz, line }))
    };
    match *shape {
        Shape::Bar { length, width, thickness } => boxed(length, width, thickness, true),
        Shape::UndercutBar { length, width, thickness, depth, cut, exponent } => {
            // The box's layers between the cut underside and the flat top: quadratic nodes
            // are placed on the curved underside by the map.
            let h = length.max(width).max(thickness) / res;
            let (nx, ny, nz) = (divisions(length, h), divisions(width, h), divisions(thickness, h).max(2));
            fits((nx + 1).saturating_mul(ny + 1).saturating_mul(nz + 1))?;
            let (base, tris) = rect_base(length, width, nx, ny);
            let lay = Layered { base, tris, layers: nz };
            let bottom =
                move |x: f64| thickness - super::geom::undercut_thickness(x, length, thickness, depth, cut, exponent);
            let mesh = lay.build(
                &|q| {
                    let zb = bottom(q[0]);
                    [q[0], q[1], zb + q[2] * (thickness - zb)]
                },
                &mid,
            )?;
            Ok((mesh, Geometry::Box { lx: length, ly: width, lz: thickness, line: true }))
        }
        Shape::Plate { length, width, thickness } => boxed(length, width, thickness, false),
        Shape::Block { length, width, height } => boxed(length, width, height, false),
        Shape::CircularPlate { radius, thickness } => {
            let rev = Revolution::new(Box::new(move |u| [u * radius, 0.0]), thickness);
            let h = 2.0 * radius / res;
            let segs = divisions(radius, h).max(2);
            revolve(&fits, rev, segs, usize::MAX, divisions(thickness, h).max(min_layers), 1.0, true)
        }
        Shape::Tube { length, outer_radius, wall } => {
            let rev = Revolution::new(Box::new(move |u| [outer_radius, u * length]), wall);
            let h = length.max(2.0 * outer_radius) / res;
            let around = divisions(2.0 * PI * outer_radius, h).max(12);
            revolve(&fits, rev, divisions(length, h), around, divisions(wall, h).max(min_layers), 0.0, false)
        }
        Shape::PluggedTube { length, outer_radius, wall, plug } => {
            // The meridian section (the wall's strip, and the bore over the plug) in a
            // structured grid of the tube's element size, swept about the axis; the element
            // counts of the wall (along, around, through) are the plain tube's.
            let h = length.max(2.0 * outer_radius) / res;
            let bore = outer_radius - wall;
            let open = length - plug;
            let around = divisions(2.0 * PI * outer_radius, h).max(12);
            let mut rs = levels(0.0, bore, divisions(bore, h));
            rs.extend(levels(bore, outer_radius, divisions(wall, h)).into_iter().skip(1));
            let mut zs = if open > 1e-9 * length { levels(0.0, open, divisions(open, h)) } else { vec![0.0] };
            zs.extend(levels(open, length, divisions(plug, h)).into_iter().skip(1));
            let solid = |r: f64, z: f64| r > bore || z > open;
            fits(section_vertices(&rs, &zs, &solid, around))?;
            let (points, tris) = grid_section(&rs, &zs, &solid);
            let mesh = revolve_section(&points, &tris, around)?;
            let rev = Revolution::new(Box::new(move |u| [outer_radius, u * length]), wall);
            Ok((mesh, Geometry::Revolution { rev, outer_t: 0.0, top_view: false }))
        }
        Shape::Bowl { radius, wall } => {
            // Hemisphere, outer radius `radius`, opening up, pole at the bottom (z = 0).
            let rev = Revolution::new(
                Box::new(move |u| {
                    let phi = u * PI / 2.0;
                    [radius * phi.sin(), radius * (1.0 - phi.cos())]
                }),
                wall,
            );
            let h = 2.0 * radius / res;
            let around = divisions(2.0 * PI * radius, h).max(12);
            revolve(
                &fits,
                rev,
                divisions(rev_len_quarter(radius), h).max(3),
                around,
                divisions(wall, h).max(min_layers),
                0.0,
                true,
            )
        }
        Shape::SphereShell { radius, wall } => {
            let rev = Revolution::new(
                Box::new(move |u| {
                    let phi = u * PI;
                    [radius * phi.sin(), radius * (1.0 - phi.cos())]
                }),
                wall,
            );
            let h = 2.0 * radius / res;
            let around = divisions(2.0 * PI * radius, h).max(12);
            revolve(
                &fits,
                rev,
                divisions(PI * radius, h).max(4),
                around,
                divisions(wall, h).max(min_layers),
                0.0,
                false,
            )
        }
        Shape::Cup { radius, height, wall } => {
            // Flat bottom, rounded corner (fillet radius f), straight wall; outer surface.
            let f = (0.2 * radius).min(0.5 * height).max(2.0 * wall);
            let (l1, l2, l3) = (radius - f, 0.5 * PI * f, height - f);
            let total = l1 + l2 + l3;
            let rev = Revolution::new(
                Box::new(move |u| {
                    let s = u * total;
                    if s <= l1 {
                        [s, 0.0]
                    } else if s <= l1 + l2 {
                        let a = (s - l1) / f;
                        [radius - f + f * a.sin(), f - f * a.cos()]
                    } else {
                        [radius, f + (s - l1 - l2)]
                    }
                }),
                wall,
            );
            let h = (2.0 * radius).max(height) / res;
            let around = divisions(2.0 * PI * radius, h).max(12);
            let segs = divisions(total, h).max(4);
            revolve(&fits, rev, segs, around, divisions(wall, h).max(min_layers), 0.0, false)
        }
        Shape::Bell { radius, height, wall } => {
            // Simplified bell: elliptic crown (shoulder radius 0.55 R, 12 % of the height), then a
            // flaring body r = r_s + (R − r_s) v² down to the lip at z = 0. Constant wall.
            let rs = 0.55 * radius;
            let c = 0.12 * height;
            let rev = Revolution::new(
                Box::new(move |u| {
                    let split = 0.25;
                    if u <= split {
                        let a = u / split * PI / 2.0;
                        [rs * a.sin(), height - c + c * a.cos()]
                    } else {
                        let v = (u - split) / (1.0 - split);
                        [rs + (radius - rs) * v * v, (height - c) * (1.0 - v)]
                    }
                }),
                wall,
            );
            let h = (2.0 * radius).max(height) / res;
            let around = divisions(2.0 * PI * radius, h).max(12);
            let segs = divisions(rev.len, h).max(4);
            // The curve is the inner surface here (N points outward), so strikes go at t = 1.
            revolve(&fits, rev, segs, around, divisions(wall, h).max(min_layers), 1.0, false)
        }
    }
}

/// `n` + 1 equally spaced values from `a` to `b`.
fn levels(a: f64, b: f64, n: usize) -> Vec<f64> {
    (0..=n).map(|i| a + (b - a) * i as f64 / n as f64).collect()
}

/// Corner vertices of [`grid_section`]'s section swept `around` times ([`revolve_section`]):
/// the grid points of its solid cells, one vertex on the axis (r = 0), `around` elsewhere.
/// Counted without allocating.
fn section_vertices(rs: &[f64], zs: &[f64], inside: &dyn Fn(f64, f64) -> bool, around: usize) -> usize {
    let (nr, nz) = (rs.len(), zs.len());
    let solid =
        |i: usize, j: usize| i + 1 < nr && j + 1 < nz && inside(0.5 * (rs[i] + rs[i + 1]), 0.5 * (zs[j] + zs[j + 1]));
    let mut count = 0usize;
    for j in 0..nz {
        for i in 0..nr {
            // A grid point is used if any of the (up to four) cells around it is solid.
            let used = solid(i, j)
                || (i > 0 && solid(i - 1, j))
                || (j > 0 && solid(i, j - 1))
                || (i > 0 && j > 0 && solid(i - 1, j - 1));
            if used {
                let on_axis = rs[i] <= 1e-12 * rs[nr - 1];
                count = count.saturating_add(if on_axis { 1 } else { around });
            }
        }
    }
    count
}

/// A meridian section on the grid `rs` × `zs` (r ≥ 0 rising from the axis, z rising): the
/// cells whose centre is `inside`, each split into two triangles with alternating diagonals.
/// Returns the (r, z) nodes the cells use and the triangles.
fn grid_section(rs: &[f64], zs: &[f64], inside: &dyn Fn(f64, f64) -> bool) -> (Vec<[f64; 2]>, Vec<[u32; 3]>) {
    let (nr, nz) = (rs.len(), zs.len());
    let mut id = vec![u32::MAX; nr * nz];
    let mut points = Vec::new();
    let mut tris = Vec::new();
    let mut node = |i: usize, j: usize, points: &mut Vec<[f64; 2]>| {
        let k = j * nr + i;
        if id[k] == u32::MAX {
            id[k] = points.len() as u32;
            points.push([rs[i], zs[j]]);
        }
        id[k]
    };
    for j in 0..nz - 1 {
        for i in 0..nr - 1 {
            if !inside(0.5 * (rs[i] + rs[i + 1]), 0.5 * (zs[j] + zs[j + 1])) {
                continue;
            }
            let a = node(i, j, &mut points);
            let b = node(i + 1, j, &mut points);
            let c = node(i + 1, j + 1, &mut points);
            let d = node(i, j + 1, &mut points);
            if (i + j) % 2 == 0 {
                tris.extend([[a, b, c], [a, c, d]]);
            } else {
                tris.extend([[a, b, d], [b, c, d]]);
            }
        }
    }
    (points, tris)
}

/// A solid of revolution: the triangulated meridian section `points` (r, z), r ≥ 0 (r = 0
/// on the axis), `tris`, swept about the z axis in `around` equal sectors. Each triangle
/// sweeps a prism per sector, split into three tetrahedra by the minimum-index rule like the
/// layered meshes (its triangular faces lie in meridian planes and are shared as they are);
/// a triangle with a corner on the axis sweeps a pyramid, whose quadrilateral is split by
/// the same rule (the diagonal through its least index) into two tetrahedra, and one with
/// an edge on the axis a single tetrahedron. Node parameters are (θ, r, z), θ NaN on the
/// axis; mid-edge nodes are placed on the swept geometry (exact on cylinders and planes).
///
/// # Errors
/// [`FemError::Mesh`] for a degenerate element (a section triangle of no area).
pub(crate) fn revolve_section(points: &[[f64; 2]], tris: &[[u32; 3]], around: usize) -> Result<TetMesh, FemError> {
    let scale = points.iter().fold(0.0f64, |m, p| m.max(p[0].abs()).max(p[1].abs()));
    let on_axis = |p: [f64; 2]| p[0] <= 1e-12 * scale;
    let mut params = Vec::new();
    // First node of each section point: one node on the axis, `around` off it.
    let first: Vec<u32> = points
        .iter()
        .map(|&p| {
            let start = params.len() as u32;
            if on_axis(p) {
                params.push([f64::NAN, 0.0, p[1]]);
            } else {
                params.extend((0..around).map(|j| [2.0 * PI * j as f64 / around as f64, p[0], p[1]]));
            }
            start
        })
        .collect();
    let at = |p: u32, j: usize| -> u32 {
        if on_axis(points[p as usize]) {
            first[p as usize]
        } else {
            first[p as usize] + (j % around) as u32
        }
    };
    let mut tets = Vec::with_capacity(3 * tris.len() * around);
    for t in tris {
        // Corners on the axis first.
        let mut t = *t;
        t.sort_by_key(|&p| !on_axis(points[p as usize]));
        let axis = t.iter().filter(|&&p| on_axis(points[p as usize])).count();
        for j in 0..around {
            let (a, b, c) = (t[0], t[1], t[2]);
            match axis {
                0 => split_prism([at(a, j), at(b, j), at(c, j), at(a, j + 1), at(b, j + 1), at(c, j + 1)], &mut tets),
                1 => {
                    let apex = at(a, j);
                    let q = [at(b, j), at(c, j), at(c, j + 1), at(b, j + 1)];
                    let min = (0..4).min_by_key(|&k| q[k]).unwrap_or(0);
                    if min % 2 == 0 {
                        tets.extend([[apex, q[0], q[1], q[2]], [apex, q[0], q[2], q[3]]]);
                    } else {
                        tets.extend([[apex, q[0], q[1], q[3]], [apex, q[1], q[2], q[3]]]);
                    }
                }
                2 => tets.push([at(a, j), at(b, j), at(c, j), at(c, j + 1)]),
                _ => return Err(FemError::Mesh("a section triangle lies on the axis".into())),
            }
        }
    }
    let map = |q: [f64; 3]| {
        let th = if q[0].is_nan() { 0.0 } else { q[0] };
        [q[1] * th.cos(), q[1] * th.sin(), q[2]]
    };
    promote(params, &tets, &map, &Revolution::mid)
}

fn rev_len_quarter(r: f64) -> f64 {
    0.5 * PI * r
}

fn revolve(
    fits: &dyn Fn(usize) -> Result<(), FemError>,
    rev: Revolution,
    segments: usize,
    around: usize,
    layers: usize,
    outer_t: f64,
    top_view: bool,
) -> Result<(TetMesh, Geometry), FemError> {
    let (s, c) = rev.rings(segments, around);
    // The layout is a few numbers per ring: the mesh is counted before it is built.
    fits(c.iter().fold(0usize, |a, &n| a.saturating_add(n)).saturating_mul(layers + 1))?;
    let (base, tris) = rings_base(&s, &c);
    let lay = Layered { base, tris, layers };
    let mesh = lay.build(&|q| rev.map(q), &Revolution::mid)?;
    Ok((mesh, Geometry::Revolution { rev, outer_t, top_view }))
}
