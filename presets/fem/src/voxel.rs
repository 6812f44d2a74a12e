//! Closed surfaces to 10-node tetrahedra by voxelisation (no external mesher).
//!
//! 1. A grid of cubes of side h = (longest bounding-box side) / `resolution`, centred on the
//!    surface's bounding box.
//! 2. A cube is inside when its centre is: parity of the crossings of a ray along +z through
//!    the cube centres of each (x, y) column (a scanline voxeliser). The ray is jittered by
//!    10⁻³·h and re-cast (up to [`MAX_RAY_ATTEMPTS`] times) when it passes within rounding
//!    distance of an edge or vertex or crosses the surface an odd number of times, so shared
//!    edges are never counted twice or missed.
//! 3. Only the largest face-connected set of cubes is kept (a warning says what was dropped).
//! 4. Each cube is split into five tetrahedra, the pattern mirrored on alternate cubes by the
//!    parity of i + j + k so the face diagonals of neighbours coincide (a conforming mesh):
//!    every face diagonal joins the two lattice vertices whose i + j + k is even.
//! 5. Optionally (on by default) the vertices on the boundary of the cube set are moved to
//!    the closest point of the input surface (within h), which removes most of the staircase.
//!    A move is kept only if every tetrahedron touching the vertex keeps at least
//!    [`MIN_VOLUME_RATIO`] of its volume with its orientation (so every element's Jacobian stays
//!    positive; the elements stay straight-sided, so the Jacobian is constant per element).
//!    The vertices of offending elements go back halfway (1 → ½ → ¼ → 0 of the move), in at
//!    most [`MAX_SNAP_ROUNDS`] rounds, after which all moves are undone and the staircase is
//!    kept (with a warning).
//! 6. The linear tetrahedra become 10-node tetrahedra with straight edges
//!    ([`TetMesh::from_linear`]).

use std::collections::HashSet;

use super::geom::{cross, dot, signed_volume, sub};
use super::import::MAX_IMPORT_VERTICES;
use super::mesh::TetMesh;
use super::surface::{ray_hit, RayHit, TriGrid, TriSurface};
use super::FemError;

/// Corner vertices aimed at by [`auto_resolution`]: about 60 000 DOFs, a build of the order
/// of a minute for a few tens of modes on a laptop.
pub const DEFAULT_VERTEX_BUDGET: usize = 3_000;
/// Range of resolutions [`auto_resolution`] picks from.
pub const AUTO_RESOLUTION_RANGE: (usize, usize) = (8, 400);
/// Most grid cells (inside or not) examined; bounds time and memory of the inside test.
pub const MAX_VOXEL_CELLS: usize = 4_000_000;
/// Most (column, triangle) pairs examined by the inside test.
pub const MAX_COLUMN_ENTRIES: usize = 100_000_000;
/// Re-casts of a column's ray before the column is given up (left empty, with a warning).
pub const MAX_RAY_ATTEMPTS: usize = 8;
/// Least fraction of its volume a tetrahedron may keep when boundary vertices are moved.
pub const MIN_VOLUME_RATIO: f64 = 0.05;
/// Largest relative difference between the mesh's and the surface's volume before the
/// voxelisation is refused (above 5 % it is a warning).
pub const MAX_VOLUME_ERROR: f64 = 0.5;
/// Rounds of undoing offending vertex moves before all moves are undone.
pub const MAX_SNAP_ROUNDS: usize = 20;

/// How to voxelise.
#[derive(Clone, Debug, PartialEq)]
pub struct VoxelOptions {
    /// Cubes along the longest side of the bounding box (≥ 2).
    pub resolution: usize,
    /// Move boundary vertices onto the input surface (see the module docs).
    pub snap: bool,
}

