//! Banks from user meshes: modal analysis as for the built-in shapes, with strike points
//! chosen on the mesh's own outer surface.
//!
//! Inputs ([`import_mesh_file`]): Gmsh `.msh` 2.2 or 4.1 ASCII tetrahedral meshes
//! ([`super::gmsh`]), or closed triangle surfaces in Wavefront `.obj` or `.stl`
//! ([`super::surface`]), which are checked and voxelised into tetrahedra
//! ([`super::voxel`]). For voxelised surfaces the strike gains use the normal of the nearest
//! input triangle, not the voxel face's.
//!
//! Strike points: the corner nodes on the boundary (faces used by one tetrahedron only) are
//! sampled by farthest-point sampling (Eldar et al. 1997), so they spread evenly over the
//! surface, then ordered into a path by greedy nearest neighbours, so neighbouring points are
//! close (the plugin interpolates along that order). Drawing coordinates project the points
//! on the bounding box's two largest axes.

use super::shell::{find_thin_wall, mesh_thin_wall, ShellOptions};
use super::surface::{check_surface, read_obj, read_stl, TriGrid, TriSurface};
use super::voxel::{auto_resolution, voxelise, VoxelOptions, DEFAULT_VERTEX_BUDGET};
use super::{
    analyse, fem_bank, finish_bank, start_build, strike, strike_gains, today, BankParts, BuildOptions, BuildReport,
    FemError, Material, Modes, TetMesh,
};
use presets::{Bank, StrikePoint};
use std::collections::HashMap;
use std::path::Path;

pub use crate::MAX_IMPORT_VERTICES;
/// Largest mesh file read, bytes.
pub const MAX_MESH_FILE_BYTES: u64 = 1 << 30;

/// How to read and mesh a file.
#[derive(Clone, Debug, PartialEq)]
pub struct ImportOptions {
    /// Factor from file units to metres (e.g. 0.001 for millimetres).
    pub scale: f64,
    /// Voxels along the longest side (surfaces only); `None` picks one by
    /// [`auto_resolution`] for [`DEFAULT_VERTEX_BUDGET`] vertices.
    pub resolution: Option<usize>,
    /// Move voxel boundary vertices onto the surface (surfaces only; see [`super::voxel`]).
    pub snap: bool,
    /// How a surface becomes tetrahedra.
    pub mesher: SurfaceMesher,
    /// A tetrahedral mesh whose sparse factor would exceed the build's limit
    /// ([`super::eigen::MAX_FACTOR_BYTES`]) is solved on its boundary surface meshed again
    /// within the budget (with a warning) instead of being refused.
    pub remesh_over_budget: bool,
}

impl Default for ImportOptions {
    fn default() -> Self {
        ImportOptions {
            scale: 1.0,
            resolution: None,
            snap: true,
            mesher: SurfaceMesher::Auto,
            remesh_over_budget: true,
        }
    }
}

/// How a closed surface becomes tetrahedra.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SurfaceMesher {
    /// Through the wall ([`super::shell`]) when the surface is thin-walled, else voxels.
    #[default]
    Auto,
    /// Through the wall; an error if the surface is not thin-walled.
    Shell,
    /// Voxels ([`super::voxel`]), whatever the shape.
    Voxel,
}

impl SurfaceMesher {
    /// The mesher named `name` (`auto`, `shell`, `voxel`).
    ///
    /// # Errors
    /// [`FemError::InvalidOptions`] for another name.
    pub fn parse(name: &str) -> Result<SurfaceMesher, FemError> {
        match name.trim().to_ascii_lowercase().as_str() {
            "auto" => Ok(SurfaceMesher::Auto),
            "shell" => Ok(SurfaceMesher::Shell),
            "voxel" => Ok(SurfaceMesher::Voxel),
            other => Err(FemError::InvalidOptions(format!("unknown mesher '{other}': use auto, shell or voxel"))),
        }
    }
}

/// A file's kind, from its extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFileKind {
    /// Gmsh `.msh` (2.2 or 4.1 ASCII).
    Gmsh,
    /// Wavefront `.obj`.
    Obj,
    /// `.stl`, ASCII or binary.
    Stl,
}

impl MeshFileKind {
    /// The kind for `path`'s extension (case-insensitive).
    ///
    /// # Errors
    /// [`FemError::InvalidOptions`] for another or no extension, or a folder (looked up on
    /// the file system).
    pub fn of(path: &Path) -> Result<MeshFileKind, FemError> {
        if path.is_dir() {
            return Err(FemError::InvalidOptions("a folder, not a mesh file (.msh, .obj or .stl)".into()));
        }
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        match ext.as_str() {
            "msh" => Ok(MeshFileKind::Gmsh),
            "obj" => Ok(MeshFileKind::Obj),
            "stl" => Ok(MeshFileKind::Stl),
            _ => Err(FemError::InvalidOptions(format!(
                "cannot tell the mesh format of {}: use a .msh (Gmsh 2.2/4.1 ASCII tetrahedra), .obj or .stl (closed surface) file",
                path.display()
            ))),
        }
    }
}

