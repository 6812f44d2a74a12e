//! Isotropic remeshing of an open triangle surface to a target edge length (Botsch & Kobbelt
//! 2004, "A remeshing approach to multiresolution modeling", §4): split edges longer than
//! 4/3·h, collapse edges shorter than 4/5·h, flip edges towards Delaunay, smooth tangentially
//! and project back onto the input; a few rounds. Used for the side of a thin wall
//! ([`super::shell`]), so a CAD export's facets (long slivers, fans, far more triangles than
//! the budget) become elements of even size.
//!
//! Boundary edges (used by one triangle) and creases (adjacent normals more than
//! [`CREASE_DEG`] apart, such as a cup's sharp bottom edge) are kept: a vertex on one moves only
//! along it (collapses into a neighbour on the same line, no smoothing), a vertex where they
//! meet, branch or turn by more than a crease (a corner) never moves. Every collapse, flip and
//! smoothing step is refused if it would turn a triangle by more than [`MAX_TURN_DEG`], so the
//! surface never folds.

use std::collections::{HashMap, HashSet};

use super::geom::{cross, dot, norm, sub};
use super::surface::{TriGrid, TriSurface};

/// Adjacent triangles whose normals are more than this apart meet at a crease.
pub const CREASE_DEG: f64 = 35.0;
/// Most a collapse, flip or smoothing step may turn a triangle's normal.
pub const MAX_TURN_DEG: f64 = 30.0;
/// Rounds of split, collapse, flip and smooth.
pub const ROUNDS: usize = 5;
/// No split round starts on more triangles than this (a file of long slivers would otherwise
/// grow by its length over the target edge per sliver).
pub const MAX_TRIANGLES: usize = 4_000_000;

type Edge = (u32, u32);

fn key(a: u32, b: u32) -> Edge {
    (a.min(b), a.max(b))
}

fn unit_normal(v: &[[f64; 3]], t: [u32; 3]) -> Option<[f64; 3]> {
    let n = cross(sub(v[t[1] as usize], v[t[0] as usize]), sub(v[t[2] as usize], v[t[0] as usize]));
    let l = norm(n);
    (l > 0.0).then(|| n.map(|x| x / l))
}

fn len(v: &[[f64; 3]], a: u32, b: u32) -> f64 {
    norm(sub(v[a as usize], v[b as usize]))
}

/// Boundary and crease edges, and each vertex's level: 0 free, 1 on one such line (two of
/// its edges), 2 a corner (any other count).
fn features(v: &[[f64; 3]], tris: &[[u32; 3]]) -> (HashSet<Edge>, Vec<u8>) {
    let mut uses: HashMap<Edge, Vec<usize>> = HashMap::with_capacity(tris.len() * 2);
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            uses.entry(key(tri[k], tri[(k + 1) % 3])).or_default().push(t);
        }
    }
    let cos_crease = CREASE_DEG.to_radians().cos();
    let mut lines = HashSet::new();
    for (e, ts) in &uses {
        let feature = match ts.as_slice() {
            [a, b] => match (unit_normal(v, tris[*a]), unit_normal(v, tris[*b])) {
                (Some(na), Some(nb)) => dot(na, nb) < cos_crease,
                _ => true,
            },
            _ => true,
        };
        if feature {
            lines.insert(*e);
        }
    }
    let mut ends: Vec<Vec<u32>> = vec![Vec::new(); v.len()];
    for &(a, b) in &lines {
        ends[a as usize].push(b);
        ends[b as usize].push(a);
    }
    // On one line, a vertex where the line turns by more than a crease (a plate's corner) is
    // a corner too.
    let level = (0..v.len())
        .map(|x| match ends[x].as_slice() {
            [] => 0,
            [p, q] => {
                let (u, w) = (sub(v[x], v[*p as usize]), sub(v[*q as usize], v[x]));
                let c = dot(u, w) / (norm(u) * norm(w)).max(f64::MIN_POSITIVE);
                if c > cos_crease {
                    1
                } else {
                    2
                }
            }
            _ => 2,
        })
        .collect();
    (lines, level)
}

