//! Closed triangle surfaces from Wavefront OBJ and STL files, and their checks.
//!
//! Formats:
//! - Wavefront OBJ (Wavefront Technologies, *Advanced Visualizer* manual, appendix B1
//!   "Object Files (.obj)"): `v x y z [w]` vertices and `f i j k …` faces whose indices are
//!   1-based, may be negative (relative to the last vertex) and may carry texture and normal
//!   indices (`i/t`, `i//n`, `i/t/n`, ignored). Polygons are fan-triangulated. Other
//!   statements (`vt`, `vn`, `g`, `o`, `s`, `usemtl`, `mtllib`, `l`, `p`, …) are ignored.
//! - STL (3D Systems, *StereoLithography Interface Specification*, 1989/1988): ASCII
//!   (`solid … facet normal … outer loop vertex x y z ×3 endloop endfacet … endsolid`) or
//!   binary (80-byte header, u32 little-endian triangle count, then per triangle 12 f32
//!   — normal, three vertices — and a u16 attribute). A binary file may begin with the word
//!   "solid", so the file is taken as binary whenever its size is exactly 84 + 50·n. Stored
//!   normals are ignored (orientation comes from the vertex order and the checks below).
//!
//! Units are not part of either format: coordinates are taken as metres, scaled by the
//! caller's factor. Vertices at the same position are merged (OBJ: exactly; STL: within
//! 10⁻⁶ of the bounding-box diagonal, because STL repeats every vertex per triangle).
//!
//! [`check_surface`] validates the surface for voxelisation: it must be non-empty, finite,
//! closed (every edge shared by exactly two triangles), manifold, consistently oriented
//! (fixed here, outward normals), enclose a volume, and not intersect itself.

use std::collections::HashMap;
use std::time::{Duration, Instant};

use super::FemError;

/// Most triangles accepted from a surface file (bounds time and memory).
pub const MAX_SURFACE_TRIANGLES: usize = 2_000_000;
/// Zero-area triangles are dropped with a warning up to this fraction, an error above.
pub const MAX_DEGENERATE_FRACTION: f64 = 0.05;
/// Time budget of the self-intersection check; past it the check stops with a warning.
pub const SELF_INTERSECTION_BUDGET: Duration = Duration::from_secs(5);

/// A triangle surface. Positions in metres.
#[derive(Clone, Debug, Default)]
pub struct TriSurface {
    /// Vertex positions (m).
    pub vertices: Vec<[f64; 3]>,
    /// Triangles as vertex indices; after [`check_surface`], counter-clockwise seen from
    /// outside (outward normals by the right-hand rule).
    pub triangles: Vec<[u32; 3]>,
}

/// What [`check_surface`] found and fixed.
#[derive(Clone, Debug, Default)]
pub struct SurfaceReport {
    /// Triangles after the checks.
    pub triangles: usize,
    /// Zero-area triangles dropped.
    pub degenerate_dropped: usize,
    /// Triangles whose vertex order was reversed to make the orientation consistent and
    /// outward.
    pub flipped: usize,
    /// Closed pieces (connected components) of the surface.
    pub pieces: usize,
    /// Separate bodies found: pieces not enclosed by another piece (a cavity's wall is a piece
    /// but not a body; a ball inside a hollow ball's cavity is a second body). Of several,
    /// only the largest is kept (with a warning).
    pub bodies: usize,
    /// Enclosed volume, m³.
    pub volume: f64,
    /// Whether the self-intersection check ran to the end.
    pub intersection_check_complete: bool,
    /// Human-readable warnings.
    pub warnings: Vec<String>,
}

use super::geom::norm;
use super::geom::{cross, dot, sub};

fn file_err(line: usize, reason: impl Into<String>) -> FemError {
    FemError::MeshFile { line, reason: reason.into() }
}

/// An error about the whole file (no line to name).
fn whole_err(reason: impl Into<String>) -> FemError {
    FemError::Mesh(format!("cannot read the surface file: {}", reason.into()))
}

pub(crate) fn fmt_p(p: [f64; 3]) -> String {
    format!("({:.4}, {:.4}, {:.4}) m", p[0], p[1], p[2])
}

impl TriSurface {
    /// Axis-aligned bounding box (min, max), m.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.vertices {
            for i in 0..3 {
                lo[i] = lo[i].min(p[i]);
                hi[i] = hi[i].max(p[i]);
            }
        }
        (lo, hi)
    }

    /// Length of the bounding-box diagonal, m.
    pub fn diagonal(&self) -> f64 {
        let (lo, hi) = self.bounds();
        norm(sub(hi, lo))
    }

    /// Multiplies every coordinate by `s` (e.g. 0.001 for a file in millimetres).
    pub fn scale(&mut self, s: f64) {
        for p in &mut self.vertices {
            for c in p.iter_mut() {
                *c *= s;
            }
        }
    }

    /// Corner positions of triangle `t`.
    pub fn corners(&self, t: usize) -> [[f64; 3]; 3] {
        let [a, b, c] = self.triangles[t];
        [self.vertices[a as usize], self.vertices[b as usize], self.vertices[c as usize]]
    }

    /// Unit normal of triangle `t` by the right-hand rule (zero for a degenerate triangle).
    pub fn normal(&self, t: usize) -> [f64; 3] {
        let [a, b, c] = self.corners(t);
        let n = cross(sub(b, a), sub(c, a));
        let l = norm(n);
        if l > 0.0 {
            [n[0] / l, n[1] / l, n[2] / l]
        } else {
            [0.0; 3]
        }
    }

    /// Signed enclosed volume (divergence theorem), m³; positive for outward normals.
    pub fn signed_volume(&self) -> f64 {
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.corners(t);
                dot(a, cross(b, c)) / 6.0
            })
            .sum()
    }

    /// Merges vertices closer than `tol` (m; 0 merges only identical positions) and
    /// renumbers the triangles; unused vertices are dropped.
    pub fn merge_vertices(&mut self, tol: f64) {
        let mut map = vec![0u32; self.vertices.len()];
        let mut out: Vec<[f64; 3]> = Vec::with_capacity(self.vertices.len());
        if tol > 0.0 {
            // Cells of size tol: a merge partner is in one of the 27 neighbouring cells.
            let key = |p: [f64; 3]| -> [i64; 3] { std::array::from_fn(|i| (p[i] / tol).floor() as i64) };
            let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::with_capacity(self.vertices.len());
            for (i, &p) in self.vertices.iter().enumerate() {
                let k = key(p);
                let mut found = None;
                'search: for dx in -1..=1 {
                    for dy in -1..=1 {
                        for dz in -1..=1 {
                            if let Some(list) = cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) {
                                if let Some(&j) = list.iter().find(|&&j| norm(sub(out[j as usize], p)) <= tol) {
                                    found = Some(j);
                                    break 'search;
                                }
                            }
                        }
                    }
                }
                map[i] = found.unwrap_or_else(|| {
                    out.push(p);
                    let j = (out.len() - 1) as u32;
                    cells.entry(k).or_default().push(j);
                    j
                });
            }
        } else {
            let mut seen: HashMap<[u64; 3], u32> = HashMap::with_capacity(self.vertices.len());
            for (i, &p) in self.vertices.iter().enumerate() {
                // +0.0 and -0.0 are the same position.
                let k = p.map(|c| (c + 0.0).to_bits());
                map[i] = *seen.entry(k).or_insert_with(|| {
                    out.push(p);
                    (out.len() - 1) as u32
                });
            }
        }
        for t in &mut self.triangles {
            for v in t.iter_mut() {
                *v = map[*v as usize];
            }
        }
        // Drop unused vertices.
        let mut used = vec![u32::MAX; out.len()];
        let mut vertices = Vec::with_capacity(out.len());
        for t in &mut self.triangles {
            for v in t.iter_mut() {
                if used[*v as usize] == u32::MAX {
                    used[*v as usize] = vertices.len() as u32;
                    vertices.push(out[*v as usize]);
                }
                *v = used[*v as usize];
            }
        }
        self.vertices = vertices;
    }
}

