//! Reader for Gmsh `.msh` version 2.2 ASCII tetrahedral meshes.
//!
//! Format: Gmsh reference manual §9.1 (MSH file format version 2). Only volume elements are
//! used: type 4 (4-node tetrahedron) and type 11 (10-node tetrahedron; its corners are kept
//! and the mid-edge nodes rebuilt as edge midpoints, i.e. straight-sided elements). Other
//! element types (points, lines, triangles on the boundary) are skipped.

use std::collections::HashMap;

use super::mesh::TetMesh;
use super::FemError;

/// Most nodes accepted (guards against absurd files; the solver's practical limit is lower).
pub const MAX_GMSH_NODES: usize = 2_000_000;

fn err(line: usize, reason: impl Into<String>) -> FemError {
    FemError::MeshFile { line, reason: reason.into() }
}

/// Parses a Gmsh 2.2 ASCII mesh into a 10-node [`TetMesh`] (coordinates taken as metres).
///
/// # Errors
/// [`FemError::MeshFile`] with the line number for a missing section, another format
/// version, a binary file, malformed numbers, unknown node ids or no tetrahedra;
/// [`FemError::Mesh`] for degenerate elements.
pub fn read_gmsh(text: &str) -> Result<TetMesh, FemError> {
    let lines: Vec<&str> = text.lines().collect();
    let mut i = 0;
    let mut version_ok = false;
    let mut ids: HashMap<u64, u32> = HashMap::new();
    let mut nodes: Vec<[f64; 3]> = Vec::new();
    let mut tets: Vec<[u64; 4]> = Vec::new();
    while i < lines.len() {
        let l = lines[i].trim();
        match l {
            "$MeshFormat" => {
                let v = lines.get(i + 1).ok_or_else(|| err(i + 2, "missing format line"))?;
                let f: Vec<&str> = v.split_whitespace().collect();
                if f.first().is_none_or(|v| !v.starts_with("2.")) {
                    return Err(err(
                        i + 2,
                        format!("format version {:?} is not supported; export as Gmsh 2.2 ASCII (gmsh -format msh22)", f.first()),
                    ));
                }
                if f.get(1) != Some(&"0") {
                    return Err(err(i + 2, "binary .msh files are not supported; export as ASCII"));
                }
                version_ok = true;
                i += 2;
            }
            "$Nodes" => {
                let n: usize = lines
                    .get(i + 1)
                    .and_then(|s| s.trim().parse().ok())
                    .ok_or_else(|| err(i + 2, "expected the number of nodes"))?;
                if n > MAX_GMSH_NODES {
                    return Err(err(i + 2, format!("{n} nodes is more than the {MAX_GMSH_NODES} supported; coarsen the mesh")));
                }
                for k in 0..n {
                    let ln = i + 2 + k;
                    let s = lines.get(ln).ok_or_else(|| err(ln + 1, "file ends inside $Nodes"))?;
                    let f: Vec<&str> = s.split_whitespace().collect();
                    if f.len() < 4 {
                        return Err(err(ln + 1, "a node line needs: id x y z"));
                    }
                    let id: u64 = f[0].parse().map_err(|_| err(ln + 1, "bad node id"))?;
                    let mut p = [0.0f64; 3];
                    for c in 0..3 {
                        p[c] = f[1 + c].parse().map_err(|_| err(ln + 1, "bad coordinate"))?;
                        if !p[c].is_finite() {
                            return Err(err(ln + 1, "coordinate is not finite"));
                        }
                    }
                    ids.insert(id, nodes.len() as u32);
                    nodes.push(p);
                }
                i += 2 + n;
            }
            "$Elements" => {
                let n: usize = lines
                    .get(i + 1)
                    .and_then(|s| s.trim().parse().ok())
                    .ok_or_else(|| err(i + 2, "expected the number of elements"))?;
                for k in 0..n {
                    let ln = i + 2 + k;
                    let s = lines.get(ln).ok_or_else(|| err(ln + 1, "file ends inside $Elements"))?;
                    let f: Vec<u64> = s
                        .split_whitespace()
                        .map(|v| v.parse::<u64>())
                        .collect::<Result<_, _>>()
                        .map_err(|_| err(ln + 1, "bad integer in element line"))?;
                    if f.len() < 3 {
                        return Err(err(ln + 1, "an element line needs: id type ntags ..."));
                    }
                    let (ty, ntags) = (f[1], f[2] as usize);
                    let want = match ty {
                        4 => 4,
                        11 => 10,
                        _ => continue,
                    };
                    let start = 3 + ntags;
                    if f.len() < start + want {
                        return Err(err(ln + 1, "element line has too few node ids"));
                    }
                    tets.push([f[start], f[start + 1], f[start + 2], f[start + 3]]);
                }
                i += 2 + n;
            }
            _ => i += 1,
        }
    }
    if !version_ok {
        return Err(err(0, "no $MeshFormat section; this is not a Gmsh .msh file"));
    }
    if tets.is_empty() {
        return Err(err(0, "no tetrahedra (element type 4 or 11); mesh the volume (gmsh -3), not only the surface"));
    }
    // Keep only nodes used by tetrahedra (surface-only nodes would be free and singular).
    let mut used = vec![u32::MAX; nodes.len()];
    let mut corners = Vec::new();
    let mut t4 = Vec::with_capacity(tets.len());
    for t in &tets {
        let mut out = [0u32; 4];
        for c in 0..4 {
            let idx = *ids
                .get(&t[c])
                .ok_or_else(|| err(0, format!("element refers to node {} which is not in $Nodes", t[c])))? as usize;
            if used[idx] == u32::MAX {
                used[idx] = corners.len() as u32;
                corners.push(nodes[idx]);
            }
            out[c] = used[idx];
        }
        t4.push(out);
    }
    TetMesh::from_linear(corners, &t4)
}