/// The creases of a surface: edges between two triangles whose normals are more than
/// [`CREASE_DEG`] apart (boundary edges are not creases).
pub(crate) fn crease_edges(v: &[[f64; 3]], tris: &[[u32; 3]]) -> Vec<Edge> {
    let (lines, _) = features(v, tris);
    let mut uses: HashMap<Edge, u32> = HashMap::new();
    for tri in tris {
        for k in 0..3 {
            *uses.entry(key(tri[k], tri[(k + 1) % 3])).or_default() += 1;
        }
    }
    let mut out: Vec<Edge> = lines.into_iter().filter(|e| uses.get(e) == Some(&2)).collect();
    out.sort_unstable();
    out
}

/// Splits every edge longer than `h` at its midpoint with red (three edges) and green (one or
/// two) templates that keep each triangle's orientation; returns the number of edges split.
pub(crate) fn split_long(v: &mut Vec<[f64; 3]>, tris: &mut Vec<[u32; 3]>, h: f64) -> usize {
    let mut mid: HashMap<Edge, u32> = HashMap::new();
    for t in tris.iter() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if len(v, a, b) > h && !mid.contains_key(&key(a, b)) {
                let (pa, pb) = (v[a as usize], v[b as usize]);
                v.push(std::array::from_fn(|i| 0.5 * (pa[i] + pb[i])));
                mid.insert(key(a, b), (v.len() - 1) as u32);
            }
        }
    }
    if mid.is_empty() {
        return 0;
    }
    let mut out = Vec::with_capacity(tris.len() * 2);
    for t in tris.iter() {
        let m: [Option<u32>; 3] = std::array::from_fn(|k| mid.get(&key(t[k], t[(k + 1) % 3])).copied());
        match m.iter().filter(|x| x.is_some()).count() {
            0 => out.push(*t),
            3 => {
                let [a, b, c] = *t;
                let [m0, m1, m2] = m.map(|x| x.unwrap_or(0));
                out.extend([[a, m0, m2], [m0, b, m1], [m2, m1, c], [m0, m1, m2]]);
            }
            1 => {
                let k = (0..3).find(|&k| m[k].is_some()).unwrap_or(0);
                let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                let m0 = m[k].unwrap_or(0);
                out.extend([[a, m0, c], [m0, b, c]]);
            }
            _ => {
                // The edge left whole is (c, a); (a, b) and (b, c) are split.
                let k = (0..3).find(|&k| m[k].is_none()).unwrap_or(0);
                let (c, a, b) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                let (m0, m1) = (m[(k + 1) % 3].unwrap_or(0), m[(k + 2) % 3].unwrap_or(0));
                out.push([m0, b, m1]);
                if len(v, a, m1) <= len(v, m0, c) {
                    out.extend([[a, m0, m1], [a, m1, c]]);
                } else {
                    out.extend([[a, m0, c], [m0, m1, c]]);
                }
            }
        }
    }
    *tris = out;
    mid.len()
}

/// Vertex-to-triangle lists and the state of a round of collapses.
struct Collapses {
    around: Vec<Vec<u32>>,
    dead: Vec<bool>,
    touched: Vec<bool>,
}

impl Collapses {
    fn new(nv: usize, tris: &[[u32; 3]]) -> Collapses {
        let mut around: Vec<Vec<u32>> = vec![Vec::new(); nv];
        for (t, tri) in tris.iter().enumerate() {
            for &x in tri {
                around[x as usize].push(t as u32);
            }
        }
        Collapses { around, dead: vec![false; tris.len()], touched: vec![false; nv] }
    }