/// Parses a Wavefront OBJ file into a triangle surface (vertices merged by exact position).
///
/// # Errors
/// [`FemError::MeshFile`] naming the line for a malformed number, a face index of 0 or out
/// of range, a face with fewer than three vertices, non-finite coordinates, too many
/// triangles ([`MAX_SURFACE_TRIANGLES`]) or no faces.
pub fn read_obj(text: &str) -> Result<TriSurface, FemError> {
    let mut s = TriSurface::default();
    let mut poly: Vec<u32> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let ln = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut f = line.split_whitespace();
        match f.next() {
            Some("v") => {
                let mut p = [0.0f64; 3];
                for (c, slot) in p.iter_mut().enumerate() {
                    let t = f.next().ok_or_else(|| file_err(ln, "a vertex needs three coordinates: v x y z"))?;
                    *slot =
                        t.parse().map_err(|_| file_err(ln, format!("coordinate {} {t:?} is not a number", c + 1)))?;
                    if !slot.is_finite() {
                        return Err(file_err(ln, "the vertex has a non-finite coordinate"));
                    }
                }
                if s.vertices.len() >= 3 * MAX_SURFACE_TRIANGLES {
                    return Err(file_err(
                        ln,
                        format!("more than {} vertices; simplify the model", 3 * MAX_SURFACE_TRIANGLES),
                    ));
                }
                s.vertices.push(p);
            }
            Some("f") | Some("fo") => {
                poly.clear();
                for t in f {
                    let idx = t.split('/').next().unwrap_or("");
                    let k: i64 =
                        idx.parse().map_err(|_| file_err(ln, format!("face index {t:?} is not an integer")))?;
                    let n = s.vertices.len() as i64;
                    // OBJ: 1-based; negative counts back from the latest vertex (-1 = last).
                    let j = if k > 0 { k - 1 } else { n + k };
                    if k == 0 || j < 0 || j >= n {
                        return Err(file_err(
                            ln,
                            format!("face index {k} is out of range (there are {n} vertices so far)"),
                        ));
                    }
                    poly.push(j as u32);
                }
                if poly.len() < 3 {
                    return Err(file_err(ln, "a face needs at least three vertices"));
                }
                for k in 1..poly.len() - 1 {
                    s.triangles.push([poly[0], poly[k], poly[k + 1]]);
                }
                if s.triangles.len() > MAX_SURFACE_TRIANGLES {
                    return Err(file_err(
                        ln,
                        format!("more than {MAX_SURFACE_TRIANGLES} triangles; simplify (decimate) the model"),
                    ));
                }
            }
            _ => {}
        }
    }
    if s.triangles.is_empty() {
        return Err(whole_err("no faces (f lines); this OBJ file has no surface"));
    }
    s.merge_vertices(0.0);
    Ok(s)
}

/// Parses an STL file, ASCII or binary (detected by size, see the module docs); vertices
/// within 10⁻⁶ of the bounding-box diagonal are merged.
///
/// # Errors
/// [`FemError::MeshFile`] for a file that is neither (with the sizes found), a facet
/// without three vertices (naming the line), non-finite coordinates, too many triangles or
/// no triangles.
pub fn read_stl(bytes: &[u8]) -> Result<TriSurface, FemError> {
    let binary_count =
        (bytes.len() >= 84).then(|| u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64);
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(512)]);
    let says_solid = head.trim_start().to_ascii_lowercase().starts_with("solid");
    // Exactly 84 + 50·n bytes: binary, even if the header begins with "solid". Without
    // "solid", trailing bytes after the n triangles are tolerated.
    let is_binary = binary_count.is_some_and(|n| {
        let want = 84 + 50 * n;
        want == bytes.len() as u64 || (!says_solid && want < bytes.len() as u64)
    });
    let size_note = |n: u64| {
        format!("as binary its header announces {n} triangles = {} bytes but the file has {}", 84 + 50 * n, bytes.len())
    };
    let mut s = if is_binary {
        read_stl_binary(bytes)?
    } else if says_solid {
        let s = read_stl_ascii(&String::from_utf8_lossy(bytes))?;
        if s.triangles.is_empty() {
            if let Some(n) = binary_count.filter(|&n| n > 0) {
                return Err(whole_err(format!("no ASCII facets found, and {} (truncated binary STL?)", size_note(n))));
            }
        }
        s
    } else {
        return Err(whole_err(match binary_count {
            Some(n) => format!("not an STL file: not ASCII (no 'solid'), and {}", size_note(n)),
            None => format!("not an STL file ({} bytes, shorter than a binary STL header)", bytes.len()),
        }));
    };
    if s.triangles.is_empty() {
        return Err(whole_err("the STL file has no triangles"));
    }
    let tol = 1e-6 * s.diagonal();
    s.merge_vertices(tol);
    Ok(s)
}