/// The highest resolution whose estimated vertex count, (nx + 1)(ny + 1)(nz + 1) times the
/// fraction of the bounding box the surface fills, stays within `budget`; clamped to
/// [`AUTO_RESOLUTION_RANGE`]. Chunky objects get ~15–20 voxels along their longest side,
/// slender ones more (so that they are several voxels thick).
pub fn auto_resolution(s: &TriSurface, budget: usize) -> usize {
    let (lo, hi) = s.bounds();
    let ext = sub(hi, lo);
    let longest = ext[0].max(ext[1]).max(ext[2]);
    if !(longest > 0.0) {
        return AUTO_RESOLUTION_RANGE.0;
    }
    let fill = (s.signed_volume().abs() / ext.iter().map(|e| e.max(1e-12 * longest)).product::<f64>()).clamp(1e-3, 1.0);
    let estimate = |r: usize| -> f64 {
        fill * ext.iter().map(|e| ((r as f64 * e / longest).ceil().max(1.0)) + 1.0).product::<f64>()
    };
    let (lo_r, hi_r) = AUTO_RESOLUTION_RANGE;
    (lo_r..=hi_r).take_while(|&r| estimate(r) <= budget as f64).last().unwrap_or(lo_r)
}

/// What [`voxelise`] did.
#[derive(Clone, Debug, Default)]
pub struct VoxelReport {
    /// Grid cells along x, y, z.
    pub dims: [usize; 3],
    /// Cube side, m.
    pub h: f64,
    /// Cubes kept.
    pub voxels: usize,
    /// Inside cubes dropped because they were not face-connected to the largest piece.
    pub dropped_voxels: usize,
    /// Pieces dropped.
    pub dropped_pieces: usize,
    /// Columns whose ray could not be cast cleanly (left empty).
    pub bad_columns: usize,
    /// Boundary vertices moved onto the surface: fully, part of the way (a half or a
    /// quarter, to keep the elements' shape), and not at all.
    pub snapped: usize,
    /// … part of the way.
    pub snap_partial: usize,
    /// … not at all.
    pub snap_undone: usize,
    /// Volume enclosed by the input surface, m³.
    pub surface_volume: f64,
    /// Volume of the tetrahedral mesh, m³.
    pub mesh_volume: f64,
    /// Human-readable warnings.
    pub warnings: Vec<String>,
}

/// Cube corner offsets, indexed by a·1 + b·2 + c·4 for offset (a, b, c).
const fn corner(a: usize, b: usize, c: usize) -> usize {
    a + 2 * b + 4 * c
}

/// Five tetrahedra of a cube whose origin has even i + j + k: the central one on the even
/// corners and one at each odd corner.
const EVEN_TETS: [[usize; 4]; 5] = [
    [corner(0, 0, 0), corner(1, 1, 0), corner(1, 0, 1), corner(0, 1, 1)],
    [corner(1, 0, 0), corner(0, 0, 0), corner(1, 1, 0), corner(1, 0, 1)],
    [corner(0, 1, 0), corner(0, 0, 0), corner(1, 1, 0), corner(0, 1, 1)],
    [corner(0, 0, 1), corner(0, 0, 0), corner(1, 0, 1), corner(0, 1, 1)],
    [corner(1, 1, 1), corner(1, 1, 0), corner(1, 0, 1), corner(0, 1, 1)],
];
/// The mirror pattern for odd cubes: central tetrahedron on the odd corners.
const ODD_TETS: [[usize; 4]; 5] = [
    [corner(1, 0, 0), corner(0, 1, 0), corner(0, 0, 1), corner(1, 1, 1)],
    [corner(0, 0, 0), corner(1, 0, 0), corner(0, 1, 0), corner(0, 0, 1)],
    [corner(1, 1, 0), corner(1, 0, 0), corner(0, 1, 0), corner(1, 1, 1)],
    [corner(1, 0, 1), corner(1, 0, 0), corner(0, 0, 1), corner(1, 1, 1)],
    [corner(0, 1, 1), corner(0, 1, 0), corner(0, 0, 1), corner(1, 1, 1)],
];