    /// Moves vertex `x` onto its neighbour `y` (their shared triangles go) if that keeps the
    /// surface a manifold (link condition), turns no triangle by more than [`MAX_TURN_DEG`],
    /// makes no sliver and no edge of `hi` or longer; returns whether it did.
    fn try_collapse(&mut self, v: &[[f64; 3]], tris: &mut [[u32; 3]], x: u32, y: u32, hi: f64) -> bool {
        if self.touched[x as usize] || self.touched[y as usize] {
            return false;
        }
        let dead = &self.dead;
        let tx: Vec<u32> = self.around[x as usize].iter().copied().filter(|&t| !dead[t as usize]).collect();
        let shared: Vec<u32> = tx.iter().copied().filter(|&t| tris[t as usize].contains(&y)).collect();
        if shared.is_empty() || shared.len() > 2 {
            return false;
        }
        // Link condition: x and y share no neighbour but the shared triangles' third corners.
        let ring = |z: u32| -> HashSet<u32> {
            self.around[z as usize]
                .iter()
                .filter(|&&t| !dead[t as usize])
                .flat_map(|&t| tris[t as usize])
                .filter(|&w| w != z)
                .collect()
        };
        let (rx, ry) = (ring(x), ring(y));
        let opposite: HashSet<u32> =
            shared.iter().flat_map(|&t| tris[t as usize]).filter(|&w| w != x && w != y).collect();
        if rx.intersection(&ry).any(|w| !opposite.contains(w)) {
            return false;
        }
        let cos_turn = MAX_TURN_DEG.to_radians().cos();
        let moved: Vec<u32> = tx.iter().copied().filter(|t| !shared.contains(t)).collect();
        let ok = moved.iter().all(|&t| {
            let old = tris[t as usize];
            let new = old.map(|w| if w == x { y } else { w });
            match (unit_normal(v, old), unit_normal(v, new)) {
                (Some(no), Some(nn)) => {
                    dot(no, nn) > cos_turn && new.iter().all(|&w| w == y || len(v, y, w) < hi) && quality(v, new) > 0.05
                }
                _ => false,
            }
        });
        if !ok {
            return false;
        }
        for &t in &shared {
            self.dead[t as usize] = true;
        }
        for &t in &moved {
            for w in tris[t as usize].iter_mut() {
                if *w == x {
                    *w = y;
                }
            }
        }
        self.around[y as usize].extend(moved);
        for z in rx.iter().chain(ry.iter()).chain([&x, &y]) {
            self.touched[*z as usize] = true;
        }
        true
    }

    /// Drops the collapsed triangles from `tris`.
    fn finish(self, tris: &mut Vec<[u32; 3]>) {
        let mut k = 0;
        tris.retain(|_| {
            k += 1;
            !self.dead[k - 1]
        });
    }
}

/// Collapses edges shorter than `lo` (shortest first) where the result keeps the surface's
/// shape; returns the number collapsed. A free vertex may go onto any neighbour, one on a
/// line only along it onto another vertex of a line, a corner never. Dead vertices stay in `v`
/// unreferenced.
fn collapse_short(v: &[[f64; 3]], tris: &mut Vec<[u32; 3]>, lo: f64, hi: f64) -> usize {
    let (lines, level) = features(v, tris);
    let mut edges: Vec<(f64, Edge)> = Vec::new();
    let mut seen = HashSet::new();
    for tri in tris.iter() {
        for k in 0..3 {
            let e = key(tri[k], tri[(k + 1) % 3]);
            let l = len(v, e.0, e.1);
            if l < lo && seen.insert(e) {
                edges.push((l, e));
            }
        }
    }
    edges.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut c = Collapses::new(v.len(), tris);
    let mut done = 0;
    for &(_, (a, b)) in &edges {
        for (x, y) in [(a, b), (b, a)] {
            let (lx, ly) = (level[x as usize], level[y as usize]);
            if !(lx == 0 || (lx == 1 && ly >= 1 && lines.contains(&key(x, y)))) {
                continue;
            }
            if c.try_collapse(v, tris, x, y, hi) {
                done += 1;
                break;
            }
        }
    }
    c.finish(tris);
    done
}