fn read_stl_binary(bytes: &[u8]) -> Result<TriSurface, FemError> {
    let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
    if n > MAX_SURFACE_TRIANGLES {
        return Err(whole_err(format!(
            "{n} triangles is more than the {MAX_SURFACE_TRIANGLES} supported; simplify (decimate) the model"
        )));
    }
    let mut s = TriSurface { vertices: Vec::with_capacity(3 * n), triangles: Vec::with_capacity(n) };
    let f = |o: usize| f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]) as f64;
    for t in 0..n {
        let base = 84 + 50 * t + 12;
        for v in 0..3 {
            let p: [f64; 3] = std::array::from_fn(|c| f(base + 12 * v + 4 * c));
            if p.iter().any(|c| !c.is_finite()) {
                return Err(whole_err(format!("binary STL triangle {t} has a non-finite coordinate")));
            }
            s.vertices.push(p);
        }
        let b = (3 * t) as u32;
        s.triangles.push([b, b + 1, b + 2]);
    }
    Ok(s)
}

fn read_stl_ascii(text: &str) -> Result<TriSurface, FemError> {
    let mut s = TriSurface::default();
    let mut facet: Vec<[f64; 3]> = Vec::with_capacity(3);
    let mut facet_line = 0;
    let mut in_facet = false;
    for (i, raw) in text.lines().enumerate() {
        let ln = i + 1;
        let mut f = raw.split_whitespace();
        match f.next().map(|w| w.to_ascii_lowercase()).as_deref() {
            Some("facet") => {
                if in_facet {
                    return Err(file_err(
                        ln,
                        format!("'facet' inside the facet begun on line {facet_line} (missing 'endfacet')"),
                    ));
                }
                in_facet = true;
                facet_line = ln;
                facet.clear();
            }
            Some("vertex") => {
                if !in_facet {
                    return Err(file_err(ln, "'vertex' outside a facet"));
                }
                let mut p = [0.0f64; 3];
                for slot in p.iter_mut() {
                    let t = f.next().ok_or_else(|| file_err(ln, "a vertex needs three coordinates"))?;
                    *slot = t.parse().map_err(|_| file_err(ln, format!("{t:?} is not a number")))?;
                    if !slot.is_finite() {
                        return Err(file_err(ln, "the vertex has a non-finite coordinate"));
                    }
                }
                facet.push(p);
            }
            Some("endfacet") => {
                if !in_facet || facet.len() != 3 {
                    return Err(file_err(
                        ln,
                        format!(
                            "the facet begun on line {facet_line} has {} vertices; STL facets are triangles",
                            facet.len()
                        ),
                    ));
                }
                in_facet = false;
                let b = s.vertices.len() as u32;
                s.vertices.extend_from_slice(&facet);
                s.triangles.push([b, b + 1, b + 2]);
                if s.triangles.len() > MAX_SURFACE_TRIANGLES {
                    return Err(file_err(
                        ln,
                        format!("more than {MAX_SURFACE_TRIANGLES} triangles; simplify (decimate) the model"),
                    ));
                }
            }
            _ => {}
        }
    }
    if in_facet {
        return Err(file_err(facet_line, "the file ends inside this facet (truncated?)"));
    }
    Ok(s)
}

/// A uniform grid over triangle bounding boxes (broad phase for the checks, the closest-point
/// queries and the inside test).
pub(crate) struct TriGrid {
    pub lo: [f64; 3],
    pub h: f64,
    pub dims: [usize; 3],
    /// CSR: triangles of cell c are `items[start[c]..start[c + 1]]`.
    start: Vec<u32>,
    items: Vec<u32>,
}

/// Most (cell, triangle) entries in a [`TriGrid`]; the cells grow until it fits.
const MAX_GRID_ENTRIES: usize = 40_000_000;
/// Most cells in a [`TriGrid`].
const MAX_GRID_CELLS: usize = 4_000_000;

impl TriGrid {
    /// A grid with about one triangle per cell (cells no smaller than `min_h`).
    pub fn new(s: &TriSurface, tris: &[u32], min_h: f64) -> TriGrid {
        let (lo, hi) = s.bounds();
        let ext = sub(hi, lo);
        let vol = ext.iter().map(|e| e.max(1e-9 * norm(ext))).product::<f64>();
        let mut h = (vol / tris.len().max(1) as f64).cbrt().max(min_h).max(1e-12);
        // Bounded: h doubles each time, so at most ~60 rounds before one cell holds all.
        for _ in 0..64 {
            let dims: [usize; 3] = std::array::from_fn(|i| ((ext[i] / h).floor() as usize + 1).max(1));
            let cells = dims[0].saturating_mul(dims[1]).saturating_mul(dims[2]);
            if cells > MAX_GRID_CELLS {
                h *= 2.0;
                continue;
            }
            let mut count = 0usize;
            for &t in tris {
                let (a, b) = Self::range_of(lo, h, dims, &s.corners(t as usize));
                count += (b[0] - a[0] + 1) * (b[1] - a[1] + 1) * (b[2] - a[2] + 1);
            }
            if count > MAX_GRID_ENTRIES {
                h *= 2.0;
                continue;
            }
            let mut start = vec![0u32; cells + 1];
            for &t in tris {
                let (a, b) = Self::range_of(lo, h, dims, &s.corners(t as usize));
                for z in a[2]..=b[2] {
                    for y in a[1]..=b[1] {
                        for x in a[0]..=b[0] {
                            start[(z * dims[1] + y) * dims[0] + x + 1] += 1;
                        }
                    }
                }
            }
            for c in 0..cells {
                start[c + 1] += start[c];
            }
            let mut fill = start.clone();
            let mut items = vec![0u32; count];
            for &t in tris {
                let (a, b) = Self::range_of(lo, h, dims, &s.corners(t as usize));
                for z in a[2]..=b[2] {
                    for y in a[1]..=b[1] {
                        for x in a[0]..=b[0] {
                            let c = (z * dims[1] + y) * dims[0] + x;
                            items[fill[c] as usize] = t;
                            fill[c] += 1;
                        }
                    }
                }
            }
            return TriGrid { lo, h, dims, start, items };
        }
        // Unreachable in practice (a single cell always fits); keep one cell of everything.
        TriGrid {
            lo,
            h: norm(ext).max(1e-12) * 2.0,
            dims: [1, 1, 1],
            start: vec![0, tris.len() as u32],
            items: tris.to_vec(),
        }
    }

    fn cell_of(lo: [f64; 3], h: f64, dims: [usize; 3], p: [f64; 3]) -> [usize; 3] {
        std::array::from_fn(|i| (((p[i] - lo[i]) / h).floor().max(0.0) as usize).min(dims[i] - 1))
    }

