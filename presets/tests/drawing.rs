//! The factory banks' drawing surfaces (issue 11 part 6): closed and outward, enclosing the
//! volume the object's closed form gives, with every strike point on them.

use presets::{factory_banks, Bank, DrawSurface};
use std::collections::HashMap;
use std::f64::consts::PI;

/// The object's volume from its dimensions by the closed form of its shape (written here,
/// not taken from the builder), or `None` for shapes without a simple one (cup, bell).
fn closed_form_volume(bank: &Bank) -> Option<f64> {
    let d = &bank.reference.dimensions_m;
    let id = bank.id.as_str();
    let shell = |r: f64, w: f64, full: f64| full * PI / 3.0 * (r.powi(3) - (r - w).powi(3));
    Some(match id {
        "bar" | "rect-plate" | "fem-bar" | "fem-plate" | "fem-block" | "fem-glockenspiel-bar" => d[0] * d[1] * d[2],
        "circular-plate" | "fem-circular-plate" => PI * d[0] * d[0] * d[1],
        "fem-tube" => PI * (d[1] * d[1] - (d[1] - d[2]).powi(2)) * d[0],
        // A plugged tube: the wall along the length, the bore filled over the plug.
        "fem-tubular-chime" => PI * (d[1] * d[1] * d[0] - (d[1] - d[2]).powi(2) * (d[0] - d[3])),
        "fem-bowl" => shell(d[0], d[1], 2.0),
        "fem-sphere-shell" => shell(d[0], d[1], 4.0),
        // Undercut: ∫(1 − |u|^p) du over [−1, 1] = 2p/(p + 1) on half-length cut·L/2.
        _ if d.len() == 6 => d[0] * d[1] * d[2] - d[1] * d[2] * d[3] * d[4] * d[0] * d[5] / (d[5] + 1.0),
        _ => return None,
    })
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Distance from `p` to triangle (a, b, c), by projecting onto the plane and, outside the
/// triangle, onto its edges.
fn distance_to_triangle(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let seg = |a: [f64; 3], b: [f64; 3]| {
        let ab = sub(b, a);
        let t = (dot(sub(p, a), ab) / dot(ab, ab).max(1e-300)).clamp(0.0, 1.0);
        let q = [a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2]];
        dot(sub(p, q), sub(p, q)).sqrt()
    };
    let (ab, ac) = (sub(b, a), sub(c, a));
    let n = [ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2], ab[0] * ac[1] - ab[1] * ac[0]];
    let nn = dot(n, n);
    if nn > 0.0 {
        let h = dot(sub(p, a), n) / nn;
        let q = [p[0] - h * n[0], p[1] - h * n[1], p[2] - h * n[2]];
        // Inside if q is on the inner side of all three edges.
        let inside = [(a, b), (b, c), (c, a)].iter().all(|&(u, v)| {
            let e = sub(v, u);
            let w = sub(q, u);
            let cr = [e[1] * w[2] - e[2] * w[1], e[2] * w[0] - e[0] * w[2], e[0] * w[1] - e[1] * w[0]];
            dot(cr, n) >= 0.0
        });
        if inside {
            return h.abs() * nn.sqrt();
        }
    }
    seg(a, b).min(seg(b, c)).min(seg(c, a))
}

fn vertex(s: &DrawSurface, i: u32) -> [f64; 3] {
    s.vertices[i as usize].map(f64::from)
}

#[test]
fn every_factory_bank_carries_a_closed_outward_surface_of_its_volume_with_the_strike_points_on_it() {
    let mut checked_volume = 0;
    for bank in factory_banks() {
        let s = bank.surface.as_ref().unwrap_or_else(|| panic!("{}: no drawing surface", bank.id));
        // Closed and consistently wound: every directed edge once, its reverse once.
        let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
        for t in &s.triangles {
            for k in 0..3 {
                *edges.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "{}: edge {a}-{b} used {n} times in one direction", bank.id);
            assert_eq!(edges.get(&(b, a)), Some(&1), "{}: edge {a}-{b} has no twin (open surface)", bank.id);
        }
        let volume = s.volume();
        assert!(volume > 0.0, "{}: volume {volume} (inward winding?)", bank.id);
        if let Some(want) = closed_form_volume(&bank) {
            let err = volume / want - 1.0;
            println!(
                "{:22} {} triangles, volume {:.4e} m³ vs closed form {:.4e} ({:+.2} %)",
                bank.id,
                s.triangles.len(),
                volume,
                want,
                100.0 * err
            );
            assert!(err.abs() < 0.08, "{}: volume {volume:.4e} vs {want:.4e} m³", bank.id);
            checked_volume += 1;
        }
        // The strike points lie on it (within 2 % of the object's size: the drawing is a coarse
        // tessellation of the surface the points were placed on).
        let size = bank.reference.size_m;
        for (i, p) in bank.points.iter().enumerate() {
            let p = p.position_m.map(f64::from);
            let d = s
                .triangles
                .iter()
                .map(|t| distance_to_triangle(p, vertex(s, t[0]), vertex(s, t[1]), vertex(s, t[2])))
                .fold(f64::INFINITY, f64::min);
            assert!(d <= 0.02 * size, "{}: strike point {i} is {d:.2e} m off the surface (size {size} m)", bank.id);
        }
    }
    assert!(checked_volume >= 15, "{checked_volume} volumes checked");
}
