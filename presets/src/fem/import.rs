//! Banks from user meshes (Gmsh `.msh` 2.2 tetrahedral meshes): modal analysis as for the
//! built-in shapes, with strike points chosen on the mesh's own outer surface.
//!
//! Strike points: the corner nodes on the boundary (faces used by one tetrahedron only) are
//! sampled by farthest-point sampling (Eldar et al. 1997), so they spread evenly over the
//! surface, then ordered into a path by greedy nearest neighbours, so neighbouring points are
//! close (the plugin interpolates along that order). Drawing coordinates project the points
//! on the bounding box's two largest axes.

use super::{analyse, finish_bank, strike_gains, today, BuildOptions, BuildReport, FemError, Material, TetMesh};
use crate::{Bank, BankReference, StrikePoint};
use std::collections::HashMap;
use std::time::Instant;

/// Largest mesh accepted, in corner vertices (a bound on time and memory; see the README).
pub const MAX_IMPORT_VERTICES: usize = 60_000;

/// Corner nodes on the boundary of `mesh`.
fn boundary_corners(mesh: &TetMesh) -> Vec<u32> {
    let mut count: HashMap<[u32; 3], u32> = HashMap::with_capacity(mesh.tets.len() * 2);
    for t in &mesh.tets {
        for opp in 0..4 {
            let mut key = [0u32; 3];
            let mut k = 0;
            for (c, &node) in t[..4].iter().enumerate() {
                if c != opp {
                    key[k] = node;
                    k += 1;
                }
            }
            key.sort_unstable();
            *count.entry(key).or_insert(0) += 1;
        }
    }
    let mut nodes: Vec<u32> = count.into_iter().filter(|&(_, n)| n == 1).flat_map(|(f, _)| f).collect();
    nodes.sort_unstable();
    nodes.dedup();
    nodes
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
        let (k, _) = left.iter().enumerate().min_by(|a, b| dist2(pos[*a.1], last).total_cmp(&dist2(pos[*b.1], last))).unwrap_or((0, &0));
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
    let t0 = Instant::now();
    material.validate()?;
    opts.validate()?;
    if mesh.corners > MAX_IMPORT_VERTICES {
        return Err(FemError::Mesh(format!(
            "{} corner vertices is over the limit of {MAX_IMPORT_VERTICES}: coarsen the mesh (e.g. a larger Gmsh characteristic length)",
            mesh.corners
        )));
    }
    if mesh.tets.is_empty() {
        return Err(FemError::Mesh("the mesh has no tetrahedra".into()));
    }
    let modes = analyse(mesh, material, opts, progress)?;
    progress("strike", 0.0);
    let points = surface_strike_points(mesh, opts.strike_points)?;
    let gains = strike_gains(mesh, &modes, &points);
    let (lo, hi) = mesh.bounds();
    let ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let mut axes = [0usize, 1, 2];
    axes.sort_by(|&a, &b| ext[b].total_cmp(&ext[a]));
    let (u, v) = (axes[0], axes[1]);
    let size = ext[u].max(1e-9);
    let bank = Bank {
        schema_version: crate::SCHEMA_VERSION,
        id: id.to_string(),
        name: name.to_string(),
        description: format!(
            "Imported mesh {source} ({:.4} x {:.4} x {:.4} m bounding box), computed by FEM for E = {:.4e} Pa, rho = {} kg/m^3, nu = {}. Strike points: boundary corner nodes, farthest-point sampled; xy = projection on the two longest box axes.",
            ext[0], ext[1], ext[2], material.young, material.density, material.poisson
        ),
        provenance: format!(
            "FEM (struck-presets fem) of {source}: {} 10-node tetrahedra, {} nodes ({} corner vertices), {} DOFs; block shift-invert Lanczos on a faer sparse Cholesky; 6 rigid modes removed; built {}",
            mesh.tets.len(),
            mesh.nodes.len(),
            mesh.corners,
            modes.dofs,
            today()
        ),
        reference: BankReference {
            specific_modulus: material.specific_modulus(),
            poisson: material.poisson,
            density: material.density,
            dimensions_m: ext.to_vec(),
            size_m: size,
        },
        lambdas: modes.lambdas.clone(),
        points: points
            .iter()
            .enumerate()
            .map(|(i, p)| StrikePoint {
                label: format!("surface {i}"),
                xy: [((p[u] - lo[u]) / ext[u].max(1e-12)).clamp(0.0, 1.0) as f32, ((p[v] - lo[v]) / ext[v].max(1e-12)).clamp(0.0, 1.0) as f32],
                position_m: [p[0] as f32, p[1] as f32, p[2] as f32],
            })
            .collect(),
        gains: gains.iter().map(|r| r.iter().map(|&g| g as f32).collect()).collect(),
        mode_labels: modes.frequencies_hz().iter().map(|f| format!("{f:.1} Hz")).collect(),
    };
    finish_bank(bank, mesh, &modes, t0, progress)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::{mesh_shape, Shape};

    #[test]
    fn a_meshed_bar_imported_as_a_mesh_gives_the_same_modes() {
        let shape = Shape::Bar { length: 0.3, width: 0.02, thickness: 0.008 };
        let mesh = mesh_shape(&shape, 10).unwrap();
        let mat = Material { young: 2.0e11, density: 7850.0, poisson: 0.3 };
        let opts = BuildOptions { max_modes: 8, max_freq_hz: None, resolution: 10, strike_points: 24 };
        let (bank, report) = build_bank_from_mesh("imported-bar", "Imported bar", "test", &mesh, &mat, &opts, &|_, _| {}).unwrap();
        assert_eq!(bank.num_points(), 24);
        assert_eq!(report.rigid_eigenvalues.len(), 6);
        let (direct, _) = crate::fem::build_bank("bar", "Bar", &shape, &mat, &opts, &|_, _| {}).unwrap();
        for (a, b) in bank.lambdas.iter().zip(&direct.lambdas) {
            assert!((a / b - 1.0).abs() < 1e-9, "{a} vs {b}");
        }
        // Points are spread: no two closer than a tenth of the mean spacing.
        let p: Vec<[f32; 3]> = bank.points.iter().map(|s| s.position_m).collect();
        let d = |a: [f32; 3], b: [f32; 3]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        let min = (0..p.len()).flat_map(|i| (i + 1..p.len()).map(move |j| (i, j))).map(|(i, j)| d(p[i], p[j])).fold(f32::MAX, f32::min);
        assert!(min > 0.003, "closest strike points {min} m apart");
        // Every mode is heard somewhere on the surface.
        for m in 0..bank.num_modes() {
            assert!(bank.gains.iter().any(|r| r[m].abs() > 1e-3), "mode {m} silent everywhere");
        }
    }
}