    fn range_of(lo: [f64; 3], h: f64, dims: [usize; 3], c: &[[f64; 3]; 3]) -> ([usize; 3], [usize; 3]) {
        let mn: [f64; 3] = std::array::from_fn(|i| c[0][i].min(c[1][i]).min(c[2][i]));
        let mx: [f64; 3] = std::array::from_fn(|i| c[0][i].max(c[1][i]).max(c[2][i]));
        (Self::cell_of(lo, h, dims, mn), Self::cell_of(lo, h, dims, mx))
    }

    fn cell(&self, x: usize, y: usize, z: usize) -> &[u32] {
        let c = (z * self.dims[1] + y) * self.dims[0] + x;
        &self.items[self.start[c] as usize..self.start[c + 1] as usize]
    }

    /// The first triangle of `s` (among those the grid holds, `skip` left out) that the ray
    /// o + t·d meets with t in (`t_min`, `t_max`): (t, triangle). The cells are walked in the
    /// ray's order (Amanatides & Woo 1987, "A fast voxel traversal algorithm"), each
    /// triangle tested by Möller & Trumbore (1997) with its edges included, so a ray through
    /// a shared edge is not lost between the two triangles.
    pub fn first_hit(
        &self,
        s: &TriSurface,
        o: [f64; 3],
        d: [f64; 3],
        (t_min, t_max): (f64, f64),
        skip: &dyn Fn(u32) -> bool,
    ) -> Option<(f64, u32)> {
        // Clip the ray to the grid's box.
        let (mut t0, mut t1) = (t_min.max(0.0), t_max);
        for i in 0..3 {
            let hi = self.lo[i] + self.h * self.dims[i] as f64;
            if d[i] == 0.0 {
                if o[i] < self.lo[i] || o[i] > hi {
                    return None;
                }
                continue;
            }
            let (a, b) = ((self.lo[i] - o[i]) / d[i], (hi - o[i]) / d[i]);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        if !(t0 <= t1) {
            return None;
        }
        let p0: [f64; 3] = std::array::from_fn(|i| o[i] + t0 * d[i]);
        let mut c = Self::cell_of(self.lo, self.h, self.dims, p0);
        let mut next = [f64::INFINITY; 3];
        let mut delta = [f64::INFINITY; 3];
        for i in 0..3 {
            if d[i] > 0.0 {
                next[i] = (self.lo[i] + (c[i] + 1) as f64 * self.h - o[i]) / d[i];
                delta[i] = self.h / d[i];
            } else if d[i] < 0.0 {
                next[i] = (self.lo[i] + c[i] as f64 * self.h - o[i]) / d[i];
                delta[i] = -self.h / d[i];
            }
        }
        let mut best: Option<(f64, u32)> = None;
        loop {
            for &t in self.cell(c[0], c[1], c[2]) {
                if skip(t) {
                    continue;
                }
                if let Some(th) = ray_triangle(o, d, s.corners(t as usize)) {
                    if th > t_min && th < t_max && best.is_none_or(|(b, _)| th < b) {
                        best = Some((th, t));
                    }
                }
            }
            let axis = (0..3).min_by(|&a, &b| next[a].total_cmp(&next[b])).unwrap_or(0);
            let exit = next[axis];
            if best.is_some_and(|(b, _)| b <= exit) || exit > t1 {
                return best;
            }
            if d[axis] > 0.0 {
                if c[axis] + 1 >= self.dims[axis] {
                    return best;
                }
                c[axis] += 1;
            } else {
                if c[axis] == 0 {
                    return best;
                }
                c[axis] -= 1;
            }
            next[axis] += delta[axis];
        }
    }

    /// The closest point of the surface to `p` among triangles within `radius` (m): the
    /// point, its distance and the triangle.
    pub fn closest(&self, s: &TriSurface, p: [f64; 3], radius: f64) -> Option<([f64; 3], f64, usize)> {
        let a = Self::cell_of(self.lo, self.h, self.dims, sub(p, [radius; 3]));
        let b = Self::cell_of(self.lo, self.h, self.dims, [p[0] + radius, p[1] + radius, p[2] + radius]);
        let mut best: Option<([f64; 3], f64, usize)> = None;
        for z in a[2]..=b[2] {
            for y in a[1]..=b[1] {
                for x in a[0]..=b[0] {
                    for &t in self.cell(x, y, z) {
                        let [ta, tb, tc] = s.corners(t as usize);
                        let (_, q) = super::strike::closest_on_triangle(p, ta, tb, tc);
                        let d = norm(sub(p, q));
                        if d <= radius && best.is_none_or(|(_, bd, _)| d < bd) {
                            best = Some((q, d, t as usize));
                        }
                    }
                }
            }
        }
        best
    }
}

/// Where the ray o + t·d meets triangle (a, b, c), edges included (relative margin 10⁻⁹):
/// t, or `None` if it misses or runs parallel. Möller & Trumbore (1997).
pub(crate) fn ray_triangle(o: [f64; 3], d: [f64; 3], [a, b, c]: [[f64; 3]; 3]) -> Option<f64> {
    let (e1, e2) = (sub(b, a), sub(c, a));
    let p = cross(d, e2);
    let det = dot(e1, p);
    if det.abs() <= 1e-300 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = sub(o, a);
    let u = dot(s, p) * inv;
    const EPS: f64 = 1e-9;
    if !(-EPS..=1.0 + EPS).contains(&u) {
        return None;
    }
    let q = cross(s, e1);
    let v = dot(d, q) * inv;
    if v < -EPS || u + v > 1.0 + EPS {
        return None;
    }
    Some(dot(e2, q) * inv)
}

/// Whether segment p→q crosses the interior of triangle (a, b, c), away from its edges and
/// the segment's ends by a relative margin (touching contacts are not intersections).
/// Möller & Trumbore (1997) with the segment parameter limited to (0, 1).
fn segment_crosses_triangle(p: [f64; 3], q: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> bool {
    const EPS: f64 = 1e-9;
    let d = sub(q, p);
    let e1 = sub(b, a);
    let e2 = sub(c, a);
    let h = cross(d, e2);
    let det = dot(e1, h);
    let scale = norm(d) * norm(e1) * norm(e2);
    if det.abs() <= 1e-12 * scale {
        return false; // parallel (coplanar overlaps are not detected)
    }
    let inv = 1.0 / det;
    let s = sub(p, a);
    let u = inv * dot(s, h);
    if u <= EPS || u >= 1.0 - EPS {
        return false;
    }
    let qv = cross(s, e1);
    let v = inv * dot(d, qv);
    if v <= EPS || u + v >= 1.0 - EPS {
        return false;
    }
    let t = inv * dot(e2, qv);
    t > EPS && t < 1.0 - EPS
}

/// Whether two triangles (sharing at most `shared` vertices, given as index pairs) cross.
fn triangles_cross(s: &TriSurface, t1: usize, t2: usize) -> bool {
    let (v1, v2) = (s.triangles[t1], s.triangles[t2]);
    let shared = v1.iter().filter(|v| v2.contains(v)).count();
    if shared >= 2 {
        return false; // neighbours across an edge: a fold is caught by the orientation check
    }
    let (c1, c2) = (s.corners(t1), s.corners(t2));
    for (tv, tc, oc, ov) in [(v1, c1, c2, v2), (v2, c2, c1, v1)] {
        for k in 0..3 {
            let (i, j) = (k, (k + 1) % 3);
            // With a shared vertex, only the edge opposite it can cross the other triangle's
            // interior without the contact at the vertex counting.
            if shared == 1 && (ov.contains(&tv[i]) || ov.contains(&tv[j])) {
                continue;
            }
            if segment_crosses_triangle(tc[i], tc[j], oc[0], oc[1], oc[2]) {
                return true;
            }
        }
    }
    false
}

/// Validates and repairs `s` for voxelisation; see the module docs. Zero-area triangles are
/// dropped (a warning if few), orientation is made consistent and outward (a warning says
/// how many triangles were flipped).
///
/// # Errors
/// [`FemError::Mesh`] with the reason and, where it applies, a position: empty surface, too
/// many triangles, many zero-area triangles, open edges ("the surface is not closed"),
/// non-manifold edges, a non-orientable piece, no enclosed volume, or self-intersection.
pub fn check_surface(s: &mut TriSurface) -> Result<SurfaceReport, FemError> {
    let mut rep = SurfaceReport::default();
    let diag = check_size(s)?;
    let collinear = drop_degenerate(s, diag, &mut rep)?;
    let n = s.triangles.len();
    let edges = edge_uses(s);
    check_closed_and_manifold(s, &edges)?;
    let mut orientation = orient_consistently(s, &edges)?;
    rep.pieces = orientation.pieces;
    let geom = geometric_triangles(n, &collinear);
    let grid = TriGrid::new(s, &geom, 0.0);
    check_self_intersection(s, &grid, &mut rep)?;
    let largest = largest_per_piece(s, &geom, &orientation);
    orient_outward(s, &grid, &largest, diag, &mut orientation);
    rep.flipped = orientation.flip.iter().filter(|&&f| f).count();
    if rep.flipped > 0 {
        rep.warnings
            .push(format!("reversed {} of {n} triangles to make the normals point outward consistently", rep.flipped));
    }
    let bodies = Bodies::of(s, &grid, &largest, &orientation);
    rep.bodies = bodies.count;
    if bodies.count > 1 {
        bodies.keep_largest_body(s, &orientation, &mut rep);
    }
    rep.volume = s.signed_volume();
    if !(rep.volume > 1e-9 * diag * diag * diag) {
        return Err(FemError::Mesh(format!("the surface encloses no volume ({:.3e} m^3); is it flat?", rep.volume)));
    }
    rep.triangles = s.triangles.len();
    Ok(rep)
}

/// Checks that `s` has triangles, not too many, finite vertices and a non-zero size; returns
/// its bounding-box diagonal.
fn check_size(s: &TriSurface) -> Result<f64, FemError> {
    if s.triangles.is_empty() {
        return Err(FemError::Mesh("the surface is empty".into()));
    }
    if s.triangles.len() > MAX_SURFACE_TRIANGLES {
        return Err(FemError::Mesh(format!(
            "{} triangles is more than the {MAX_SURFACE_TRIANGLES} supported; simplify (decimate) the model",
            s.triangles.len()
        )));
    }
    if let Some(p) = s.vertices.iter().find(|p| p.iter().any(|c| !c.is_finite())) {
        return Err(FemError::Mesh(format!("a vertex has a non-finite coordinate {p:?}")));
    }
    let diag = s.diagonal();
    if !(diag > 0.0) {
        return Err(FemError::Mesh("the surface has zero size".into()));
    }
    Ok(diag)
}

/// Drops the triangles with a repeated vertex and counts them and the collinear ones as
/// zero-area (an error if there are many); returns the collinear triangles' new numbers.
fn drop_degenerate(s: &mut TriSurface, diag: f64, rep: &mut SurfaceReport) -> Result<Vec<usize>, FemError> {
    // Zero-area triangles: repeated vertices (they carry no edge) or collinear corners (their
    // edges still close the surface, so they count for topology but not for geometry).
    let area_tol = 1e-14 * diag * diag;
    let total = s.triangles.len();
    let mut degenerate = 0usize;
    let mut tris = Vec::with_capacity(total);
    let mut collinear = Vec::new(); // indices into the kept triangles
    for (i, t) in s.triangles.iter().enumerate() {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            degenerate += 1;
            continue;
        }
        let [a, b, c] = s.corners(i);
        if norm(cross(sub(b, a), sub(c, a))) <= area_tol {
            degenerate += 1;
            collinear.push(tris.len());
        }
        tris.push(*t);
    }
    if degenerate as f64 > MAX_DEGENERATE_FRACTION * total as f64 && degenerate > 10 {
        return Err(FemError::Mesh(format!(
            "{degenerate} of {total} triangles have zero area; repair the mesh (merge close vertices, remove degenerate faces)"
        )));
    }
    s.triangles = tris;
    rep.degenerate_dropped = degenerate;
    if degenerate > 0 {
        rep.warnings.push(format!("dropped {degenerate} zero-area triangle(s) of {total}"));
    }
    Ok(collinear)
}

/// An undirected edge: its lower and higher vertex.
type EdgeKey = (u32, u32);

/// One triangle's use of an undirected edge.
#[derive(Clone, Copy)]
struct EdgeUse {
    /// The triangle.
    tri: u32,
    /// Whether the triangle runs the edge from its lower to its higher vertex.
    ascending: bool,
}

/// Every edge of `s` with the triangles that use it, in triangle order.
fn edge_uses(s: &TriSurface) -> HashMap<EdgeKey, Vec<EdgeUse>> {
    let mut edges: HashMap<EdgeKey, Vec<EdgeUse>> = HashMap::with_capacity(2 * s.triangles.len());
    for (i, t) in s.triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.entry((a.min(b), a.max(b))).or_default().push(EdgeUse { tri: i as u32, ascending: a < b });
        }
    }
    edges
}

