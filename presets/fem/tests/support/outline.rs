//! Closed surfaces of revolution written from a meridian outline, the way a CAD export
//! facets a turned object: shared by the thin-wall tests and the `thin_wall` example (each
//! takes what it needs, hence no dead-code warnings).
#![allow(dead_code)]

use fem::TriSurface;
use std::f64::consts::PI;

/// A closed surface of revolution about z from a closed meridian outline (r, z), listed with
/// the solid on its left; points with r = 0 become one pole vertex.
pub fn revolve(outline: &[[f64; 2]], around: usize) -> TriSurface {
    let mut s = TriSurface::default();
    let rows: Vec<Vec<u32>> = outline
        .iter()
        .map(|&[r, z]| {
            if r < 1e-12 {
                s.vertices.push([0.0, 0.0, z]);
                vec![(s.vertices.len() - 1) as u32; around]
            } else {
                (0..around)
                    .map(|j| {
                        let th = 2.0 * PI * j as f64 / around as f64;
                        s.vertices.push([r * th.cos(), r * th.sin(), z]);
                        (s.vertices.len() - 1) as u32
                    })
                    .collect()
            }
        })
        .collect();
    for i in 0..rows.len() {
        let (a, b) = (&rows[i], &rows[(i + 1) % rows.len()]);
        for j in 0..around {
            let k = (j + 1) % around;
            for t in [[a[j], b[j], b[k]], [a[j], b[k], a[k]]] {
                if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                    s.triangles.push(t);
                }
            }
        }
    }
    s
}

/// Points of a circular arc about `c` of radius `r`, angle a from the bottom (−z) towards +r.
pub fn arc(c: [f64; 2], r: f64, a0: f64, a1: f64, n: usize) -> Vec<[f64; 2]> {
    (0..=n).map(|i| a0 + (a1 - a0) * i as f64 / n as f64).map(|a| [c[0] + r * a.sin(), c[1] - r * a.cos()]).collect()
}

/// `n` + 1 points from `a` to `b`.
pub fn line(a: [f64; 2], b: [f64; 2], n: usize) -> Vec<[f64; 2]> {
    (0..=n).map(|i| i as f64 / n as f64).map(|t| [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]).collect()
}

/// Joins pieces, dropping each piece's first point where it repeats the last one.
pub fn join(pieces: Vec<Vec<[f64; 2]>>) -> Vec<[f64; 2]> {
    let mut out: Vec<[f64; 2]> = Vec::new();
    for p in pieces {
        for q in p {
            if out.last().is_none_or(|l| (l[0] - q[0]).abs() + (l[1] - q[1]).abs() > 1e-12) {
                out.push(q);
            }
        }
    }
    if out.len() > 1 && (out[0][0] - out[out.len() - 1][0]).abs() + (out[0][1] - out[out.len() - 1][1]).abs() < 1e-12 {
        out.pop();
    }
    out
}
