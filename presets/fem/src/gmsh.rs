//! Reader for Gmsh `.msh` ASCII tetrahedral meshes, format versions 2.2 and 4.1.
//!
//! Formats: Gmsh reference manual §10 "Gmsh file formats" — "MSH file format" (version 4.1,
//! the default since Gmsh 4.1) and "Legacy formats: MSH file format version 2" (2.2). The
//! version is read from `$MeshFormat`; binary files (file-type 1) are refused. Only volume
//! elements are used: type 4 (4-node tetrahedron) and type 11 (10-node tetrahedron; its
//! corners are kept and the mid-edge nodes rebuilt as edge midpoints, i.e. straight-sided
//! elements). Other element types (points, lines, boundary triangles) are skipped, and so
//! are sections other than `$MeshFormat`, `$Nodes` and `$Elements` (`$Entities`,
//! `$PhysicalNames`, …).
//!
//! MSH 4.1 layout read here:
//! ```text
//! $Nodes
//! numEntityBlocks numNodes minNodeTag maxNodeTag
//! entityDim entityTag parametric numNodesInBlock   (per block)
//! nodeTag                                          (numNodesInBlock lines)
//! x y z [u [v [w]]]                                (numNodesInBlock lines)
//! $EndNodes
//! $Elements
//! numEntityBlocks numElements minElementTag maxElementTag
//! entityDim entityTag elementType numElementsInBlock
//! elementTag nodeTag …                             (numElementsInBlock lines)
//! $EndElements
//! ```

use std::collections::HashMap;

use super::mesh::TetMesh;
use super::FemError;

/// Most nodes accepted (guards against absurd files; the solver's practical limit is lower).
pub const MAX_GMSH_NODES: usize = 2_000_000;
/// Most elements (of any type) accepted.
pub const MAX_GMSH_ELEMENTS: usize = 10_000_000;

fn err(line: usize, reason: impl Into<String>) -> FemError {
    FemError::MeshFile { line, reason: reason.into() }
}

/// The file's lines with 1-based numbers and a cursor.
struct Lines<'a> {
    lines: Vec<&'a str>,
    i: usize,
}

impl<'a> Lines<'a> {
    /// Line number (1-based) of the line `next` would return.
    fn number(&self) -> usize {
        self.i + 1
    }

    /// The next line, trimmed, or an error naming the section the file ended in.
    fn next(&mut self, section: &str) -> Result<(usize, &'a str), FemError> {
        let n = self.i + 1;
        let l = self.lines.get(self.i).ok_or_else(|| err(n, format!("the file ends inside {section} (truncated?)")))?;
        self.i += 1;
        Ok((n, l.trim()))
    }

    /// Requires the next line to be `end` (e.g. `$EndNodes`).
    fn expect_end(&mut self, end: &str, section: &str) -> Result<(), FemError> {
        let (n, l) = self.next(section)?;
        if l != end {
            return Err(err(
                n,
                format!("expected {end} but found {:?}; the counts in {section} do not match its contents", short(l)),
            ));
        }
        Ok(())
    }
}

fn short(s: &str) -> String {
    if s.len() > 40 {
        format!("{}…", s.chars().take(40).collect::<String>())
    } else {
        s.to_string()
    }
}

/// Parses whitespace-separated unsigned integers.
fn ints(line: usize, s: &str, what: &str) -> Result<Vec<u64>, FemError> {
    s.split_whitespace()
        .map(|v| {
            v.parse::<u64>().map_err(|_| err(line, format!("{what}: {:?} is not a non-negative integer", short(v))))
        })
        .collect()
}

fn coords(line: usize, f: &[&str]) -> Result<[f64; 3], FemError> {
    let mut p = [0.0f64; 3];
    for c in 0..3 {
        p[c] = f[c].parse().map_err(|_| err(line, format!("bad coordinate {:?}", short(f[c]))))?;
        if !p[c].is_finite() {
            return Err(err(line, "coordinate is not finite"));
        }
    }
    Ok(p)
}