/// Checks that every edge is shared by exactly two triangles (closed and manifold).
fn check_closed_and_manifold(s: &TriSurface, edges: &HashMap<EdgeKey, Vec<EdgeUse>>) -> Result<(), FemError> {
    let mut open: Vec<EdgeKey> = edges.iter().filter(|(_, v)| v.len() == 1).map(|(e, _)| *e).collect();
    if !open.is_empty() {
        open.sort_unstable();
        let p = s.vertices[open[0].0 as usize];
        return Err(FemError::Mesh(format!(
            "the surface is not closed: {} open edges (used by one triangle only), one near {}; close the holes (make it watertight) before importing",
            open.len(),
            fmt_p(p)
        )));
    }
    let mut nonman: Vec<EdgeKey> = edges.iter().filter(|(_, v)| v.len() > 2).map(|(e, _)| *e).collect();
    if !nonman.is_empty() {
        nonman.sort_unstable();
        let p = s.vertices[nonman[0].0 as usize];
        return Err(FemError::Mesh(format!(
            "the surface is not manifold: {} edges are shared by more than two triangles, one near {}; separate the touching parts or merge them into one solid",
            nonman.len(),
            fmt_p(p)
        )));
    }
    Ok(())
}

/// The pieces (connected components) of the surface and which triangles were reversed.
struct Orientation {
    /// Whether each triangle's vertex order was reversed.
    flip: Vec<bool>,
    /// Piece of each triangle.
    piece: Vec<u32>,
    /// Number of pieces.
    pieces: usize,
}