/// A tetrahedral mesh ready for [`build_bank_from_import`], with what was done to get it.
#[derive(Clone, Debug)]
pub struct ImportedMesh {
    /// The mesh (m).
    pub mesh: TetMesh,
    /// The checked input surface, if the mesh was voxelised from one.
    pub surface: Option<TriSurface>,
    /// Warnings from the checks and the voxeliser.
    pub warnings: Vec<String>,
    /// One line on how the mesh was made (goes into the bank's provenance).
    pub summary: String,
}

/// Reads a mesh file (kind by extension, see [`MeshFileKind`]), scales it to metres and,
/// for a surface, checks and voxelises it. `progress` gets `"read"`, `"check"`,
/// `"voxelise"` and `"snap"`.
///
/// # Errors
/// [`FemError::InvalidOptions`] (extension, scale), [`FemError::MeshFile`] (parse errors with
/// the line) or [`FemError::Mesh`] (unreadable or too large file, failed surface checks,
/// voxel limits).
pub fn import_mesh_file(
    path: &Path,
    opts: &ImportOptions,
    progress: &dyn Fn(&str, f32),
) -> Result<ImportedMesh, FemError> {
    let budget = (super::eigen::MAX_FACTOR_BYTES as f64, OVER_BUDGET_MIN_DOFS);
    import_mesh_file_within(path, opts, budget, progress)
}

/// [`import_mesh_file`] with the factor's limit (bytes) and the DOFs under which no estimate
/// is made given (tests try the over-budget path on small meshes).
fn import_mesh_file_within(
    path: &Path,
    opts: &ImportOptions,
    (limit, min_dofs): (f64, usize),
    progress: &dyn Fn(&str, f32),
) -> Result<ImportedMesh, FemError> {
    let kind = MeshFileKind::of(path)?;
    validate_scale(opts.scale)?;
    progress("read", 0.0);
    let io = |e: std::io::Error| FemError::Mesh(format!("cannot read {}: {e}", path.display()));
    let len = std::fs::metadata(path).map_err(io)?.len();
    if len > MAX_MESH_FILE_BYTES {
        return Err(FemError::Mesh(format!(
            "{} is {len} bytes, over the limit of {MAX_MESH_FILE_BYTES}; simplify the mesh",
            path.display()
        )));
    }
    // No further than the limit either: a device's length is 0 (a link to `/dev/zero`).
    let bytes = presets::read_capped(path, MAX_MESH_FILE_BYTES).map_err(io)?.ok_or_else(|| {
        FemError::Mesh(format!(
            "{} is over the limit of {MAX_MESH_FILE_BYTES} bytes; simplify the mesh",
            path.display()
        ))
    })?;
    match kind {
        MeshFileKind::Gmsh => {
            let text = String::from_utf8_lossy(&bytes);
            let mut mesh = super::read_gmsh(&text)?;
            drop(bytes);
            check_one_body(&mesh)?;
            // Over the factor's limit the build would refuse the mesh: its surface, meshed
            // again by the DOF budget, gives a bank instead (the estimate is skipped for
            // meshes far under the limit: it costs a symbolic analysis).
            if opts.remesh_over_budget && 3 * mesh.nodes.len() > min_dofs {
                let bytes = super::eigen::factor_bytes_estimate(&mesh)?;
                // The build also refuses more corner vertices than MAX_IMPORT_VERTICES.
                if bytes > limit || mesh.corners > MAX_IMPORT_VERTICES {
                    let (dofs, corners) = (3 * mesh.nodes.len(), mesh.corners);
                    let surface = boundary_surface(&mesh);
                    let triangles = surface.triangles.len();
                    drop(mesh);
                    let mut imported = import_surface(surface, "its boundary", opts, progress)?;
                    let why = if bytes > limit {
                        format!(
                            "{dofs} DOFs would need a {:.2} GiB sparse factor, over the build's {:.2} GiB limit",
                            bytes / f64::from(1 << 30),
                            limit / f64::from(1 << 30)
                        )
                    } else {
                        format!("{corners} corner vertices are over the build's limit of {MAX_IMPORT_VERTICES}")
                    };
                    let how = match opts.resolution {
                        Some(r) => format!("at --resolution {r}"),
                        None => "within the budget".to_string(),
                    };
                    imported.warnings.insert(
                        0,
                        format!(
                            "the mesh's {why}: it was remeshed from its boundary ({triangles} triangles) {how}, so the modes are those of the new mesh, not of the file's (the summary says how it was meshed); --no-remesh refuses such a mesh instead"
                        ),
                    );
                    imported.summary = format!(
                        "Gmsh tetrahedral mesh of {corners} corner vertices and {dofs} DOFs, over the build's budget, remeshed from {}",
                        imported.summary
                    );
                    return Ok(imported);
                }
            }
            for p in &mut mesh.nodes {
                for c in p.iter_mut() {
                    *c *= opts.scale;
                }
            }
            let summary = format!("Gmsh tetrahedral mesh, scale {}", opts.scale);
            let (lo, hi) = mesh.bounds();
            let warnings = units_warning(extent(lo, hi), opts.scale).into_iter().collect();
            Ok(ImportedMesh { mesh, surface: None, warnings, summary })
        }
        MeshFileKind::Obj => import_surface(read_obj(&String::from_utf8_lossy(&bytes))?, "OBJ", opts, progress),
        MeshFileKind::Stl => import_surface(read_stl(&bytes)?, "STL", opts, progress),
    }
}