/// What the version-specific parsers collect.
#[derive(Default)]
struct Raw {
    ids: HashMap<u64, u32>,
    nodes: Vec<[f64; 3]>,
    /// Tetrahedron corner tags and the line each came from.
    tets: Vec<([u64; 4], usize)>,
}

impl Raw {
    fn add_node(&mut self, line: usize, tag: u64, p: [f64; 3]) -> Result<(), FemError> {
        if self.ids.insert(tag, self.nodes.len() as u32).is_some() {
            return Err(err(line, format!("node {tag} is defined twice")));
        }
        self.nodes.push(p);
        Ok(())
    }
}

/// Parses a Gmsh 2.2 or 4.1 ASCII mesh (detected from `$MeshFormat`) into a 10-node
/// [`TetMesh`] (coordinates taken as metres).
///
/// # Errors
/// [`FemError::MeshFile`] with the line number for a missing section, another format
/// version, a binary file, malformed numbers, counts that do not match the contents, a
/// truncated file, unknown node tags or no tetrahedra; [`FemError::Mesh`] for degenerate
/// elements.
pub fn read_gmsh(text: &str) -> Result<TetMesh, FemError> {
    let mut l = Lines { lines: text.lines().collect(), i: 0 };
    let mut version: Option<u32> = None;
    let mut raw = Raw::default();
    let mut seen_nodes = false;
    while l.i < l.lines.len() {
        let (n, line) = l.next("the file")?;
        match line {
            "$MeshFormat" => {
                let (vn, v) = l.next("$MeshFormat")?;
                let f: Vec<&str> = v.split_whitespace().collect();
                if f.len() < 3 {
                    return Err(err(vn, "the format line needs: version file-type data-size"));
                }
                if f[1] != "0" {
                    return Err(err(vn, "binary .msh files are not supported; export as ASCII (gmsh -save_all -format msh41, Mesh.Binary = 0)"));
                }
                version = Some(match f[0] {
                    "2.2" | "2.1" | "2" | "2.0" => 2,
                    "4.1" => 4,
                    other => {
                        return Err(err(
                            vn,
                            format!("format version {other} is not supported; export as Gmsh 4.1 or 2.2 ASCII (gmsh -format msh41 or msh22)"),
                        ))
                    }
                });
                l.expect_end("$EndMeshFormat", "$MeshFormat")?;
            }
            "$Nodes" | "$Elements" => {
                let v = version
                    .ok_or_else(|| err(n, format!("{line} before $MeshFormat; this is not a Gmsh .msh file")))?;
                match (line, v) {
                    ("$Nodes", 2) => nodes_v2(&mut l, &mut raw)?,
                    ("$Nodes", _) => nodes_v4(&mut l, &mut raw)?,
                    (_, 2) => elements_v2(&mut l, &mut raw)?,
                    _ => elements_v4(&mut l, &mut raw)?,
                }
                seen_nodes |= line == "$Nodes";
            }
            _ => {}
        }
    }
    if version.is_none() {
        return Err(err(0, "no $MeshFormat section; this is not a Gmsh .msh file"));
    }
    if !seen_nodes {
        return Err(err(0, "no $Nodes section"));
    }
    if raw.tets.is_empty() {
        return Err(err(0, "no tetrahedra (element type 4 or 11); mesh the volume (gmsh -3), not only the surface"));
    }
    // Keep only nodes used by tetrahedra (surface-only nodes would be free and singular).
    let mut used = vec![u32::MAX; raw.nodes.len()];
    let mut corners = Vec::new();
    let mut t4 = Vec::with_capacity(raw.tets.len());
    for (t, line) in &raw.tets {
        let mut out = [0u32; 4];
        for c in 0..4 {
            let idx = *raw
                .ids
                .get(&t[c])
                .ok_or_else(|| err(*line, format!("the element refers to node {} which is not in $Nodes", t[c])))?
                as usize;
            if used[idx] == u32::MAX {
                used[idx] = corners.len() as u32;
                corners.push(raw.nodes[idx]);
            }
            out[c] = used[idx];
        }
        if (0..4).any(|a| (a + 1..4).any(|b| out[a] == out[b])) {
            return Err(err(*line, "the tetrahedron repeats a node"));
        }
        t4.push(out);
    }
    TetMesh::from_linear(corners, &t4)
}

