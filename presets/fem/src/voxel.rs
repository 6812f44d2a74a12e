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
use std::ops::RangeInclusive;

use super::geom::{cross, dot, signed_volume, sub};
use super::mesh::TetMesh;
use super::surface::{ray_hit, RayHit, TriGrid, TriSurface};
use super::FemError;
use crate::MAX_IMPORT_VERTICES;

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
    // 1. The grid.
    let grid = Grid::around(s, opts.resolution)?;
    let mut rep = VoxelReport { dims: grid.dims, h: grid.h, surface_volume: s.signed_volume(), ..Default::default() };
    let tris = non_degenerate_triangles(s);
    // 2. Inside cells, by rays along the columns.
    progress("voxelise", 0.0);
    let columns = Columns::new(s, &tris, &grid)?;
    let inside = classify_cells(s, &grid, &columns, &mut rep, progress);
    drop(columns);
    // 3. The largest face-connected piece.
    let kept = keep_largest_piece(&grid, &inside, opts.resolution, &mut rep)?;
    drop(inside);
    // 4. Five tetrahedra per cube.
    let mut lattice = Lattice::new(&grid, &kept, opts.resolution)?;
    let tets = split_cubes(&kept, &lattice);
    // 5. Boundary vertices onto the surface.
    if opts.snap {
        snap_boundary(s, &tris, &grid, &kept, &tets, &mut lattice, &mut rep, progress);
    }
    // 6. 10-node tetrahedra, checked against the surface's volume.
    let mesh = TetMesh::from_linear(lattice.nodes, &tets)?;
    rep.mesh_volume = mesh.volume();
    check_volume(&mut rep, opts.resolution)?;
    Ok((mesh, rep))
}

/// The voxel grid: cubes of side `h`, `dims` of them along x, y, z, the corner of cell
/// (0, 0, 0) at `origin`.
struct Grid {
    /// Cube side, m.
    h: f64,
    /// Cells along x, y, z.
    dims: [usize; 3],
    /// Lowest corner of the grid, m.
    origin: [f64; 3],
}

impl Grid {
    /// The grid of `resolution` cubes along the longest side of `s`'s bounding box, centred on it.
    fn around(s: &TriSurface, resolution: usize) -> Result<Grid, FemError> {
        if resolution < 2 {
            return Err(FemError::InvalidOptions(format!(
                "resolution {resolution} is too coarse; use at least 2 voxels along the longest side"
            )));
        }
        let (lo, hi) = s.bounds();
        let ext = sub(hi, lo);
        let longest = ext[0].max(ext[1]).max(ext[2]);
        if !(longest > 0.0 && longest.is_finite()) {
            return Err(FemError::Mesh("the surface has zero or non-finite size".into()));
        }
        let h = longest / resolution as f64;
        let dims: [usize; 3] = std::array::from_fn(|i| ((ext[i] / h - 1e-6).ceil() as usize).max(1));
        let cells = dims[0].saturating_mul(dims[1]).saturating_mul(dims[2]);
        if cells > MAX_VOXEL_CELLS {
            return Err(FemError::InvalidOptions(format!(
                "resolution {} gives a grid of {} x {} x {} = {cells} cells, over the limit of {MAX_VOXEL_CELLS}; use a lower resolution",
                resolution, dims[0], dims[1], dims[2]
            )));
        }
        let origin: [f64; 3] = std::array::from_fn(|i| 0.5 * (lo[i] + hi[i]) - 0.5 * dims[i] as f64 * h);
        Ok(Grid { h, dims, origin })
    }