/// The largest side of the box `lo`–`hi`.
fn extent(lo: [f64; 3], hi: [f64; 3]) -> f64 {
    (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max)
}

/// Struck's objects are millimetres to metres across: a warning naming `--scale` when an
/// imported object's largest side `size` (m, after `scale`) is outside 2 mm–20 m, the usual
/// sign of a file in other units (a 5 cm cup saved in millimetres is read as 50 m and rings
/// at a few hertz).
pub fn units_warning(size: f64, scale: f64) -> Option<String> {
    if size > 20.0 {
        Some(format!(
            "the object is {size:.4} m across at --scale {scale}: if the file is in millimetres use --scale {}, in centimetres --scale {}",
            scale * 1e-3,
            scale * 1e-2
        ))
    } else if size < 2e-3 {
        Some(format!(
            "the object is {:.4} mm across at --scale {scale}: its modes will lie far above hearing; check --scale (the factor from the file's units to metres)",
            size * 1e3
        ))
    } else {
        None
    }
}

/// Fails when the tetrahedra form more than one connected body (sharing no node), naming how
/// many and their sizes: a free solid made of N bodies has 6N rigid modes, and a bank is one
/// object.
///
/// # Errors
/// [`FemError::Mesh`] for two or more bodies.
pub fn check_one_body(mesh: &TetMesh) -> Result<(), FemError> {
    let mut parent: Vec<u32> = (0..mesh.nodes.len() as u32).collect();
    fn root(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            parent[i as usize] = parent[parent[i as usize] as usize];
            i = parent[i as usize];
        }
        i
    }
    for t in &mesh.tets {
        let a = root(&mut parent, t[0]);
        for &n in &t[1..] {
            let b = root(&mut parent, n);
            if a != b {
                parent[b as usize] = a;
            }
        }
    }
    let mut sizes: HashMap<u32, usize> = HashMap::new();
    for t in &mesh.tets {
        *sizes.entry(root(&mut parent, t[0])).or_default() += 1;
    }
    if sizes.len() <= 1 {
        return Ok(());
    }
    let mut counts: Vec<usize> = sizes.into_values().collect();
    counts.sort_unstable_by(|a, b| b.cmp(a));
    let shown: Vec<String> = counts.iter().take(5).map(|c| c.to_string()).collect();
    Err(FemError::Mesh(format!(
        "the mesh is {} separate bodies that share no node ({}{} tetrahedra); a bank is one connected object: mesh each body on its own",
        counts.len(),
        shown.join(", "),
        if counts.len() > 5 { ", …" } else { "" }
    )))
}

fn validate_scale(scale: f64) -> Result<(), FemError> {
    if !(scale.is_finite() && scale > 0.0) {
        return Err(FemError::InvalidOptions(format!(
            "the scale must be a finite factor > 0 (e.g. 0.001 for millimetres), found {scale}"
        )));
    }
    Ok(())
}

/// Share of a surface's area on parts thinner than two voxels over which a voxel mesh is
/// warned about.
pub const THIN_PART_SHARE: f64 = 0.01;

/// A warning when over [`THIN_PART_SHARE`] of `surface` lies on parts thinner than two voxel
/// sides `h` ([`super::shell::thin_parts`]): the voxels cannot follow such a part (a fin, a
/// blade, a thin wall), so its modes come out sharp (a 1 mm fin on a 6 cm block voxelised at
/// 2.4 mm: 28 % high; a 4 mm bowl wall at 3.2 mm voxels: up to 14 %).
fn thin_parts_warning(surface: &TriSurface, h: f64) -> Option<String> {
    let (share, thinnest) = super::shell::thin_parts(surface, 2.0 * h);
    (share > THIN_PART_SHARE).then(|| {
        // The resolution whose voxels would fit two across the thinnest part (rounding
        // noise of the ray cast kept out of the ceiling); beyond any grid the voxeliser
        // takes, Gmsh is the only advice.
        // (The resolution is the box's largest side over h.)
        let (lo, hi) = surface.bounds();
        let needed = (2.0 * extent(lo, hi) / thinnest * (1.0 - 1e-9)).ceil();
        let advice = if needed <= 1000.0 {
            format!("--resolution {needed:.0} would resolve them (if it fits the budget), or mesh the object as Gmsh tetrahedra")
        } else {
            "mesh the object as Gmsh tetrahedra".to_string()
        };
        format!(
            "{:.0} % of the surface is on parts thinner than two voxels (down to {:.2e} m, voxels {:.2e} m): the voxel mesh cannot follow them, so modes that move them come out sharp; {advice}",
            100.0 * share,
            thinnest,
            h
        )
    })
}