/// The point of the segment a–b closest to `p`.
fn closest_on_segment(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let ab = sub(b, a);
    let t = (dot(sub(p, a), ab) / dot(ab, ab).max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
    [a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2]]
}

/// Distance from `p` to the segment a–b.
fn to_segment(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    norm(sub(p, closest_on_segment(p, a, b)))
}

/// Collapses every free vertex closer than `clearance` to a crease (not a boundary) onto the
/// crease vertex it neighbours, or where no collapse keeps the surface sound moves it away to
/// that distance, so no element is squeezed between a crease and a vertex beside it when the
/// surface is offset by `clearance` (a wall's thickness: the inside of a cup's bottom edge).
/// Returns the number collapsed or moved.
pub(crate) fn clear_creases(v: &mut [[f64; 3]], tris: &mut Vec<[u32; 3]>, clearance: f64) -> usize {
    let mut total = 0;
    for _ in 0..6 {
        let (_, level) = features(v, tris);
        let creases = crease_edges(v, tris);
        let mut on_crease: Vec<Vec<u32>> = vec![Vec::new(); v.len()];
        for &(a, b) in &creases {
            on_crease[a as usize].push(b);
            on_crease[b as usize].push(a);
        }
        let mut c = Collapses::new(v.len(), tris);
        let mut done = 0;
        for x in 0..v.len() as u32 {
            if level[x as usize] != 0 || c.around[x as usize].is_empty() {
                continue;
            }
            let ring: HashSet<u32> =
                c.around[x as usize].iter().flat_map(|&t| tris[t as usize]).filter(|&w| w != x).collect();
            let mut near: Vec<(f64, u32)> = ring
                .iter()
                .filter(|&&y| !on_crease[y as usize].is_empty())
                .map(|&y| {
                    let d = on_crease[y as usize]
                        .iter()
                        .map(|&z| to_segment(v[x as usize], v[y as usize], v[z as usize]))
                        .fold(f64::INFINITY, f64::min);
                    (d, y)
                })
                .filter(|&(d, _)| d < clearance)
                .collect();
            near.sort_by(|a, b| len(v, x, a.1).total_cmp(&len(v, x, b.1)));
            if near.iter().any(|&(_, y)| c.try_collapse(v, tris, x, y, f64::INFINITY)) {
                done += 1;
            } else if let Some(&(_, y)) = near.first() {
                // No collapse keeps the surface sound: move the vertex straight away from the
                // crease to the clearance instead, if no triangle around it turns or thins.
                let (q, _) = on_crease[y as usize]
                    .iter()
                    .map(|&z| closest_on_segment(v[x as usize], v[y as usize], v[z as usize]))
                    .map(|q| (q, norm(sub(v[x as usize], q))))
                    .fold(([0.0; 3], f64::INFINITY), |b, c| if c.1 < b.1 { c } else { b });
                let away = sub(v[x as usize], q);
                let l = norm(away);
                if l > 0.0 {
                    let target: [f64; 3] = std::array::from_fn(|i| q[i] + away[i] / l * 1.05 * clearance);
                    let ts: Vec<u32> = c.around[x as usize].iter().copied().filter(|&t| !c.dead[t as usize]).collect();
                    let old: Vec<Option<[f64; 3]>> = ts.iter().map(|&t| unit_normal(v, tris[t as usize])).collect();
                    let keep = v[x as usize];
                    v[x as usize] = target;
                    let cos_turn = MAX_TURN_DEG.to_radians().cos();
                    let ok = ts.iter().zip(&old).all(|(&t, o)| match (o, unit_normal(v, tris[t as usize])) {
                        (Some(o), Some(m)) => dot(*o, m) > cos_turn && quality(v, tris[t as usize]) > 0.02,
                        _ => false,
                    });
                    if ok {
                        done += 1;
                    } else {
                        v[x as usize] = keep;
                    }
                }
            }
        }
        c.finish(tris);
        total += done;
        if done == 0 {
            break;
        }
    }
    total
}