    /// Number of cells (at most [`MAX_VOXEL_CELLS`]).
    fn cells(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// Index of cell (x, y, z), x fastest.
    fn cell(&self, [x, y, z]: [usize; 3]) -> usize {
        (z * self.dims[1] + y) * self.dims[0] + x
    }

    /// Centre of the `i`-th cell along `axis`, m.
    fn centre(&self, axis: usize, i: usize) -> f64 {
        self.origin[axis] + (i as f64 + 0.5) * self.h
    }
}

/// Triangles of `s` with a non-zero area (the only ones a ray can cross or a vertex snap to).
fn non_degenerate_triangles(s: &TriSurface) -> Vec<u32> {
    let area_tol = 1e-14 * s.diagonal().powi(2);
    (0..s.triangles.len() as u32)
        .filter(|&t| {
            let [a, b, c] = s.corners(t as usize);
            dot(cross(sub(b, a), sub(c, a)), cross(sub(b, a), sub(c, a))).sqrt() > area_tol
        })
        .collect()
}

/// The grid columns (x, y) whose centre line a triangle's xy box (widened by the ray jitter)
/// reaches.
struct ColumnBox {
    /// Columns along x.
    xs: RangeInclusive<usize>,
    /// Columns along y.
    ys: RangeInclusive<usize>,
}

impl ColumnBox {
    /// The columns of triangle `t`, if it reaches any.
    fn of(s: &TriSurface, t: u32, grid: &Grid) -> Option<ColumnBox> {
        let c = s.corners(t as usize);
        let centres = |axis: usize| {
            let mn = c[0][axis].min(c[1][axis]).min(c[2][axis]);
            let mx = c[0][axis].max(c[1][axis]).max(c[2][axis]);
            let (h, o, n) = (grid.h, grid.origin[axis], grid.dims[axis]);
            let a = ((mn - 0.01 * h - o) / h - 0.5).ceil().max(0.0);
            let b = ((mx + 0.01 * h - o) / h - 0.5).floor().min(n as f64 - 1.0);
            (a <= b).then_some(a as usize..=b as usize)
        };
        centres(0).zip(centres(1)).map(|(xs, ys)| ColumnBox { xs, ys })
    }

    /// Column indices y·nx + x, y slowest.
    fn columns(&self, nx: usize) -> impl Iterator<Item = usize> + '_ {
        self.ys.clone().flat_map(move |y| self.xs.clone().map(move |x| y * nx + x))
    }
}

/// Per (x, y) column of the grid, the triangles that may cross its centre line (compressed
/// rows: column c's are `items[start[c]..start[c + 1]]`).
struct Columns {
    /// Row starts, one per column and one past the end.
    start: Vec<u32>,
    /// Triangle numbers.
    items: Vec<u32>,
}

impl Columns {
    /// The columns of `tris` on `grid`.
    fn new(s: &TriSurface, tris: &[u32], grid: &Grid) -> Result<Columns, FemError> {
        let ncols = grid.dims[0] * grid.dims[1];
        let boxes: Vec<Option<ColumnBox>> = tris.iter().map(|&t| ColumnBox::of(s, t, grid)).collect();
        let mut start = vec![0u32; ncols + 1];
        for b in boxes.iter().flatten() {
            for c in b.columns(grid.dims[0]) {
                start[c + 1] += 1;
            }
        }
        for c in 0..ncols {
            start[c + 1] = start[c].saturating_add(start[c + 1]);
        }
        if start[ncols] as usize >= MAX_COLUMN_ENTRIES {
            return Err(FemError::Mesh(format!(
                "the surface's triangles cover too many voxel columns ({} or more pairs); use a lower resolution or a simpler surface",
                MAX_COLUMN_ENTRIES
            )));
        }
        let mut items = vec![0u32; start[ncols] as usize];
        let mut fill = start.clone();
        for (&t, b) in tris.iter().zip(&boxes) {
            for c in b.iter().flat_map(|b| b.columns(grid.dims[0])) {
                items[fill[c] as usize] = t;
                fill[c] += 1;
            }
        }
        Ok(Columns { start, items })
    }

    /// The triangles of column `c` = y·nx + x.
    fn triangles(&self, c: usize) -> &[u32] {
        &self.items[self.start[c] as usize..self.start[c + 1] as usize]
    }
}