/// Scales and checks ([`check_surface`]) a triangle surface (`format` names it in the
/// summary), then meshes it through its wall if it is thin-walled ([`super::shell`], per
/// `opts.mesher`) or voxelises it ([`voxelise`]).
///
/// # Errors
/// As [`check_surface`], [`super::shell::mesh_thin_wall`] (with `SurfaceMesher::Shell`; with
/// `Auto` only its option errors, the others fall back to voxels) and [`voxelise`];
/// [`FemError::InvalidOptions`] for a bad scale, or a `resolution` too fine for a thin wall
/// (over the corner limit or the factor limit).
pub fn import_surface(
    mut surface: TriSurface,
    format: &str,
    opts: &ImportOptions,
    progress: &dyn Fn(&str, f32),
) -> Result<ImportedMesh, FemError> {
    validate_scale(opts.scale)?;
    if opts.scale != 1.0 {
        surface.scale(opts.scale);
    }
    progress("check", 0.0);
    let check = check_surface(&mut surface)?;
    let (lo, hi) = surface.bounds();
    let units = units_warning(extent(lo, hi), opts.scale);
    let mut warnings = check.warnings;
    warnings.extend(units);
    let head = format!("{format} surface of {} triangles (scale {})", check.triangles, opts.scale);
    if opts.mesher != SurfaceMesher::Voxel {
        let (lo, hi) = surface.bounds();
        let shell_opts =
            ShellOptions { edge: opts.resolution.map(|r| extent(lo, hi) / r.max(1) as f64), ..ShellOptions::default() };
        let meshed = find_thin_wall(&surface)
            .map_err(|why| FemError::Mesh(format!("the surface is not thin-walled: {why}")))
            .and_then(|wall| {
                let mut shell_opts = shell_opts;
                // By budget: fewer DOFs while the factor is estimated over 90 % of its limit;
                // a fold (a few elements squeezed at a sharp inner corner) is tried once or
                // twice more on a coarser remeshing, whose triangles fall elsewhere.
                let mut retries = 0;
                loop {
                    let (mesh, rep) = match mesh_thin_wall(&surface, &wall, &shell_opts, progress) {
                        Err(FemError::Mesh(m))
                            if m.contains("folds over") && opts.resolution.is_none() && retries < 2 =>
                        {
                            retries += 1;
                            shell_opts.dofs = (shell_opts.dofs as f64 * 0.8) as usize;
                            continue;
                        }
                        r => r?,
                    };
                    // One object: two walls joined only through solid parts (a goblet's bowl
                    // and foot) would come out as pieces; voxels instead.
                    check_one_body(&mesh)?;
                    let bytes = super::eigen::factor_bytes_estimate(&mesh)?;
                    let limit = 0.9 * super::eigen::MAX_FACTOR_BYTES as f64;
                    if let Some(r) = opts.resolution {
                        // The user's resolution is kept, but a mesh the build would refuse
                        // is refused here, before its assembly.
                        let max = super::eigen::MAX_FACTOR_BYTES as f64;
                        if bytes > max {
                            return Err(FemError::InvalidOptions(format!(
                                "--resolution {r} is too fine for this wall: its mesh has {} DOFs, whose sparse factor would take {:.2} GiB (limit {:.2} GiB, to keep the build within 4 GiB); use a --resolution of at most about {:.0}, or leave it out to mesh within the budget (or --mesher voxel)",
                                3 * mesh.nodes.len(),
                                bytes / f64::from(1 << 30),
                                max / f64::from(1 << 30),
                                // A wall's DOFs go as the resolution squared and its factor
                                // about as its DOFs; a fifth's margin.
                                (r as f64 * (0.8 * max / bytes).sqrt()).floor()
                            )));
                        }
                        return Ok((mesh, rep));
                    }
                    if bytes <= limit {
                        return Ok((mesh, rep));
                    }
                    if retries >= 4 {
                        return Err(FemError::Mesh("the wall's mesh does not fit the build's memory budget".into()));
                    }
                    retries += 1;
                    shell_opts.dofs = (shell_opts.dofs as f64 * 0.9 * limit / bytes) as usize;
                }
            });
        match meshed {
            Ok((mesh, rep)) => {
                let summary = format!(
                    "{head}, thin-walled ({} wall{}, {:.0} % of the surface): meshed through the wall, {} layers of prisms under a side of {} triangles remeshed to {} (edge {:.3e} m{}), wall {:.3e}-{:.3e} m (median {:.3e}), smallest dihedral angle {:.1} deg, largest aspect {:.1}; volume {:.4e} m^3 vs {:.4e} m^3 enclosed",
                    rep.walls,
                    if rep.walls == 1 { "" } else { "s" },
                    100.0 * rep.cover,
                    rep.layers,
                    rep.side_triangles[0],
                    rep.side_triangles[1],
                    rep.edge,
                    if opts.resolution.is_none() { ", chosen for the DOF budget" } else { "" },
                    rep.thickness[0],
                    rep.thickness[2],
                    rep.thickness[1],
                    rep.min_dihedral_deg,
                    rep.max_aspect,
                    rep.mesh_volume,
                    rep.surface_volume
                );
                if rep.min_dihedral_deg < 2.0 || rep.max_aspect > 100.0 {
                    warnings.push(format!(
                        "some elements of the wall are badly shaped (smallest dihedral angle {:.1} deg, largest aspect {:.0}), typically beside a sharp inner corner; the modes may be off there: compare with --mesher voxel or another --resolution",
                        rep.min_dihedral_deg, rep.max_aspect
                    ));
                }
                if rep.cover < 0.95 {
                    warnings.push(format!(
                        "{:.0} % of the surface is not part of a thin wall (rims, ends, or small solid parts such as a thin handle, which the wall mesh leaves out); if that part matters, use --mesher voxel",
                        100.0 * (1.0 - rep.cover)
                    ));
                }
                return Ok(ImportedMesh { mesh, surface: Some(surface), warnings, summary });
            }
            // A --resolution too fine for the wall is the user's to change, not a reason to
            // voxelise at it.
            Err(e @ FemError::InvalidOptions(_)) => return Err(e),
            Err(e) if opts.mesher == SurfaceMesher::Shell => return Err(e),
            Err(e) => {
                let why = e.to_string();
                // Not thin-walled is the usual case for a solid: no warning. A thin wall that
                // could not be meshed through is worth one.
                if !why.contains("not thin-walled") {
                    warnings.push(format!("the thin wall could not be meshed through ({why}); voxelised instead"));
                }
            }
        }
    }
    let resolution = opts.resolution.unwrap_or_else(|| auto_resolution(&surface, DEFAULT_VERTEX_BUDGET));
    let (mesh, vox) = voxelise(&surface, &VoxelOptions { resolution, snap: opts.snap }, progress)?;
    warnings.extend(vox.warnings.iter().cloned());
    if let Some(w) = thin_parts_warning(&surface, vox.h) {
        warnings.push(w);
    }
    let summary = format!(
        "{head}, voxelised at resolution {}{} (h = {:.3e} m, {} x {} x {} grid, {} voxels, 5 tetrahedra each; boundary vertices moved onto the surface: {} fully, {} partly); volume {:.4e} m^3 vs {:.4e} m^3 enclosed",
        resolution,
        if opts.resolution.is_none() { ", chosen for the vertex budget" } else { "" },
        vox.h,
        vox.dims[0],
        vox.dims[1],
        vox.dims[2],
        vox.voxels,
        vox.snapped,
        vox.snap_partial,
        vox.mesh_volume,
        vox.surface_volume
    );
    Ok(ImportedMesh { mesh, surface: Some(surface), warnings, summary })
}