/// Shape quality of a triangle: 4√3·area / (sum of squared edges), 1 for equilateral.
fn quality(v: &[[f64; 3]], t: [u32; 3]) -> f64 {
    let p = t.map(|i| v[i as usize]);
    let area = 0.5 * norm(cross(sub(p[1], p[0]), sub(p[2], p[0])));
    let s: f64 = (0..3).map(|k| norm(sub(p[(k + 1) % 3], p[k])).powi(2)).sum();
    4.0 * 3f64.sqrt() * area / s.max(f64::MIN_POSITIVE)
}

/// Flips interior, non-crease edges whose two opposite angles sum to more than π (towards a
/// Delaunay triangulation) where the quadrilateral is nearly flat; returns the flips.
fn flip_edges(v: &[[f64; 3]], tris: &mut [[u32; 3]]) -> usize {
    let (lines, _) = features(v, tris);
    let mut uses: HashMap<Edge, Vec<usize>> = HashMap::with_capacity(tris.len() * 2);
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            uses.entry(key(tri[k], tri[(k + 1) % 3])).or_default().push(t);
        }
    }
    let cos_turn = MAX_TURN_DEG.to_radians().cos();
    let angle = |at: u32, p: u32, q: u32| -> f64 {
        let (u, w) = (sub(v[p as usize], v[at as usize]), sub(v[q as usize], v[at as usize]));
        (dot(u, w) / (norm(u) * norm(w)).max(f64::MIN_POSITIVE)).clamp(-1.0, 1.0).acos()
    };
    let mut touched = vec![false; tris.len()];
    // Edges made by this pass's flips (`uses` is the pass's start).
    let mut made: HashSet<Edge> = HashSet::new();
    let mut done = 0;
    let mut list: Vec<(&Edge, &Vec<usize>)> = uses.iter().collect();
    list.sort_unstable_by_key(|(e, _)| **e);
    for (&(a, b), ts) in list {
        let [t1, t2] = ts[..] else { continue };
        if lines.contains(&(a, b)) || touched[t1] || touched[t2] {
            continue;
        }
        // Orient: t1 runs a→b, t2 b→a.
        let runs = |t: [u32; 3], p: u32, q: u32| (0..3).any(|k| t[k] == p && t[(k + 1) % 3] == q);
        let (t1, t2) = if runs(tris[t1], a, b) { (t1, t2) } else { (t2, t1) };
        if !runs(tris[t1], a, b) || !runs(tris[t2], b, a) {
            continue;
        }
        let c = tris[t1].iter().copied().find(|&w| w != a && w != b).unwrap_or(a);
        let d = tris[t2].iter().copied().find(|&w| w != a && w != b).unwrap_or(a);
        if c == d || uses.contains_key(&key(c, d)) || made.contains(&key(c, d)) {
            continue;
        }
        if angle(c, a, b) + angle(d, b, a) <= std::f64::consts::PI + 1e-9 {
            continue;
        }
        let (n1, n2) = ([a, d, c], [d, b, c]);
        let ok = match (unit_normal(v, tris[t1]), unit_normal(v, tris[t2]), unit_normal(v, n1), unit_normal(v, n2)) {
            (Some(o1), Some(o2), Some(m1), Some(m2)) => {
                dot(o1, o2) > cos_turn && dot(m1, m2) > cos_turn && dot(o1, m1) > cos_turn && dot(o2, m2) > cos_turn
            }
            _ => false,
        };
        if !ok || quality(v, n1).min(quality(v, n2)) <= quality(v, tris[t1]).min(quality(v, tris[t2])) {
            continue;
        }
        tris[t1] = n1;
        tris[t2] = n2;
        made.insert(key(c, d));
        touched[t1] = true;
        touched[t2] = true;
        done += 1;
    }
    done
}