/// Which cells have their centre inside `s`, column by column (module docs, step 2); columns
/// whose ray cannot be cast cleanly are left empty and counted (with a warning) in `rep`.
fn classify_cells(
    s: &TriSurface,
    grid: &Grid,
    columns: &Columns,
    rep: &mut VoxelReport,
    progress: &dyn Fn(&str, f32),
) -> Vec<bool> {
    let [nx, ny, nz] = grid.dims;
    let mut inside = vec![false; grid.cells()];
    let mut hits: Vec<f64> = Vec::new();
    for y in 0..ny {
        progress("voxelise", y as f32 / ny as f32);
        for x in 0..nx {
            let list = columns.triangles(y * nx + x);
            if list.is_empty() {
                continue;
            }
            if !cast_column_ray(s, grid, list, [x, y], &mut hits) {
                rep.bad_columns += 1;
                continue;
            }
            hits.sort_by(f64::total_cmp);
            // Parity: a centre is inside when an odd number of crossings lie below it.
            let mut below = 0;
            for z in 0..nz {
                let zc = grid.centre(2, z);
                while below < hits.len() && hits[below] < zc {
                    below += 1;
                }
                inside[grid.cell([x, y, z])] = below % 2 == 1;
            }
        }
    }
    if rep.bad_columns > 0 {
        rep.warnings.push(format!(
            "{} of {} voxel columns could not be classified (rays kept grazing edges) and were left empty",
            rep.bad_columns,
            nx * ny
        ));
    }
    inside
}

/// The heights at which a ray along +z near the centre of column `[x, y]` crosses the
/// triangles `list`, into `hits`: jittered by 10⁻³·h and re-cast up to [`MAX_RAY_ATTEMPTS`]
/// times until no crossing is ambiguous and their number is even; false if it never is.
fn cast_column_ray(s: &TriSurface, grid: &Grid, list: &[u32], [x, y]: [usize; 2], hits: &mut Vec<f64>) -> bool {
    'attempts: for attempt in 0..MAX_RAY_ATTEMPTS {
        let j = super::surface::jitter(attempt);
        let q = [
            grid.origin[0] + (x as f64 + 0.5 + 1e-3 * j.0) * grid.h,
            grid.origin[1] + (y as f64 + 0.5 + 1e-3 * j.1) * grid.h,
        ];
        hits.clear();
        for &t in list {
            match ray_hit(s, t as usize, 2, q) {
                RayHit::Miss => {}
                RayHit::At(z) => hits.push(z),
                RayHit::Ambiguous => continue 'attempts,
            }
        }
        if hits.len() % 2 == 0 {
            return true;
        }
    }
    false
}

/// The face-connected pieces of the inside cells.
struct Pieces {
    /// Piece of each cell (`u32::MAX` outside).
    label: Vec<u32>,
    /// Cells of each piece.
    sizes: Vec<usize>,
}

/// Labels the face-connected pieces of the inside cells by flood fill, in cell order.
fn label_pieces(grid: &Grid, inside: &[bool]) -> Pieces {
    let [nx, ny, nz] = grid.dims;
    let cells = grid.cells();
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
    Pieces { label, sizes }
}

/// The cubes kept: the largest face-connected piece of the inside cells.
struct Kept {
    /// Whether each cell is kept.
    mask: Vec<bool>,
    /// Cells along x, y, z.
    dims: [usize; 3],
    /// Cubes kept.
    count: usize,
}

impl Kept {
    /// Whether cell (x, y, z) is kept.
    fn has(&self, [x, y, z]: [usize; 3]) -> bool {
        self.mask[(z * self.dims[1] + y) * self.dims[0] + x]
    }