/// Tetrahedral meshes under this many DOFs are far under the factor's limit (the 5 cm cube's
/// 89,000 DOFs build within 1.6 GiB in all): no estimate is made for them (it costs a
/// symbolic analysis).
const OVER_BUDGET_MIN_DOFS: usize = 60_000;

/// The boundary faces of `mesh` (corner nodes; faces of one element only), each oriented
/// outward (counter-clockwise seen from outside, the element's fourth corner behind it).
fn boundary_faces(mesh: &TetMesh) -> Vec<[u32; 3]> {
    let mut faces: HashMap<[u32; 3], ([u32; 3], u32)> = HashMap::with_capacity(mesh.tets.len() * 2);
    for t in &mesh.tets {
        for opp in 0..4 {
            // Corners 0–3 are positively oriented, so each face below, as listed, has the
            // opposite corner on its inner side.
            let f = match opp {
                0 => [t[1], t[2], t[3]],
                1 => [t[0], t[3], t[2]],
                2 => [t[0], t[1], t[3]],
                _ => [t[0], t[2], t[1]],
            };
            let mut key = f;
            key.sort_unstable();
            faces.entry(key).or_insert((f, 0)).1 += 1;
        }
    }
    let mut out: Vec<[u32; 3]> = faces.into_values().filter(|&(_, n)| n == 1).map(|(f, _)| f).collect();
    out.sort_unstable();
    out
}

/// Corner nodes on the boundary of `mesh`.
fn boundary_corners(mesh: &TetMesh) -> Vec<u32> {
    nodes_of(&boundary_faces(mesh))
}

/// The nodes `faces` use, in order, once each.
fn nodes_of(faces: &[[u32; 3]]) -> Vec<u32> {
    let mut nodes: Vec<u32> = faces.iter().flatten().copied().collect();
    nodes.sort_unstable();
    nodes.dedup();
    nodes
}