fn count_line(l: &mut Lines, section: &str, what: &str) -> Result<(usize, Vec<u64>), FemError> {
    let (n, s) = l.next(section)?;
    Ok((n, ints(n, s, what)?))
}

/// MSH 2.2 `$Nodes`: a count, then `id x y z` lines.
fn nodes_v2(l: &mut Lines, raw: &mut Raw) -> Result<(), FemError> {
    let (cn, c) = count_line(l, "$Nodes", "the number of nodes")?;
    let n = *c.first().ok_or_else(|| err(cn, "expected the number of nodes"))? as usize;
    if n > MAX_GMSH_NODES {
        return Err(err(cn, format!("{n} nodes is more than the {MAX_GMSH_NODES} supported; coarsen the mesh")));
    }
    for _ in 0..n {
        let (ln, s) = l.next("$Nodes")?;
        let f: Vec<&str> = s.split_whitespace().collect();
        if f.len() < 4 || f[0].starts_with('$') {
            return Err(err(
                ln,
                format!("a node line needs: id x y z (found {:?}; is the node count right?)", short(s)),
            ));
        }
        let id: u64 = f[0].parse().map_err(|_| err(ln, "bad node id"))?;
        raw.add_node(ln, id, coords(ln, &f[1..4])?)?;
    }
    l.expect_end("$EndNodes", "$Nodes")
}

/// MSH 2.2 `$Elements`: a count, then `id type ntags tags… nodes…` lines.
fn elements_v2(l: &mut Lines, raw: &mut Raw) -> Result<(), FemError> {
    let (cn, c) = count_line(l, "$Elements", "the number of elements")?;
    let n = *c.first().ok_or_else(|| err(cn, "expected the number of elements"))? as usize;
    if n > MAX_GMSH_ELEMENTS {
        return Err(err(cn, format!("{n} elements is more than the {MAX_GMSH_ELEMENTS} supported; coarsen the mesh")));
    }
    for _ in 0..n {
        let (ln, s) = l.next("$Elements")?;
        if s.starts_with('$') {
            return Err(err(ln, format!("found {:?} inside $Elements; is the element count right?", short(s))));
        }
        let f = ints(ln, s, "element line")?;
        if f.len() < 3 {
            return Err(err(ln, "an element line needs: id type ntags ..."));
        }
        let (ty, ntags) = (f[1], f[2] as usize);
        let want = match ty {
            4 => 4,
            11 => 10,
            _ => continue,
        };
        let start = 3usize.saturating_add(ntags);
        if f.len() < start.saturating_add(want) {
            return Err(err(ln, format!("the element line has too few node ids (type {ty} needs {want})")));
        }
        raw.tets.push(([f[start], f[start + 1], f[start + 2], f[start + 3]], ln));
    }
    l.expect_end("$EndElements", "$Elements")
}