/// Voxelises the closed, outward-oriented surface `s` (as left by
/// [`super::surface::check_surface`]) into a 10-node tetrahedral mesh; see the module docs.
/// `progress(stage, fraction)` is called with `"voxelise"` and `"snap"`.
///
/// # Errors
/// [`FemError::InvalidOptions`] for a resolution < 2 or a grid over [`MAX_VOXEL_CELLS`]
/// cells; [`FemError::Mesh`] if no cube is inside (the object is thinner than a cube) or the
/// mesh would have more than [`MAX_IMPORT_VERTICES`] vertices (both say which resolution to
/// use instead).
pub fn voxelise(
    s: &TriSurface,
    opts: &VoxelOptions,
    progress: &dyn Fn(&str, f32),
) -> Result<(TetMesh, VoxelReport), FemError> {
    let mut rep = VoxelReport::default();
    if opts.resolution < 2 {
        return Err(FemError::InvalidOptions(format!(
            "resolution {} is too coarse; use at least 2 voxels along the longest side",
            opts.resolution
        )));
    }
    let (lo, hi) = s.bounds();
    let ext = sub(hi, lo);
    let longest = ext[0].max(ext[1]).max(ext[2]);
    if !(longest > 0.0 && longest.is_finite()) {
        return Err(FemError::Mesh("the surface has zero or non-finite size".into()));
    }
    let h = longest / opts.resolution as f64;
    let dims: [usize; 3] = std::array::from_fn(|i| ((ext[i] / h - 1e-6).ceil() as usize).max(1));
    let cells = dims[0].saturating_mul(dims[1]).saturating_mul(dims[2]);
    if cells > MAX_VOXEL_CELLS {
        return Err(FemError::InvalidOptions(format!(
            "resolution {} gives a grid of {} x {} x {} = {cells} cells, over the limit of {MAX_VOXEL_CELLS}; use a lower resolution",
            opts.resolution, dims[0], dims[1], dims[2]
        )));
    }
    let origin: [f64; 3] = std::array::from_fn(|i| 0.5 * (lo[i] + hi[i]) - 0.5 * dims[i] as f64 * h);
    rep.dims = dims;
    rep.h = h;
    rep.surface_volume = s.signed_volume();
    let area_tol = 1e-14 * s.diagonal().powi(2);
    let tris: Vec<u32> = (0..s.triangles.len() as u32)
        .filter(|&t| {
            let [a, b, c] = s.corners(t as usize);
            dot(cross(sub(b, a), sub(c, a)), cross(sub(b, a), sub(c, a))).sqrt() > area_tol
        })
        .collect();

    // Columns: which triangles' xy boxes (widened by the jitter) reach each column centre.
    progress("voxelise", 0.0);
    let (nx, ny, nz) = (dims[0], dims[1], dims[2]);
    let col_range = |mn: f64, mx: f64, o: f64, n: usize| -> Option<(usize, usize)> {
        let a = ((mn - 0.01 * h - o) / h - 0.5).ceil().max(0.0);
        let b = ((mx + 0.01 * h - o) / h - 0.5).floor().min(n as f64 - 1.0);
        (a <= b).then_some((a as usize, b as usize))
    };
    let mut start = vec![0u32; nx * ny + 1];
    let mut ranges = Vec::with_capacity(tris.len());
    for &t in &tris {
        let c = s.corners(t as usize);
        let r = col_range(c[0][0].min(c[1][0]).min(c[2][0]), c[0][0].max(c[1][0]).max(c[2][0]), origin[0], nx)
            .zip(col_range(c[0][1].min(c[1][1]).min(c[2][1]), c[0][1].max(c[1][1]).max(c[2][1]), origin[1], ny));
        if let Some(((x0, x1), (y0, y1))) = r {
            for y in y0..=y1 {
                for x in x0..=x1 {
                    start[y * nx + x + 1] += 1;
                }
            }
        }
        ranges.push(r);
    }
    for c in 0..nx * ny {
        start[c + 1] = start[c].saturating_add(start[c + 1]);
    }
    if start[nx * ny] as usize >= MAX_COLUMN_ENTRIES {
        return Err(FemError::Mesh(format!(
            "the surface's triangles cover too many voxel columns ({} or more pairs); use a lower resolution or a simpler surface",
            MAX_COLUMN_ENTRIES
        )));
    }
    let mut items = vec![0u32; start[nx * ny] as usize];
    let mut fill = start.clone();
    for (&t, r) in tris.iter().zip(&ranges) {
        if let Some(((x0, x1), (y0, y1))) = *r {
            for y in y0..=y1 {
                for x in x0..=x1 {
                    items[fill[y * nx + x] as usize] = t;
                    fill[y * nx + x] += 1;
                }
            }
        }
    }
    drop(ranges);
    drop(fill);
    let idx = |x: usize, y: usize, z: usize| (z * ny + y) * nx + x;
    let mut inside = vec![false; cells];
    let mut hits: Vec<f64> = Vec::new();
    for y in 0..ny {
        progress("voxelise", y as f32 / ny as f32);
        for x in 0..nx {
            let list = &items[start[y * nx + x] as usize..start[y * nx + x + 1] as usize];
            if list.is_empty() {
                continue;
            }
            let mut ok = false;
            for attempt in 0..MAX_RAY_ATTEMPTS {
                let j = super::surface::jitter(attempt);
                let q = [origin[0] + (x as f64 + 0.5 + 1e-3 * j.0) * h, origin[1] + (y as f64 + 0.5 + 1e-3 * j.1) * h];
                hits.clear();
                let mut clean = true;
                for &t in list {
                    match ray_hit(s, t as usize, 2, q) {
                        RayHit::Miss => {}
                        RayHit::At(z) => hits.push(z),
                        RayHit::Ambiguous => {
                            clean = false;
                            break;
                        }
                    }
                }
                if clean && hits.len() % 2 == 0 {
                    ok = true;
                    break;
                }
            }
            if !ok {
                rep.bad_columns += 1;
                continue;
            }
            hits.sort_by(f64::total_cmp);
            // Parity: a centre is inside when an odd number of crossings lie below it.
            let mut below = 0;
            for z in 0..nz {
                let zc = origin[2] + (z as f64 + 0.5) * h;
                while below < hits.len() && hits[below] < zc {
                    below += 1;
                }
                inside[idx(x, y, z)] = below % 2 == 1;
            }
        }
    }
    drop(items);
    drop(start);
    if rep.bad_columns > 0 {
        rep.warnings.push(format!(
            "{} of {} voxel columns could not be classified (rays kept grazing edges) and were left empty",
            rep.bad_columns,
            nx * ny
        ));
    }

    // Largest face-connected piece.
    let mut label = vec![u32::MAX; cells];
    let mut sizes: Vec<usize> = Vec::new();
    let mut stack = Vec::new();
    for c0 in 0..cells {
        if !inside[c0] || label[c0] != u32::MAX {
            continue;
        }
        let id = sizes.len() as u32;
        label[c0] = id;
        stack.push(c0);
        let mut size = 0;
        while let Some(c) = stack.pop() {
            size += 1;
            let (x, y, z) = (c % nx, (c / nx) % ny, c / (nx * ny));
            let mut visit = |nb: usize| {
                if inside[nb] && label[nb] == u32::MAX {
                    label[nb] = id;
                    stack.push(nb);
                }
            };
            if x > 0 {
                visit(c - 1);
            }
            if x + 1 < nx {
                visit(c + 1);
            }
            if y > 0 {
                visit(c - nx);
            }
            if y + 1 < ny {
                visit(c + nx);
            }
            if z > 0 {
                visit(c - nx * ny);
            }
            if z + 1 < nz {
                visit(c + nx * ny);
            }
        }
        sizes.push(size);
    }
    let Some((keep, &kept)) = sizes.iter().enumerate().max_by_key(|&(i, &n)| (n, std::cmp::Reverse(i))) else {
        return Err(FemError::Mesh(format!(
            "no voxel centre is inside the surface at resolution {} (voxel size {:.3e} m); the object is thinner than a voxel: raise the resolution",
            opts.resolution, h
        )));
    };
    let keep = keep as u32;
    rep.voxels = kept;
    rep.dropped_pieces = sizes.len() - 1;
    rep.dropped_voxels = sizes.iter().sum::<usize>() - kept;
    if rep.dropped_pieces > 0 {
        rep.warnings.push(format!(
            "kept the largest connected piece ({kept} voxels); dropped {} voxels in {} smaller piece(s) not joined to it by a voxel face (parts thinner than a voxel, or separate bodies)",
            rep.dropped_voxels, rep.dropped_pieces
        ));
    }
    let kept_cell = |x: usize, y: usize, z: usize| label[idx(x, y, z)] == keep;

    // Lattice vertices of kept cubes.
    let (vx, vy) = (nx + 1, ny + 1);
    let vid = |x: usize, y: usize, z: usize| (z * vy + y) * vx + x;
    let mut vmap = vec![u32::MAX; vx * vy * (nz + 1)];
    let mut nodes: Vec<[f64; 3]> = Vec::new();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                if !kept_cell(x, y, z) {
                    continue;
                }
                for c in 0..8 {
                    let (a, b, cc) = (x + (c & 1), y + ((c >> 1) & 1), z + (c >> 2));
                    let v = vid(a, b, cc);
                    if vmap[v] == u32::MAX {
                        vmap[v] = nodes.len() as u32;
                        nodes.push([origin[0] + a as f64 * h, origin[1] + b as f64 * h, origin[2] + cc as f64 * h]);
                    }
                }
            }
        }
    }
    if nodes.len() > MAX_IMPORT_VERTICES {
        let suggest = ((opts.resolution as f64) * (MAX_IMPORT_VERTICES as f64 / nodes.len() as f64).cbrt() * 0.95)
            .floor() as usize;
        return Err(FemError::Mesh(format!(
            "resolution {} gives {} vertices, over the limit of {MAX_IMPORT_VERTICES}; use a resolution of about {} or less",
            opts.resolution,
            nodes.len(),
            suggest.max(2)
        )));
    }
    let mut tets: Vec<[u32; 4]> = Vec::with_capacity(5 * kept);
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                if !kept_cell(x, y, z) {
                    continue;
                }
                let pattern = if (x + y + z) % 2 == 0 { &EVEN_TETS } else { &ODD_TETS };
                for t in pattern {
                    tets.push(t.map(|c| vmap[vid(x + (c & 1), y + ((c >> 1) & 1), z + (c >> 2))]));
                }
            }
        }
    }

    if opts.snap {
        progress("snap", 0.0);
        // Boundary vertices: corners of cube faces that have no kept neighbour.
        let mut boundary: HashSet<u32> = HashSet::new();
        let face_corners = |axis: usize, x: usize, y: usize, z: usize, side: usize| -> [u32; 4] {
            let mut out = [0u32; 4];
            let mut k = 0;
            for c in 0..8 {
                let off = [c & 1, (c >> 1) & 1, c >> 2];
                if off[axis] == side {
                    out[k] = vmap[vid(x + off[0], y + off[1], z + off[2])];
                    k += 1;
                }
            }
            out
        };
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    if !kept_cell(x, y, z) {
                        continue;
                    }
                    let p = [x, y, z];
                    for axis in 0..3 {
                        for side in 0..2 {
                            let mut q = p;
                            let open = if side == 0 {
                                p[axis] == 0 || {
                                    q[axis] -= 1;
                                    !kept_cell(q[0], q[1], q[2])
                                }
                            } else {
                                p[axis] + 1 == dims[axis] || {
                                    q[axis] += 1;
                                    !kept_cell(q[0], q[1], q[2])
                                }
                            };
                            if open {
                                boundary.extend(face_corners(axis, x, y, z, side));
                            }
                        }
                    }
                }
            }
        }
        let mut bverts: Vec<u32> = boundary.into_iter().collect();
        bverts.sort_unstable();
        let grid = TriGrid::new(s, &tris, 0.5 * h);
        let orig = nodes.clone();
        // Each boundary vertex moves a fraction (1, 1/2, 1/4 or 0) of the way to its target.
        let mut target: Vec<Option<[f64; 3]>> = vec![None; nodes.len()];
        let mut frac = vec![0.0f64; nodes.len()];
        for (k, &v) in bverts.iter().enumerate() {
            if k % 256 == 0 {
                progress("snap", 0.5 * k as f32 / bverts.len().max(1) as f32);
            }
            if let Some((q, _, _)) = grid.closest(s, nodes[v as usize], h) {
                target[v as usize] = Some(q);
                frac[v as usize] = 1.0;
            }
        }
        let place = |nodes: &mut Vec<[f64; 3]>, v: usize, f: f64| {
            if let Some(q) = target[v] {
                let o = orig[v];
                nodes[v] = [o[0] + f * (q[0] - o[0]), o[1] + f * (q[1] - o[1]), o[2] + f * (q[2] - o[2])];
            }
        };
        for v in 0..nodes.len() {
            place(&mut nodes, v, frac[v]);
        }
        let vol0: Vec<f64> = tets.iter().map(|t| signed_volume(&orig, t)).collect();
        let mut settled = false;
        for _round in 0..MAX_SNAP_ROUNDS {
            let mut bad = Vec::new();
            for (e, t) in tets.iter().enumerate() {
                if t.iter().any(|&v| frac[v as usize] > 0.0) {
                    let v = signed_volume(&nodes, t);
                    if !(v * vol0[e].signum() >= MIN_VOLUME_RATIO * vol0[e].abs()) {
                        bad.push(e);
                    }
                }
            }
            if bad.is_empty() {
                settled = true;
                break;
            }
            // Halve the moves of the offending elements' vertices (to zero after a quarter).
            let mut touched = HashSet::new();
            for e in bad {
                touched.extend(tets[e].iter().copied().filter(|&v| frac[v as usize] > 0.0));
            }
            for v in touched {
                let v = v as usize;
                frac[v] = if frac[v] > 0.25 { 0.5 * frac[v] } else { 0.0 };
                place(&mut nodes, v, frac[v]);
            }
        }
        progress("snap", 1.0);
        if settled {
            rep.snapped = frac.iter().filter(|&&f| f == 1.0).count();
            rep.snap_partial = frac.iter().filter(|&&f| f > 0.0 && f < 1.0).count();
            rep.snap_undone = target.iter().zip(&frac).filter(|(t, &f)| t.is_some() && f == 0.0).count();
        } else {
            nodes = orig;
            rep.snapped = 0;
            rep.snap_undone = bverts.len();
            rep.warnings.push(
                "moving the boundary vertices onto the surface kept distorting elements; the voxel staircase was kept"
                    .into(),
            );
        }
    }
    let mesh = TetMesh::from_linear(nodes, &tets)?;
    rep.mesh_volume = mesh.volume();
    let dv = rep.mesh_volume / rep.surface_volume - 1.0;
    if dv.abs() > MAX_VOLUME_ERROR {
        return Err(FemError::Mesh(format!(
            "the voxel mesh's volume is {:.2} times the surface's at resolution {} (voxel size {:.3e} m): the object is thinner than a voxel somewhere; raise the resolution",
            rep.mesh_volume / rep.surface_volume,
            opts.resolution,
            h
        )));
    }
    if dv.abs() > 0.05 {
        rep.warnings.push(format!(
            "the voxel mesh's volume differs from the surface's by {:+.1} % (features thinner than the voxel size {:.3e} m are lost or thickened); raise the resolution",
            100.0 * dv,
            h
        ));
    }
    if let Some(w) = thin_warning(&rep, opts.resolution) {
        rep.warnings.push(w);
    }
    Ok((mesh, rep))
}

/// A warning when the object is only one or two voxels thick somewhere along an axis of the
/// whole grid (coarse through the thickness: bending is then too stiff).
fn thin_warning(rep: &VoxelReport, resolution: usize) -> Option<String> {
    let thin = rep.dims.iter().copied().min().unwrap_or(0);
    (thin <= 2).then(|| {
        format!(
            "the object is only {thin} voxel(s) thick at resolution {resolution}; bending frequencies will be too high: raise the resolution so the thinnest side has 3 or more"
        )
    })
}