/// The closed surface bounding `mesh`: its boundary faces (flat triangles on the corner
/// nodes) with the vertices they use, numbered in node order.
pub fn boundary_surface(mesh: &TetMesh) -> TriSurface {
    let faces = boundary_faces(mesh);
    let mut index = vec![u32::MAX; mesh.nodes.len()];
    let mut vertices = Vec::new();
    for n in nodes_of(&faces) {
        index[n as usize] = vertices.len() as u32;
        vertices.push(mesh.nodes[n as usize]);
    }
    let triangles = faces.iter().map(|f| f.map(|n| index[n as usize])).collect();
    TriSurface { vertices, triangles }
}

fn dist2(a: [f64; 3], b: [f64; 3]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)
}

/// `count` boundary points of `mesh`, evenly spread and ordered along a path.
///
/// # Errors
/// [`FemError::Mesh`] if the mesh has no boundary (it cannot be struck).
pub fn surface_strike_points(mesh: &TetMesh, count: usize) -> Result<Vec<[f64; 3]>, FemError> {
    let cand = boundary_corners(mesh);
    if cand.is_empty() {
        return Err(FemError::Mesh("the mesh has no boundary faces".into()));
    }
    let pos: Vec<[f64; 3]> = cand.iter().map(|&n| mesh.nodes[n as usize]).collect();
    let count = count.clamp(1, pos.len());
    // Farthest-point sampling from the point farthest from the centroid.
    let c = pos.iter().fold([0.0; 3], |a, p| [a[0] + p[0], a[1] + p[1], a[2] + p[2]]);
    let c = [c[0] / pos.len() as f64, c[1] / pos.len() as f64, c[2] / pos.len() as f64];
    let first = (0..pos.len()).max_by(|&i, &j| dist2(pos[i], c).total_cmp(&dist2(pos[j], c))).unwrap_or(0);
    let mut chosen = vec![first];
    let mut near: Vec<f64> = pos.iter().map(|p| dist2(*p, pos[first])).collect();
    while chosen.len() < count {
        let next = (0..pos.len()).max_by(|&i, &j| near[i].total_cmp(&near[j])).unwrap_or(0);
        if near[next] <= 0.0 {
            break;
        }
        chosen.push(next);
        for (d, p) in near.iter_mut().zip(&pos) {
            *d = d.min(dist2(*p, pos[next]));
        }
    }
    // Greedy nearest-neighbour path from the first sample.
    let mut path = vec![chosen[0]];
    let mut left: Vec<usize> = chosen[1..].to_vec();
    while !left.is_empty() {
        let last = pos[*path.last().unwrap_or(&chosen[0])];
        let (k, _) = left
            .iter()
            .enumerate()
            .min_by(|a, b| dist2(pos[*a.1], last).total_cmp(&dist2(pos[*b.1], last)))
            .unwrap_or((0, &0));
        path.push(left.swap_remove(k));
    }
    Ok(path.into_iter().map(|i| pos[i]).collect())
}

/// Builds a bank from a tetrahedral mesh (e.g. from [`super::read_gmsh`]): modal analysis,
/// strike points on the mesh's surface and their gains. `source` names the mesh in the
/// bank's provenance.
///
/// # Errors
/// Any [`FemError`]; [`FemError::Mesh`] for a mesh over [`MAX_IMPORT_VERTICES`] corner
/// vertices (coarsen it) or without a boundary.
pub fn build_bank_from_mesh(
    id: &str,
    name: &str,
    source: &str,
    mesh: &TetMesh,
    material: &Material,
    opts: &BuildOptions,
    progress: &dyn Fn(&str, f32),
) -> Result<(Bank, BuildReport), FemError> {
    build(id, name, source, mesh, None, "", material, opts, progress)
}

/// Builds a bank from an [`ImportedMesh`]: as [`build_bank_from_mesh`], with the gains of a
/// voxelised surface taken along the nearest input triangle's normal.
///
/// # Errors
/// As [`build_bank_from_mesh`].
pub fn build_bank_from_import(
    id: &str,
    name: &str,
    source: &str,
    imported: &ImportedMesh,
    material: &Material,
    opts: &BuildOptions,
    progress: &dyn Fn(&str, f32),
) -> Result<(Bank, BuildReport), FemError> {
    build(id, name, source, &imported.mesh, imported.surface.as_ref(), &imported.summary, material, opts, progress)
}

/// Surface-normal gains like [`strike_gains`], with the normal of the nearest triangle of
/// `surface` instead of the mesh face's.
fn gains_with_surface_normals(
    mesh: &TetMesh,
    modes: &Modes,
    points: &[[f64; 3]],
    surface: &TriSurface,
) -> Vec<Vec<f64>> {
    let tris: Vec<u32> = (0..surface.triangles.len() as u32).collect();
    let diag = surface.diagonal();
    let grid = TriGrid::new(surface, &tris, 1e-3 * diag);
    let faces = strike::Surface::new(mesh);
    points
        .iter()
        .map(|&p| {
            let Some((nodes, w, mesh_normal)) = faces.locate(mesh, p) else {
                return vec![0.0; modes.lambdas.len()];
            };
            // Growing search radius: a few rounds reach the whole bounding box.
            let mut r = grid.h;
            let mut nrm = mesh_normal;
            while r < 4.0 * diag {
                if let Some((_, _, t)) = grid.closest(surface, p, r) {
                    let n = surface.normal(t);
                    if n != [0.0; 3] {
                        nrm = n;
                    }
                    break;
                }
                r *= 2.0;
            }
            (0..modes.lambdas.len())
                .map(|m| {
                    let v = modes.mode(m);
                    nodes
                        .iter()
                        .enumerate()
                        .map(|(k, &nd)| {
                            let d = 3 * nd as usize;
                            w[k] * (v[d] * nrm[0] + v[d + 1] * nrm[1] + v[d + 2] * nrm[2])
                        })
                        .sum()
                })
                .collect()
        })
        .collect()
}