/// Orients each piece consistently by breadth-first search (neighbours across an edge must
/// run it in opposite directions) and reverses the triangles that need it.
fn orient_consistently(s: &mut TriSurface, edges: &HashMap<EdgeKey, Vec<EdgeUse>>) -> Result<Orientation, FemError> {
    let n = s.triangles.len();
    let mut flip = vec![false; n];
    let mut piece = vec![u32::MAX; n];
    let mut pieces = 0u32;
    let mut queue = Vec::new();
    for seed in 0..n {
        if piece[seed] != u32::MAX {
            continue;
        }
        piece[seed] = pieces;
        queue.clear();
        queue.push(seed);
        while let Some(t) = queue.pop() {
            let tv = s.triangles[t];
            for k in 0..3 {
                let (a, b) = (tv[k], tv[(k + 1) % 3]);
                let fwd_t = (a < b) != flip[t];
                for &EdgeUse { tri: o, ascending: fwd_o } in &edges[&(a.min(b), a.max(b))] {
                    let o = o as usize;
                    if o == t {
                        continue;
                    }
                    // Consistent when the two run the edge in opposite directions.
                    let want_flip = fwd_o == fwd_t;
                    if piece[o] == u32::MAX {
                        piece[o] = pieces;
                        flip[o] = want_flip;
                        queue.push(o);
                    } else if flip[o] != want_flip {
                        return Err(FemError::Mesh(format!(
                            "the surface cannot be oriented consistently (a non-orientable piece, like a Moebius strip, near {}); repair the model",
                            fmt_p(s.vertices[a as usize])
                        )));
                    }
                }
            }
        }
        pieces += 1;
    }
    for (t, f) in s.triangles.iter_mut().zip(&flip) {
        if *f {
            t.swap(1, 2);
        }
    }
    Ok(Orientation { flip, piece, pieces: pieces as usize })
}

/// The triangles that carry geometry: all `n` but the collinear ones.
fn geometric_triangles(n: usize, collinear: &[usize]) -> Vec<u32> {
    let mut is_collinear = vec![false; n];
    for &t in collinear {
        is_collinear[t] = true;
    }
    (0..n as u32).filter(|&t| !is_collinear[t as usize]).collect()
}

/// An axis-aligned bounding box.
struct Aabb {
    /// Lowest corner.
    lo: [f64; 3],
    /// Highest corner.
    hi: [f64; 3],
}

/// What the self-intersection check found.
struct Crossings {
    /// Crossing triangle pairs.
    pairs: usize,
    /// A corner of the first triangle found crossing another.
    first: Option<[f64; 3]>,
    /// Whether the check ran to the end (within [`SELF_INTERSECTION_BUDGET`]).
    complete: bool,
}

/// Checks that the surface does not intersect itself (a warning if the check ran out of
/// time).
fn check_self_intersection(s: &TriSurface, grid: &TriGrid, rep: &mut SurfaceReport) -> Result<(), FemError> {
    let found = find_crossings(s, grid);
    rep.intersection_check_complete = found.complete;
    if !found.complete {
        rep.warnings.push(format!(
            "the self-intersection check stopped after {:.0} s; the surface was not fully checked",
            SELF_INTERSECTION_BUDGET.as_secs_f64()
        ));
    }
    if let Some(p) = found.first {
        return Err(FemError::Mesh(format!(
            "the surface intersects itself ({} crossing triangle pairs, one near {}); repair it (e.g. a boolean union of the overlapping parts)",
            found.pairs,
            fmt_p(p)
        )));
    }
    Ok(())
}

/// Crossing triangle pairs: broad phase on the grid, then triangle pairs. Each pair is tested
/// in one cell only: the one holding the low corner of the overlap of their boxes.
fn find_crossings(s: &TriSurface, grid: &TriGrid) -> Crossings {
    let t0 = Instant::now();
    let mut found = Crossings { pairs: 0, first: None, complete: false };
    let boxes: Vec<Aabb> = (0..s.triangles.len())
        .map(|t| {
            let c = s.corners(t);
            Aabb {
                lo: std::array::from_fn(|i| c[0][i].min(c[1][i]).min(c[2][i])),
                hi: std::array::from_fn(|i| c[0][i].max(c[1][i]).max(c[2][i])),
            }
        })
        .collect();
    for z in 0..grid.dims[2] {
        for y in 0..grid.dims[1] {
            if t0.elapsed() > SELF_INTERSECTION_BUDGET {
                return found;
            }
            for x in 0..grid.dims[0] {
                let list = grid.cell(x, y, z);
                for (ia, &ta) in list.iter().enumerate() {
                    // Checked per triangle too: one crowded cell can hold many pairs.
                    if ia % 64 == 63 && t0.elapsed() > SELF_INTERSECTION_BUDGET {
                        return found;
                    }
                    for &tb in &list[ia + 1..] {
                        let (a, b) = (&boxes[ta as usize], &boxes[tb as usize]);
                        let lo: [f64; 3] = std::array::from_fn(|i| a.lo[i].max(b.lo[i]));
                        if (0..3).any(|i| lo[i] > a.hi[i].min(b.hi[i])) {
                            continue;
                        }
                        if TriGrid::cell_of(grid.lo, grid.h, grid.dims, lo) != [x, y, z] {
                            continue;
                        }
                        if triangles_cross(s, ta as usize, tb as usize) {
                            found.pairs += 1;
                            if found.first.is_none() {
                                found.first = Some(s.corners(ta as usize)[0]);
                            }
                        }
                    }
                }
            }
        }
    }
    found.complete = true;
    found
}