/// Moves every free vertex halfway to its neighbours' centroid within its tangent plane, then
/// onto the closest point of `target` (the input surface's triangles in `grid`), unless a
/// triangle around it would turn too far.
fn smooth(v: &mut [[f64; 3]], tris: &[[u32; 3]], target: &TriSurface, grid: &TriGrid, h: f64) {
    let (_, level) = features(v, tris);
    let mut around: Vec<Vec<u32>> = vec![Vec::new(); v.len()];
    let mut nbr: Vec<HashSet<u32>> = vec![HashSet::new(); v.len()];
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            around[tri[k] as usize].push(t as u32);
            nbr[tri[k] as usize].insert(tri[(k + 1) % 3]);
            nbr[tri[k] as usize].insert(tri[(k + 2) % 3]);
        }
    }
    let cos_turn = MAX_TURN_DEG.to_radians().cos();
    for x in 0..v.len() {
        if level[x] != 0 || nbr[x].is_empty() {
            continue;
        }
        let mut n = [0.0; 3];
        for &t in &around[x] {
            if let Some(m) = unit_normal(v, tris[t as usize]) {
                n = [n[0] + m[0], n[1] + m[1], n[2] + m[2]];
            }
        }
        let l = norm(n);
        if !(l > 0.0) {
            continue;
        }
        let n = n.map(|c| c / l);
        let k = nbr[x].len() as f64;
        let c: [f64; 3] = std::array::from_fn(|i| nbr[x].iter().map(|&w| v[w as usize][i]).sum::<f64>() / k);
        let d = sub(c, v[x]);
        let dn = dot(d, n);
        let moved: [f64; 3] = std::array::from_fn(|i| v[x][i] + 0.5 * (d[i] - dn * n[i]));
        let Some((p, _, _)) = grid.closest(target, moved, h) else { continue };
        let old: Vec<Option<[f64; 3]>> = around[x].iter().map(|&t| unit_normal(v, tris[t as usize])).collect();
        let keep = v[x];
        v[x] = p;
        let ok = around[x].iter().zip(&old).all(|(&t, o)| match (o, unit_normal(v, tris[t as usize])) {
            (Some(o), Some(m)) => dot(*o, m) > cos_turn,
            _ => false,
        });
        if !ok {
            v[x] = keep;
        }
    }
}

/// Remeshes the surface (`v`, `tris`, consistently oriented, possibly open) to edges of about
/// `h`, keeping it on `target`'s triangles held by `grid`; unreferenced vertices are dropped.
pub(crate) fn remesh(v: &mut Vec<[f64; 3]>, tris: &mut Vec<[u32; 3]>, h: f64, target: &TriSurface, grid: &TriGrid) {
    for _ in 0..ROUNDS {
        // Splits may not go on forever on a slivered input: each round halves the longest,
        // and none starts past MAX_TRIANGLES.
        for _ in 0..8 {
            if tris.len() > MAX_TRIANGLES || split_long(v, tris, 4.0 / 3.0 * h) == 0 {
                break;
            }
        }
        for _ in 0..8 {
            if collapse_short(v, tris, 0.8 * h, 4.0 / 3.0 * h) == 0 {
                break;
            }
        }
        for _ in 0..4 {
            if flip_edges(v, tris) == 0 {
                break;
            }
        }
        smooth(v, tris, target, grid, h);
    }
    compact(v, tris);
}

/// Drops the vertices no triangle uses, renumbering the triangles.
pub(crate) fn compact(v: &mut Vec<[f64; 3]>, tris: &mut [[u32; 3]]) {
    let mut index = vec![u32::MAX; v.len()];
    let mut out = Vec::new();
    for t in tris.iter_mut() {
        for w in t.iter_mut() {
            if index[*w as usize] == u32::MAX {
                index[*w as usize] = out.len() as u32;
                out.push(v[*w as usize]);
            }
            *w = index[*w as usize];
        }
    }
    *v = out;
}