#[allow(clippy::too_many_arguments)]
fn build(
    id: &str,
    name: &str,
    source: &str,
    mesh: &TetMesh,
    surface: Option<&TriSurface>,
    how: &str,
    material: &Material,
    opts: &BuildOptions,
    progress: &dyn Fn(&str, f32),
) -> Result<(Bank, BuildReport), FemError> {
    let t0 = start_build(material, opts)?;
    if mesh.corners > MAX_IMPORT_VERTICES {
        return Err(FemError::Mesh(format!(
            "{} corner vertices is over the limit of {MAX_IMPORT_VERTICES}: coarsen the mesh (e.g. a larger Gmsh characteristic length)",
            mesh.corners
        )));
    }
    if mesh.tets.is_empty() {
        return Err(FemError::Mesh("the mesh has no tetrahedra".into()));
    }
    check_one_body(mesh)?;
    let modes = analyse(mesh, material, opts, progress)?;
    progress("strike", 0.0);
    let points = surface_strike_points(mesh, opts.strike_points)?;
    let gains = match surface {
        Some(surf) => gains_with_surface_normals(mesh, &modes, &points, surf),
        None => strike_gains(mesh, &modes, &points),
    };
    let (lo, hi) = mesh.bounds();
    let ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let mut axes = [0usize, 1, 2];
    axes.sort_by(|&a, &b| ext[b].total_cmp(&ext[a]));
    let (u, v) = (axes[0], axes[1]);
    let size = ext[u].max(1e-9);
    let parts = BankParts {
        description: format!(
            "Imported mesh {source} ({:.4} x {:.4} x {:.4} m bounding box), computed by FEM for E = {:.4e} Pa, rho = {} kg/m^3, nu = {}. Strike points: boundary corner nodes, farthest-point sampled; xy = projection on the two longest box axes.",
            ext[0], ext[1], ext[2], material.young, material.density, material.poisson
        ),
        provenance: format!(
            "FEM (struck-presets fem) of {source}{}{how}{}: {} 10-node tetrahedra, {} nodes ({} corner vertices), {} DOFs; spectrum slicing with block shift-invert Lanczos and Sturm-count checks on faer sparse LDL^T factorisations ({} ordering); 6 rigid modes removed; built {}",
            if how.is_empty() { "" } else { " (" },
            if how.is_empty() { "" } else { ")" },
            mesh.tets.len(),
            mesh.nodes.len(),
            mesh.corners,
            modes.dofs,
            modes.ordering,
            today()
        ),
        dimensions_m: ext.to_vec(),
        size_m: size,
        points: points
            .iter()
            .enumerate()
            .map(|(i, p)| StrikePoint {
                label: format!("surface {i}"),
                xy: [((p[u] - lo[u]) / ext[u].max(1e-12)).clamp(0.0, 1.0) as f32, ((p[v] - lo[v]) / ext[v].max(1e-12)).clamp(0.0, 1.0) as f32],
                position_m: [p[0] as f32, p[1] as f32, p[2] as f32],
            })
            .collect(),
        surface: super::strike::Surface::new(mesh).drawing(mesh, presets::MAX_DRAW_TRIANGLES),
    };
    let bank = fem_bank(id, name, material, &modes, &gains, parts);
    finish_bank(bank, mesh, &modes, t0, progress)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{mesh_shape, Shape};
    use std::f64::consts::TAU;

    /// The boundary of a meshed bowl or block is a closed surface, oriented outward as it
    /// comes (the checks flip nothing), enclosing the mesh's volume, with every boundary
    /// corner and no interior node.
    #[test]
    fn a_meshs_boundary_is_the_closed_surface_of_its_volume() {
        for (shape, res) in [
            (Shape::Bowl { radius: 0.08, wall: 0.004 }, 16),
            (Shape::Block { length: 0.05, width: 0.04, height: 0.03 }, 6),
        ] {
            let mesh = mesh_shape(&shape, res).unwrap();
            let mut surface = boundary_surface(&mesh);
            let enclosed = surface.signed_volume();
            assert!((enclosed / mesh.volume() - 1.0).abs() < 1e-9, "{enclosed} vs {}", mesh.volume());
            let report = check_surface(&mut surface).unwrap();
            assert_eq!(report.flipped, 0, "{:?}", report.warnings);
            assert_eq!(surface.vertices.len(), boundary_corners(&mesh).len());
            if matches!(shape, Shape::Block { .. }) {
                assert!(surface.vertices.len() < mesh.corners, "interior corners are left out");
            }
        }
    }

    /// A Gmsh mesh over the factor's limit (here a tiny one) is solved on its boundary meshed
    /// again, with the warning, and rings as the mesh itself does (first modes within 2 %,
    /// the two meshes' own discretisation errors); with `remesh_over_budget` off it is taken
    /// as it is.
    #[test]
    fn a_mesh_over_the_budget_is_solved_on_its_boundary_meshed_again() {
        let shape = Shape::Bowl { radius: 0.08, wall: 0.004 };
        let mesh = mesh_shape(&shape, 16).unwrap();
        let mut msh = format!("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n{}\n", mesh.corners);
        for (i, p) in mesh.nodes[..mesh.corners].iter().enumerate() {
            msh += &format!("{} {:e} {:e} {:e}\n", i + 1, p[0], p[1], p[2]);
        }
        msh += &format!("$EndNodes\n$Elements\n{}\n", mesh.tets.len());
        for (i, t) in mesh.tets.iter().enumerate() {
            msh += &format!("{} 4 2 1 1 {} {} {} {}\n", i + 1, t[0] + 1, t[1] + 1, t[2] + 1, t[3] + 1);
        }
        msh += "$EndElements\n";
        let path = std::env::temp_dir().join(format!("struck-over-budget-{}.msh", std::process::id()));
        std::fs::write(&path, msh).unwrap();
        let opts = ImportOptions { resolution: Some(16), ..ImportOptions::default() };
        let quiet = |_: &str, _: f32| {};
        let remeshed = import_mesh_file_within(&path, &opts, (1e3, 0), &quiet).unwrap();
        let as_given = import_mesh_file_within(
            &path,
            &ImportOptions { remesh_over_budget: false, ..opts.clone() },
            (1e3, 0),
            &quiet,
        )
        .unwrap();
        std::fs::remove_file(&path).unwrap();
        assert!(remeshed.warnings[0].contains("over the build's") && remeshed.warnings[0].contains("remeshed"));
        assert!(remeshed.summary.contains("remeshed from its boundary surface of"), "{}", remeshed.summary);
        assert!(remeshed.summary.contains("thin-walled"), "{}", remeshed.summary);
        assert!(as_given.warnings.is_empty() && as_given.summary.starts_with("Gmsh tetrahedral mesh,"));
        let glass = Material { young: 63e9, density: 2500.0, poisson: 0.22 };
        let opts = BuildOptions { max_modes: 4, resolution: 16, strike_points: 8, ..BuildOptions::default() };
        let bank = |m: &ImportedMesh| build_bank_from_import("b", "B", "test", m, &glass, &opts, &quiet).unwrap().0;
        let (a, b) = (bank(&remeshed), bank(&as_given));
        for (x, y) in a.lambdas.iter().zip(&b.lambdas) {
            let ratio = (x / y).sqrt();
            assert!((ratio - 1.0).abs() < 0.02, "{} Hz vs {} Hz", x.sqrt() / TAU, y.sqrt() / TAU);
        }
    }

    #[test]
    fn a_meshed_bar_imported_as_a_mesh_gives_the_same_modes() {
        let shape = Shape::Bar { length: 0.3, width: 0.02, thickness: 0.008 };
        let mesh = mesh_shape(&shape, 10).unwrap();
        let mat = Material { young: 2.0e11, density: 7850.0, poisson: 0.3 };
        let opts = BuildOptions {
            max_modes: 8,
            max_freq_hz: None,
            resolution: 10,
            strike_points: 24,
            auto_resolution: false,
            accuracy: None,
        };
        let (bank, report) =
            build_bank_from_mesh("imported-bar", "Imported bar", "test", &mesh, &mat, &opts, &|_, _| {}).unwrap();
        assert_eq!(bank.num_points(), 24);
        assert_eq!(report.rigid_eigenvalues.len(), 6);
        let (direct, _) = crate::build_bank("bar", "Bar", &shape, &mat, &opts, &|_, _| {}).unwrap();
        for (a, b) in bank.lambdas.iter().zip(&direct.lambdas) {
            assert!((a / b - 1.0).abs() < 1e-9, "{a} vs {b}");
        }
        // Points are spread: no two closer than a tenth of the mean spacing.
        let p: Vec<[f32; 3]> = bank.points.iter().map(|s| s.position_m).collect();
        let d =
            |a: [f32; 3], b: [f32; 3]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        let min = (0..p.len())
            .flat_map(|i| (i + 1..p.len()).map(move |j| (i, j)))
            .map(|(i, j)| d(p[i], p[j]))
            .fold(f32::MAX, f32::min);
        assert!(min > 0.003, "closest strike points {min} m apart");
        // Every mode is heard somewhere on the surface.
        for m in 0..bank.num_modes() {
            assert!(bank.gains.iter().any(|r| r[m].abs() > 1e-3), "mode {m} silent everywhere");
        }
    }
}