/// The largest (geometric) triangle of a piece, which gives the most reliable probe.
#[derive(Clone, Copy)]
struct Largest {
    /// Its area (twice, as the cross product's norm).
    area: f64,
    /// The triangle.
    tri: u32,
}

/// Makes each piece's normals point out of the solid. A piece inside another (a cavity)
/// points into the cavity, so decide by parity: a point just off a triangle along its normal
/// must be outside. Reversed triangles are recorded in `orientation.flip`.
fn orient_outward(
    s: &mut TriSurface,
    grid: &TriGrid,
    largest: &[Option<Largest>],
    diag: f64,
    orientation: &mut Orientation,
) {
    let piece_flip: Vec<bool> =
        largest.iter().map(|b| b.is_some_and(|l| points_inward(s, grid, l.tri as usize, diag))).collect();
    for (i, t) in s.triangles.iter_mut().enumerate() {
        if piece_flip[orientation.piece[i] as usize] {
            t.swap(1, 2);
            orientation.flip[i] = !orientation.flip[i];
        }
    }
}

/// The largest geometric triangle of each piece (`None` for a piece of collinear triangles
/// only).
fn largest_per_piece(s: &TriSurface, geom: &[u32], orientation: &Orientation) -> Vec<Option<Largest>> {
    let mut best: Vec<Option<Largest>> = vec![None; orientation.pieces];
    for &t in geom {
        let [x, y, z] = s.corners(t as usize);
        let area = norm(cross(sub(y, x), sub(z, x)));
        let b = &mut best[orientation.piece[t as usize] as usize];
        if b.is_none_or(|l| area > l.area) {
            *b = Some(Largest { area, tri: t });
        }
    }
    best
}

/// The bodies of a surface of several pieces: which body each piece bounds (an outer wall is
/// its own body; a cavity's wall belongs to the smallest outer wall around it) and each
/// body's volume.
struct Bodies {
    /// Number of bodies (outer walls).
    count: usize,
    /// Body (its outer wall's piece) of each piece.
    body_of: Vec<usize>,
    /// Signed volume each piece encloses (a cavity's is negative), m³.
    volume: Vec<f64>,
}