/// MSH 4.1 `$Nodes`: entity blocks, each with its node tags first, then the coordinates.
fn nodes_v4(l: &mut Lines, raw: &mut Raw) -> Result<(), FemError> {
    let (hn, h) = count_line(l, "$Nodes", "the $Nodes header")?;
    if h.len() < 4 {
        return Err(err(hn, "the $Nodes header needs: numEntityBlocks numNodes minNodeTag maxNodeTag"));
    }
    let (blocks, total) = (h[0] as usize, h[1] as usize);
    if total > MAX_GMSH_NODES {
        return Err(err(hn, format!("{total} nodes is more than the {MAX_GMSH_NODES} supported; coarsen the mesh")));
    }
    if blocks > total.max(1) {
        return Err(err(hn, format!("{blocks} entity blocks for {total} nodes; the header is inconsistent")));
    }
    let mut seen = 0usize;
    let mut tags = Vec::new();
    for _ in 0..blocks {
        let (bn, b) = count_line(l, "$Nodes", "an entity block header")?;
        if b.len() < 4 {
            return Err(err(bn, "an entity block header needs: entityDim entityTag parametric numNodesInBlock"));
        }
        let (dim, parametric, count) = (b[0], b[2], b[3] as usize);
        if dim > 3 || parametric > 1 {
            return Err(err(bn, "bad entity block header (entityDim 0..3, parametric 0 or 1)"));
        }
        seen = seen.saturating_add(count);
        if seen > total {
            return Err(err(bn, format!("the blocks hold more nodes than the {total} in the $Nodes header")));
        }
        tags.clear();
        for _ in 0..count {
            let (tn, s) = l.next("$Nodes")?;
            let t = ints(tn, s, "node tag")?;
            if t.len() != 1 {
                return Err(err(
                    tn,
                    format!("expected one node tag, found {:?} (are the block counts right?)", short(s)),
                ));
            }
            tags.push((t[0], tn));
        }
        let want = 3 + if parametric == 1 { dim as usize } else { 0 };
        for &(tag, tn) in &tags {
            let (ln, s) = l.next("$Nodes")?;
            let f: Vec<&str> = s.split_whitespace().collect();
            if f.len() < want.max(3) || f.len() > want.max(3) {
                return Err(err(
                    ln,
                    format!("expected {want} coordinates for node {tag} (tag on line {tn}), found {:?}", short(s)),
                ));
            }
            raw.add_node(ln, tag, coords(ln, &f[..3])?)?;
        }
    }
    if seen != total {
        return Err(err(l.number(), format!("the $Nodes header says {total} nodes but the blocks hold {seen}")));
    }
    l.expect_end("$EndNodes", "$Nodes")
}

/// MSH 4.1 `$Elements`: entity blocks of one element type each.
fn elements_v4(l: &mut Lines, raw: &mut Raw) -> Result<(), FemError> {
    let (hn, h) = count_line(l, "$Elements", "the $Elements header")?;
    if h.len() < 4 {
        return Err(err(hn, "the $Elements header needs: numEntityBlocks numElements minElementTag maxElementTag"));
    }
    let (blocks, total) = (h[0] as usize, h[1] as usize);
    if total > MAX_GMSH_ELEMENTS {
        return Err(err(
            hn,
            format!("{total} elements is more than the {MAX_GMSH_ELEMENTS} supported; coarsen the mesh"),
        ));
    }
    if blocks > total.max(1) {
        return Err(err(hn, format!("{blocks} entity blocks for {total} elements; the header is inconsistent")));
    }
    let mut seen = 0usize;
    for _ in 0..blocks {
        let (bn, b) = count_line(l, "$Elements", "an entity block header")?;
        if b.len() < 4 {
            return Err(err(bn, "an entity block header needs: entityDim entityTag elementType numElementsInBlock"));
        }
        let (ty, count) = (b[2], b[3] as usize);
        seen = seen.saturating_add(count);
        if seen > total {
            return Err(err(bn, format!("the blocks hold more elements than the {total} in the $Elements header")));
        }
        let want = match ty {
            4 => Some(4),
            11 => Some(10),
            _ => None,
        };
        for _ in 0..count {
            let (ln, s) = l.next("$Elements")?;
            if s.starts_with('$') {
                return Err(err(ln, format!("found {:?} inside $Elements; are the block counts right?", short(s))));
            }
            let Some(want) = want else { continue };
            let f = ints(ln, s, "element line")?;
            if f.len() != 1 + want {
                return Err(err(
                    ln,
                    format!("a type-{ty} element line needs its tag and {want} node tags, found {} numbers", f.len()),
                ));
            }
            raw.tets.push(([f[1], f[2], f[3], f[4]], ln));
        }
    }
    if seen != total {
        return Err(err(l.number(), format!("the $Elements header says {total} elements but the blocks hold {seen}")));
    }
    l.expect_end("$EndElements", "$Elements")
}
