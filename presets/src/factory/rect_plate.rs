//! The `"rect-plate"` bank: a simply supported rectangular thin plate (Kirchhoff).
//!
//! Source: Leissa, *Vibration of Plates* (NASA SP-160, 1969), §4.1 (SSSS plate, Navier
//! solution, eq. 4.21): ω_mn = π² (m²/a² + n²/b²) sqrt(D/(ρh)), shape
//! sin(mπx/a) sin(nπy/b); exact within Kirchhoff theory. Mass-normalised shape:
//! 2/sqrt(ρ h a b) · sin · sin.

use super::analytic::{assemble, BankInfo, Mode, FACTORY_MAX_FREQ_HZ};
use crate::DrawSurface;
use crate::{Bank, BankReference, StrikePoint};

/// Reference material: steel, Young's modulus in Pa.
pub const RECT_E: f64 = 200e9;
/// Reference density, kg/m³.
pub const RECT_RHO: f64 = 7850.0;
/// Reference Poisson's ratio.
pub const RECT_NU: f64 = 0.30;
/// Side a (along x), m.
pub const RECT_A: f64 = 0.5;
/// Side b (along y), m.
pub const RECT_B: f64 = 0.35;
/// Thickness h, m. 4 mm keeps the count of modes below 20 kHz near 300.
pub const RECT_THICKNESS: f64 = 0.004;
/// Number of strike points (near a corner to the centre).
const N_POINTS: usize = 20;
/// Path start and end in units of (a, b): near a corner, then straight to the centre.
/// It misses the exact diagonal (x/a ≠ y/b) so that (m,n) and (n,m)-like modes differ.
const PATH_START: [f64; 2] = [0.06, 0.10];
const PATH_END: [f64; 2] = [0.5, 0.5];

/// Builds the rectangular plate bank (see the module docs and the bank's `description`).
pub fn rect_plate_bank() -> Bank {
    let (e, rho, nu, a, b, h) = (RECT_E, RECT_RHO, RECT_NU, RECT_A, RECT_B, RECT_THICKNESS);
    let flexural = e * h * h * h / (12.0 * (1.0 - nu * nu));
    let kappa = (flexural / (rho * h)).sqrt();
    let omega_max = 2.0 * std::f64::consts::PI * FACTORY_MAX_FREQ_HZ;
    let pi = std::f64::consts::PI;

    let uv: Vec<[f64; 2]> = (0..N_POINTS)
        .map(|k| {
            let t = k as f64 / (N_POINTS - 1) as f64;
            [PATH_START[0] + (PATH_END[0] - PATH_START[0]) * t, PATH_START[1] + (PATH_END[1] - PATH_START[1]) * t]
        })
        .collect();
    let points = uv
        .iter()
        .map(|&[u, v]| StrikePoint {
            label: format!("({:.2} a, {:.2} b)", u, v),
            xy: [u as f32, v as f32],
            position_m: [(u * a) as f32, (v * b) as f32, (h / 2.0) as f32],
        })
        .collect();

    let norm = 2.0 / (rho * h * a * b).sqrt();
    let mut modes = Vec::new();
    // ω ≤ ω_max ⇔ m²/a² + n²/b² ≤ ω_max/(π² κ).
    let bound = omega_max / (pi * pi * kappa);
    let m_max = (a * bound.sqrt()).floor() as usize;
    for m in 1..=m_max {
        let rest = bound - (m * m) as f64 / (a * a);
        let n_max = (b * rest.max(0.0).sqrt()).floor() as usize;
        for n in 1..=n_max {
            let omega = pi * pi * ((m * m) as f64 / (a * a) + (n * n) as f64 / (b * b)) * kappa;
            let shape = uv.iter().map(|&[u, v]| norm * (m as f64 * pi * u).sin() * (n as f64 * pi * v).sin()).collect();
            modes.push(Mode { lambda: omega * omega, label: format!("(m,n)=({m},{n})"), shape });
        }
    }

    let info = BankInfo {
        id: "rect-plate",
        name: "Rectangular plate (simply supported)",
        description: format!(
            "A thin rectangular plate simply supported on all four edges, {:.0} mm x {:.0} mm, {:.0} mm thick, \
             struck along a straight path from near a corner to the centre. \
             dimensions_m = [a (x side), b (y side), thickness]; size_m = a. \
             position_m = [x, y, z] from a corner of the mid-plane, z up; xy = [x/a, y/b]. \
             Modes labelled (m,n) = half-waves along x and y.",
            a * 1e3,
            b * 1e3,
            h * 1e3
        ),
        provenance: "Analytic, exact within Kirchhoff thin-plate theory: Navier solution of the simply supported \
                     rectangular plate (Leissa 1969, Vibration of Plates, section 4.1), \
                     omega = pi^2 (m^2/a^2 + n^2/b^2) sqrt(D/(rho h)), shape sin(m pi x/a) sin(n pi y/b), \
                     mass-normalised; modes up to 20 kHz. Reference: steel (E = 200 GPa, rho = 7850 kg/m^3, nu = 0.3)."
            .to_string(),
        reference: BankReference {
            specific_modulus: e / rho,
            poisson: nu,
            density: rho,
            dimensions_m: vec![a, b, h],
            size_m: a,
        },
        surface: DrawSurface::cuboid([0.0, 0.0, -h / 2.0], [a, b, h / 2.0]),
    };
    assemble(info, points, modes)
}