impl Bodies {
    fn of(s: &TriSurface, grid: &TriGrid, largest: &[Option<Largest>], orientation: &Orientation) -> Bodies {
        let pieces = orientation.pieces;
        let mut volume = vec![0.0; pieces];
        for t in 0..s.triangles.len() {
            let [a, b, c] = s.corners(t);
            volume[orientation.piece[t] as usize] += dot(a, cross(b, c)) / 6.0;
        }
        let probe = |p: usize| {
            largest[p].map(|l| {
                let [a, b, c] = s.corners(l.tri as usize);
                [(a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0, (a[2] + b[2] + c[2]) / 3.0]
            })
        };
        // Inside `o` alone (parity of `o`'s triangles), or inside the pieces other than `p`.
        let inside_piece = |x: [f64; 3], o: usize| {
            inside_by_rays_of(s, grid, x, &|t| orientation.piece[t as usize] as usize == o) == Some(true)
        };
        let outer: Vec<bool> = (0..pieces)
            .map(|p| {
                // A piece whose probe gives no clean answer counts as a body of its own (then
                // it is only dropped if it lies apart, see `keep_largest_body`).
                pieces == 1
                    || probe(p).is_none_or(|x| {
                        inside_by_rays_of(s, grid, x, &|t| orientation.piece[t as usize] as usize != p) != Some(true)
                    })
            })
            .collect();
        let body_of = (0..pieces)
            .map(|p| {
                if outer[p] {
                    return p;
                }
                let x = probe(p);
                (0..pieces)
                    .filter(|&o| outer[o] && x.is_some_and(|x| inside_piece(x, o)))
                    .min_by(|&a, &b| volume[a].abs().total_cmp(&volume[b].abs()))
                    .unwrap_or(p)
            })
            .collect();
        Bodies { count: outer.iter().filter(|&&o| o).count(), body_of, volume }
    }

    /// Keeps the triangles of the body with the largest volume and drops the others, saying
    /// so in `rep.warnings`.
    fn keep_largest_body(&self, s: &mut TriSurface, orientation: &Orientation, rep: &mut SurfaceReport) {
        let mut body_volume = vec![0.0; self.volume.len()];
        for (p, &b) in self.body_of.iter().enumerate() {
            body_volume[b] += self.volume[p];
        }
        let Some(keep) = (0..body_volume.len()).max_by(|&a, &b| body_volume[a].total_cmp(&body_volume[b])) else {
            return;
        };
        let total: f64 = body_volume.iter().sum();
        // Bodies whose bounding boxes touch or overlap (shells sharing a face, interlocked
        // parts) are kept together, as before: the voxeliser joins what touches.
        let mut boxes = vec![([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]); self.volume.len()];
        for t in 0..s.triangles.len() {
            let b = &mut boxes[self.body_of[orientation.piece[t] as usize]];
            for v in s.corners(t) {
                for a in 0..3 {
                    b.0[a] = b.0[a].min(v[a]);
                    b.1[a] = b.1[a].max(v[a]);
                }
            }
        }
        let bodies: Vec<usize> = (0..boxes.len()).filter(|&b| boxes[b].0[0].is_finite()).collect();
        let apart = |a: usize, b: usize| (0..3).any(|k| boxes[a].1[k] < boxes[b].0[k] || boxes[b].1[k] < boxes[a].0[k]);
        if bodies.iter().any(|&a| bodies.iter().any(|&b| a < b && !apart(a, b))) {
            rep.warnings.push(format!(
                "the surface has {} closed shells not inside one another whose boxes touch or overlap: kept together as one object (if they are separate bodies, export each to its own file)",
                self.count
            ));
            return;
        }
        let mut t = 0;
        s.triangles.retain(|_| {
            let kept = self.body_of[orientation.piece[t] as usize] == keep;
            t += 1;
            kept
        });
        // Drop the other bodies' vertices too (they would widen the bounding box).
        s.merge_vertices(0.0);
        rep.warnings.push(format!(
            "the surface is {} separate bodies (closed shells not inside one another): kept the largest ({:.4e} m^3) and dropped {} ({:.4e} m^3); a bank is one connected object, so export each body to its own file to use it",
            self.count,
            body_volume[keep],
            self.count - 1,
            total - body_volume[keep]
        ));
    }
}

/// Whether a point 10⁻⁶·`diag` off triangle `t`'s centroid along its normal is inside.
fn points_inward(s: &TriSurface, grid: &TriGrid, t: usize, diag: f64) -> bool {
    let [a, b, c] = s.corners(t);
    let nrm = s.normal(t);
    let ctr = [(a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0, (a[2] + b[2] + c[2]) / 3.0];
    let eps = 1e-6 * diag;
    let probe = [ctr[0] + eps * nrm[0], ctr[1] + eps * nrm[1], ctr[2] + eps * nrm[2]];
    inside_by_rays(s, grid, probe) == Some(true)
}

/// Whether `p` is inside the closed surface, by the parity of crossings along rays in the
/// three axis directions (slightly jittered), by majority; `None` if no ray gave a clean
/// answer.
fn inside_by_rays(s: &TriSurface, grid: &TriGrid, p: [f64; 3]) -> Option<bool> {
    inside_by_rays_of(s, grid, p, &|_| true)
}

/// [`inside_by_rays`] counting only the triangles `keep` accepts.
fn inside_by_rays_of(s: &TriSurface, grid: &TriGrid, p: [f64; 3], keep: &dyn Fn(u32) -> bool) -> Option<bool> {
    let mut votes = [0usize; 2];
    let mut cand: Vec<u32> = Vec::new();
    let c = TriGrid::cell_of(grid.lo, grid.h, grid.dims, p);
    for axis in 0..3 {
        // Triangles in the cells the ray passes (its own cell and beyond along +axis).
        cand.clear();
        let mut cell = c;
        for k in c[axis]..grid.dims[axis] {
            cell[axis] = k;
            cand.extend_from_slice(grid.cell(cell[0], cell[1], cell[2]));
        }
        cand.sort_unstable();
        cand.dedup();
        cand.retain(|&t| keep(t));
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for attempt in 0..4 {
            // Jitter well inside the cell, so the ray stays in the cells gathered above.
            let j = jitter(attempt + 4 * axis);
            let q = [p[u] + j.0 * 1e-6 * grid.h, p[v] + j.1 * 1e-6 * grid.h];
            if let Some(k) = crossings(s, &cand, axis, q, p[axis]) {
                votes[k % 2] += 1;
                break;
            }
        }
    }
    if votes[0] + votes[1] == 0 {
        None
    } else {
        Some(votes[1] > votes[0])
    }
}

/// Deterministic jitter pair in [−0.5, 0.5)² for attempt `k` (a low-discrepancy sequence).
pub(crate) fn jitter(k: usize) -> (f64, f64) {
    let a = ((k as f64 + 1.0) * 0.754_877_666_246_692_8).fract() - 0.5;
    let b = ((k as f64 + 1.0) * 0.569_840_290_998_053_3).fract() - 0.5;
    (a, b)
}

/// Crossings of the ray from (q in the plane ⟂ `axis`, `from` along it) towards +axis with
/// the triangles; `None` if the ray passes too close to an edge or vertex to be sure.
fn crossings(s: &TriSurface, tris: &[u32], axis: usize, q: [f64; 2], from: f64) -> Option<usize> {
    let mut k = 0;
    for &t in tris {
        match ray_hit(s, t as usize, axis, q) {
            RayHit::Miss => {}
            RayHit::Ambiguous => return None,
            RayHit::At(z) => {
                if z > from {
                    k += 1
                }
            }
        }
    }
    Some(k)
}

pub(crate) enum RayHit {
    Miss,
    Ambiguous,
    At(f64),
}

/// Where the line through q (coordinates on the two axes other than `axis`) parallel to
/// `axis` meets triangle `t`: by 2-D edge functions of the projected triangle.
pub(crate) fn ray_hit(s: &TriSurface, t: usize, axis: usize, q: [f64; 2]) -> RayHit {
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let [a, b, c] = s.corners(t);
    let pa = [a[u] - q[0], a[v] - q[1]];
    let pb = [b[u] - q[0], b[v] - q[1]];
    let pc = [c[u] - q[0], c[v] - q[1]];
    // Quick reject on the projected box.
    if (pa[0] > 0.0 && pb[0] > 0.0 && pc[0] > 0.0)
        || (pa[0] < 0.0 && pb[0] < 0.0 && pc[0] < 0.0)
        || (pa[1] > 0.0 && pb[1] > 0.0 && pc[1] > 0.0)
        || (pa[1] < 0.0 && pb[1] < 0.0 && pc[1] < 0.0)
    {
        return RayHit::Miss;
    }
    let e0 = pb[0] * pc[1] - pb[1] * pc[0];
    let e1 = pc[0] * pa[1] - pc[1] * pa[0];
    let e2 = pa[0] * pb[1] - pa[1] * pb[0];
    let area = e0 + e1 + e2;
    let scale = (pa[0].abs() + pb[0].abs() + pc[0].abs()) * (pa[1].abs() + pb[1].abs() + pc[1].abs());
    let tol = 1e-12 * scale;
    if area.abs() <= tol {
        // Seen edge-on; a ray through it is ambiguous only if it touches the segment.
        return if e0.abs() <= tol && e1.abs() <= tol && e2.abs() <= tol { RayHit::Ambiguous } else { RayHit::Miss };
    }
    // Inside iff every edge function has the sign of the area.
    let sg = area.signum();
    let (f0, f1, f2) = (e0 * sg, e1 * sg, e2 * sg);
    if f0 < -tol || f1 < -tol || f2 < -tol {
        RayHit::Miss
    } else if f0 > tol && f1 > tol && f2 > tol {
        RayHit::At((e0 * a[axis] + e1 * b[axis] + e2 * c[axis]) / area)
    } else {
        RayHit::Ambiguous
    }
}