    /// The kept cells (x, y, z), x fastest.
    fn cells(&self) -> impl Iterator<Item = [usize; 3]> + '_ {
        let [nx, ny, nz] = self.dims;
        (0..nz)
            .flat_map(move |z| (0..ny).flat_map(move |y| (0..nx).map(move |x| [x, y, z])))
            .filter(move |&p| self.has(p))
    }
}

/// Keeps the largest piece of the inside cells (the first of equal ones) and reports what was
/// dropped.
fn keep_largest_piece(
    grid: &Grid,
    inside: &[bool],
    resolution: usize,
    rep: &mut VoxelReport,
) -> Result<Kept, FemError> {
    let pieces = label_pieces(grid, inside);
    let sizes = &pieces.sizes;
    let Some((keep, &kept)) = sizes.iter().enumerate().max_by_key(|&(i, &n)| (n, std::cmp::Reverse(i))) else {
        return Err(FemError::Mesh(format!(
            "no voxel centre is inside the surface at resolution {} (voxel size {:.3e} m); the object is thinner than a voxel: raise the resolution",
            resolution, grid.h
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
    Ok(Kept { mask: pieces.label.iter().map(|&l| l == keep).collect(), dims: grid.dims, count: kept })
}

/// Offset (a, b, c) of cube corner number a + 2b + 4c (see [`corner`]).
fn corner_offset(c: usize) -> [usize; 3] {
    [c & 1, (c >> 1) & 1, c >> 2]
}

/// The corners of the kept cubes: vertex positions and the vertex at each lattice point.
struct Lattice {
    /// Vertex positions, m.
    nodes: Vec<[f64; 3]>,
    /// Vertex at lattice point (x, y, z), x fastest (`u32::MAX` where no kept cube touches).
    vmap: Vec<u32>,
    /// Lattice points along x, y (one more than cells).
    points: [usize; 2],
}

impl Lattice {
    /// Numbers the corners of the kept cubes in cell order.
    ///
    /// # Errors
    /// [`FemError::Mesh`] over [`MAX_IMPORT_VERTICES`] vertices, suggesting a resolution.
    fn new(grid: &Grid, kept: &Kept, resolution: usize) -> Result<Lattice, FemError> {
        let [nx, ny, nz] = grid.dims;
        let mut lattice = Lattice {
            nodes: Vec::new(),
            vmap: vec![u32::MAX; (nx + 1) * (ny + 1) * (nz + 1)],
            points: [nx + 1, ny + 1],
        };
        for [x, y, z] in kept.cells() {
            for c in 0..8 {
                let [a, b, cc] = corner_offset(c);
                let (a, b, cc) = (x + a, y + b, z + cc);
                let v = lattice.index([a, b, cc]);
                if lattice.vmap[v] == u32::MAX {
                    lattice.vmap[v] = lattice.nodes.len() as u32;
                    let o = grid.origin;
                    lattice.nodes.push([o[0] + a as f64 * grid.h, o[1] + b as f64 * grid.h, o[2] + cc as f64 * grid.h]);
                }
            }
        }
        let n = lattice.nodes.len();
        if n > MAX_IMPORT_VERTICES {
            let suggest =
                ((resolution as f64) * (MAX_IMPORT_VERTICES as f64 / n as f64).cbrt() * 0.95).floor() as usize;
            return Err(FemError::Mesh(format!(
                "resolution {} gives {} vertices, over the limit of {MAX_IMPORT_VERTICES}; use a resolution of about {} or less",
                resolution,
                n,
                suggest.max(2)
            )));
        }
        Ok(lattice)
    }

    /// Index of lattice point (x, y, z) in `vmap`.
    fn index(&self, [x, y, z]: [usize; 3]) -> usize {
        (z * self.points[1] + y) * self.points[0] + x
    }

    /// The vertex at corner `c` (numbered as by [`corner`]) of cube (x, y, z).
    fn corner(&self, [x, y, z]: [usize; 3], c: usize) -> u32 {
        let [a, b, cc] = corner_offset(c);
        self.vmap[self.index([x + a, y + b, z + cc])]
    }
}

/// Five tetrahedra per kept cube, [`EVEN_TETS`] or [`ODD_TETS`] by the parity of x + y + z.
fn split_cubes(kept: &Kept, lattice: &Lattice) -> Vec<[u32; 4]> {
    let mut tets: Vec<[u32; 4]> = Vec::with_capacity(5 * kept.count);
    for p in kept.cells() {
        let pattern = if (p[0] + p[1] + p[2]) % 2 == 0 { &EVEN_TETS } else { &ODD_TETS };
        for t in pattern {
            tets.push(t.map(|c| lattice.corner(p, c)));
        }
    }
    tets
}

/// Moves the boundary vertices onto the surface as far as the elements allow (module docs,
/// step 5), or undoes every move (with a warning) if that does not settle; counts in `rep`.
#[allow(clippy::too_many_arguments)]
fn snap_boundary(
    s: &TriSurface,
    tris: &[u32],
    grid: &Grid,
    kept: &Kept,
    tets: &[[u32; 4]],
    lattice: &mut Lattice,
    rep: &mut VoxelReport,
    progress: &dyn Fn(&str, f32),
) {
    progress("snap", 0.0);
    let bverts = boundary_vertices(kept, lattice);
    let surface_grid = TriGrid::new(s, tris, 0.5 * grid.h);
    let mut snap = Snap::aim(s, &surface_grid, &bverts, &lattice.nodes, grid.h, progress);
    for v in 0..lattice.nodes.len() {
        snap.place(&mut lattice.nodes, v);
    }
    let settled = snap.settle(tets, &mut lattice.nodes);
    progress("snap", 1.0);
    if settled {
        rep.snapped = snap.frac.iter().filter(|&&f| f == 1.0).count();
        rep.snap_partial = snap.frac.iter().filter(|&&f| f > 0.0 && f < 1.0).count();
        rep.snap_undone = snap.target.iter().zip(&snap.frac).filter(|(t, &f)| t.is_some() && f == 0.0).count();
    } else {
        lattice.nodes = snap.orig;
        rep.snapped = 0;
        rep.snap_undone = bverts.len();
        rep.warnings.push(
            "moving the boundary vertices onto the surface kept distorting elements; the voxel staircase was kept"
                .into(),
        );
    }
}

/// The corners of kept cube faces that have no kept neighbour, ascending.
fn boundary_vertices(kept: &Kept, lattice: &Lattice) -> Vec<u32> {
    let mut boundary: HashSet<u32> = HashSet::new();
    // The four corners of the face of cube p on `side` (0: low, 1: high) across `axis`.
    let face_corners = |axis: usize, p: [usize; 3], side: usize| -> [u32; 4] {
        let mut out = [0u32; 4];
        let mut k = 0;
        for c in 0..8 {
            if corner_offset(c)[axis] == side {
                out[k] = lattice.corner(p, c);
                k += 1;
            }
        }
        out
    };
    for p in kept.cells() {
        for axis in 0..3 {
            for side in 0..2 {
                let mut q = p;
                let open = if side == 0 {
                    p[axis] == 0 || {
                        q[axis] -= 1;
                        !kept.has(q)
                    }
                } else {
                    p[axis] + 1 == kept.dims[axis] || {
                        q[axis] += 1;
                        !kept.has(q)
                    }
                };
                if open {
                    boundary.extend(face_corners(axis, p, side));
                }
            }
        }
    }
    let mut bverts: Vec<u32> = boundary.into_iter().collect();
    bverts.sort_unstable();
    bverts
}

/// Boundary vertex moves: each vertex goes a fraction (1, 1/2, 1/4 or 0) of the way from its
/// lattice position to its target on the surface.
struct Snap {
    /// Lattice positions of all vertices, m.
    orig: Vec<[f64; 3]>,
    /// Closest surface point within h of each boundary vertex.
    target: Vec<Option<[f64; 3]>>,
    /// Fraction of the move made.
    frac: Vec<f64>,
}

impl Snap {
    /// Full moves of the boundary vertices `bverts` to the closest surface point within `h`.
    fn aim(
        s: &TriSurface,
        grid: &TriGrid,
        bverts: &[u32],
        nodes: &[[f64; 3]],
        h: f64,
        progress: &dyn Fn(&str, f32),
    ) -> Snap {
        let orig = nodes.to_vec();
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
        Snap { orig, target, frac }
    }

    /// Puts vertex `v` its fraction of the way to its target (if it has one).
    fn place(&self, nodes: &mut [[f64; 3]], v: usize) {
        if let Some(q) = self.target[v] {
            let (o, f) = (self.orig[v], self.frac[v]);
            nodes[v] = [o[0] + f * (q[0] - o[0]), o[1] + f * (q[1] - o[1]), o[2] + f * (q[2] - o[2])];
        }
    }

    /// Halves the moves of the vertices of distorted elements (to zero after a quarter) for
    /// up to [`MAX_SNAP_ROUNDS`] rounds; whether every element then keeps
    /// [`MIN_VOLUME_RATIO`] of its volume with its orientation.
    fn settle(&mut self, tets: &[[u32; 4]], nodes: &mut [[f64; 3]]) -> bool {
        let vol0: Vec<f64> = tets.iter().map(|t| signed_volume(&self.orig, t)).collect();
        for _round in 0..MAX_SNAP_ROUNDS {
            let bad = self.distorted(tets, nodes, &vol0);
            if bad.is_empty() {
                return true;
            }
            let mut touched = HashSet::new();
            for e in bad {
                touched.extend(tets[e].iter().copied().filter(|&v| self.frac[v as usize] > 0.0));
            }
            for v in touched {
                let v = v as usize;
                self.frac[v] = if self.frac[v] > 0.25 { 0.5 * self.frac[v] } else { 0.0 };
                self.place(nodes, v);
            }
        }
        false
    }

    /// The elements with a moved vertex that keep less than [`MIN_VOLUME_RATIO`] of their
    /// volume `vol0` with its orientation.
    fn distorted(&self, tets: &[[u32; 4]], nodes: &[[f64; 3]], vol0: &[f64]) -> Vec<usize> {
        let mut bad = Vec::new();
        for (e, t) in tets.iter().enumerate() {
            if t.iter().any(|&v| self.frac[v as usize] > 0.0) {
                let v = signed_volume(nodes, t);
                if !(v * vol0[e].signum() >= MIN_VOLUME_RATIO * vol0[e].abs()) {
                    bad.push(e);
                }
            }
        }
        bad
    }
}

/// Compares the mesh's volume with the surface's (an error past [`MAX_VOLUME_ERROR`], a
/// warning past 5 %) and warns of an object only one or two voxels thick.
fn check_volume(rep: &mut VoxelReport, resolution: usize) -> Result<(), FemError> {
    let dv = rep.mesh_volume / rep.surface_volume - 1.0;
    if dv.abs() > MAX_VOLUME_ERROR {
        return Err(FemError::Mesh(format!(
            "the voxel mesh's volume is {:.2} times the surface's at resolution {} (voxel size {:.3e} m): the object is thinner than a voxel somewhere; raise the resolution",
            rep.mesh_volume / rep.surface_volume,
            resolution,
            rep.h
        )));
    }
    if dv.abs() > 0.05 {
        rep.warnings.push(format!(
            "the voxel mesh's volume differs from the surface's by {:+.1} % (features thinner than the voxel size {:.3e} m are lost or thickened); raise the resolution",
            100.0 * dv,
            rep.h
        ));
    }
    if let Some(w) = thin_warning(rep, resolution) {
        rep.warnings.push(w);
    }
    Ok(())
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
