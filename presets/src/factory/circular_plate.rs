//! The `"circular-plate"` bank: a thin circular plate with a free edge (Kirchhoff theory).
//!
//! Source: Leissa, *Vibration of Plates* (NASA SP-160, 1969), §2.1.3, eq. 2.13 (frequency
//! equation of the free circular plate) and Table 2.5 (its roots); Blevins 1979, Table 11-1.
//! Modes w = [Jₘ(kr) + C Iₘ(kr)] cos(mθ), ω = k² sqrt(D/(ρh)), D = E h³/(12(1 − ν²)).
//! Bessel functions: our own Miller-recurrence evaluations in [`super::bessel`] (integer
//! orders only; no crate needed).
//!
//! Each m > 0 mode is included once, in its cos(mθ) orientation. A perfect plate has a
//! degenerate sin(mθ) twin at the same frequency; it is left out because a bank with both
//! would double the resonators for no new pitch. The strike line sits a little off the
//! θ = 0 axis (θ₀ = 0.04 rad), so high-m modes are hit slightly off their antinode, as a
//! real strike on a slightly imperfect plate would.

use super::analytic::{assemble, simpson, BankInfo, Mode, FACTORY_MAX_FREQ_HZ};
use super::bessel::{bessel_i_scaled, bessel_j};
use crate::DrawSurface;
use crate::{Bank, BankReference, StrikePoint};

/// Reference material: cartridge brass, Young's modulus in Pa.
pub const PLATE_E: f64 = 110e9;
/// Reference density, kg/m³.
pub const PLATE_RHO: f64 = 8530.0;
/// Reference Poisson's ratio.
pub const PLATE_NU: f64 = 0.33;
/// Radius a, m.
pub const PLATE_RADIUS: f64 = 0.15;
/// Thickness h, m.
pub const PLATE_THICKNESS: f64 = 0.002;
/// Angle of the strike line, rad.
const STRIKE_ANGLE: f64 = 0.04;
/// Number of strike points (centre to edge).
const N_POINTS: usize = 20;
/// Scan step in x = ka when bracketing roots (roots of one m are ≈ π apart).
const SCAN_STEP: f64 = 0.01;

/// One root of the free circular plate's frequency equation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CircularPlateRoot {
    /// Nodal diameters.
    pub m: usize,
    /// Nodal circles (Leissa's s): the first elastic m = 0 and m = 1 modes have one.
    pub n: usize,
    /// x = k a, dimensionless; ω = x² sqrt(D/(ρh)) / a², so Leissa's λ² = x².
    pub x: f64,
    /// Ratio C/Iₘ(x) scaled: W(r) = Jₘ(x r/a) + `c_ratio` · Iₘ(x r/a)/Iₘ(x).
    pub c_ratio: f64,
}

/// Frequency determinant f(x) = M_J V_I − M_I V_J (I terms divided by Iₘ(x)), and the
/// mode's `c_ratio` = −M_J/M_I. `j` and `i` hold J and e⁻ˣI of orders 0..=m+1 at x.
///
/// Free edge (Leissa eq. 2.12): radial moment M_r and effective shear V_r vanish at r = a.
/// For w = W(r) cos mθ, multiplied by a² and a³:
///   M: x² W'' + ν (x W' − m² W),  V: x³ (∇²W)' − (1 − ν) m² (x W' − W),
/// with Bessel's equation giving, for J: M_J = −x² J − (1−ν)(x J' − m² J),
/// V_J = −x³ J' − (1−ν) m² (x J' − J); for I: M_I = x² I − (1−ν)(x I' − m² I),
/// V_I = x³ I' − (1−ν) m² (x I' − I). This is Leissa's eq. 2.13.
fn determinant(m: usize, x: f64, nu: f64, j: &[f64], i: &[f64]) -> (f64, f64) {
    let mf = m as f64;
    let m2 = mf * mf;
    let (jm, im) = (j[m], i[m]);
    let (jm_1, im_1) = if m == 0 { (-j[1], i[1]) } else { (j[m - 1], i[m - 1]) };
    let dj = jm_1 - mf / x * jm; // J'ₘ = Jₘ₋₁ − (m/x) Jₘ
    let rho = (im_1 - mf / x * im) / im; // I'ₘ/Iₘ
    let x2 = x * x;
    let x3 = x2 * x;
    let k = 1.0 - nu;
    let mj = -x2 * jm - k * (x * dj - m2 * jm);
    let vj = -x3 * dj - k * m2 * (x * dj - jm);
    let mi = x2 - k * (x * rho - m2);
    let vi = x3 * rho - k * m2 * (x * rho - 1.0);
    (mj * vi - mi * vj, -mj / mi)
}

fn eval(m: usize, x: f64, nu: f64, j: &mut [f64], i: &mut [f64]) -> (f64, f64) {
    bessel_j(x, &mut j[..m + 2]);
    bessel_i_scaled(x, &mut i[..m + 2]);
    determinant(m, x, nu, j, i)
}

/// All elastic modes of a free circular plate with x = ka ≤ `x_max`, sorted by x.
/// Rigid-body modes (x = 0 for m = 0, 1) are excluded.
pub fn free_circular_plate_roots(nu: f64, x_max: f64) -> Vec<CircularPlateRoot> {
    // The first root of order m lies above x ≈ m, so orders beyond x_max + 2 have none.
    let m_cap = x_max.ceil() as usize + 2;
    let mut j = vec![0.0; m_cap + 2];
    let mut i = vec![0.0; m_cap + 2];
    let mut prev = vec![f64::NAN; m_cap + 1];
    let mut count = vec![0usize; m_cap + 1];
    let mut roots = Vec::new();
    // Start clear of x = 0, where the rigid-body modes make f vanish.
    let n_steps = ((x_max - 0.5) / SCAN_STEP).ceil() as usize;
    for s in 0..=n_steps {
        let x = 0.5 + s as f64 * SCAN_STEP;
        bessel_j(x, &mut j);
        bessel_i_scaled(x, &mut i);
        for m in 0..=m_cap {
            let (f, _) = determinant(m, x, nu, &j, &i);
            if prev[m].is_finite() && f.is_finite() && (f == 0.0 || (f > 0.0) != (prev[m] > 0.0)) {
                // Bisect the bracket [x − step, x].
                let (mut lo, mut hi) = (x - SCAN_STEP, x);
                let mut f_lo = prev[m];
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    let (f_mid, _) = eval(m, mid, nu, &mut j, &mut i);
                    if (f_mid > 0.0) == (f_lo > 0.0) {
                        lo = mid;
                        f_lo = f_mid;
                    } else {
                        hi = mid;
                    }
                    if hi - lo < 1e-14 * hi {
                        break;
                    }
                }
                let root = 0.5 * (lo + hi);
                let (_, c_ratio) = eval(m, root, nu, &mut j, &mut i);
                if root <= x_max {
                    let n = count[m] + usize::from(m < 2);
                    roots.push(CircularPlateRoot { m, n, x: root, c_ratio });
                }
                count[m] += 1;
                // The arrays were overwritten by the bisection: restore them for this x.
                bessel_j(x, &mut j);
                bessel_i_scaled(x, &mut i);
            }
            prev[m] = f;
        }
    }
    roots.sort_by(|a, b| a.x.total_cmp(&b.x));
    roots
}

/// Radial shape W(ρ a) = Jₘ(xρ) + c_ratio · Iₘ(xρ)/Iₘ(x), ρ = r/a in [0, 1].
fn radial_shape(root: &CircularPlateRoot, rho: f64, i_edge: f64, j: &mut [f64], i: &mut [f64]) -> f64 {
    let m = root.m;
    let xr = root.x * rho;
    bessel_j(xr, &mut j[..m + 1]);
    bessel_i_scaled(xr, &mut i[..m + 1]);
    // Iₘ(xr)/Iₘ(x) = [e^(−xr) Iₘ(xr)] / [e^(−x) Iₘ(x)] · e^(xr − x)
    j[m] + root.c_ratio * i[m] / i_edge * (xr - root.x).exp()
}

/// Builds the circular plate bank (see the module docs and the bank's `description`).
pub fn circular_plate_bank() -> Bank {
    let (e, rho, nu, a, h) = (PLATE_E, PLATE_RHO, PLATE_NU, PLATE_RADIUS, PLATE_THICKNESS);
    let flexural = e * h * h * h / (12.0 * (1.0 - nu * nu)); // D, N·m
    let kappa = (flexural / (rho * h)).sqrt(); // sqrt(D/(ρh)), m²/s
    let omega_max = 2.0 * std::f64::consts::PI * FACTORY_MAX_FREQ_HZ;
    let x_max = a * (omega_max / kappa).sqrt();
    let roots = free_circular_plate_roots(nu, x_max);

    let radii: Vec<f64> = (0..N_POINTS).map(|k| k as f64 / (N_POINTS - 1) as f64).collect();
    let points = radii
        .iter()
        .map(|&r| StrikePoint {
            label: format!("r = {:.2} a", r),
            xy: [(0.5 + 0.5 * r * STRIKE_ANGLE.cos()) as f32, (0.5 + 0.5 * r * STRIKE_ANGLE.sin()) as f32],
            position_m: [(a * r * STRIKE_ANGLE.cos()) as f32, (a * r * STRIKE_ANGLE.sin()) as f32, (h / 2.0) as f32],
        })
        .collect();

    let m_top = roots.iter().map(|r| r.m).max().unwrap_or(0);
    let mut j = vec![0.0; m_top + 2];
    let mut i = vec![0.0; m_top + 2];
    let modes = roots
        .iter()
        .map(|root| {
            let m = root.m;
            bessel_i_scaled(root.x, &mut i[..m + 1]);
            let i_edge = i[m];
            // Mass normalisation: ρh ∫∫ W² cos²(mθ) r dr dθ = 1.
            // ~6 Simpson intervals per radian of x·r/a: relative error well below f32 precision.
            let intervals = (8.0 * root.x).ceil().max(64.0) as usize;
            let radial =
                simpson(0.0, 1.0, intervals, |r| radial_shape(root, r, i_edge, &mut j, &mut i).powi(2) * r) * a * a;
            let angular = if m == 0 { 2.0 * std::f64::consts::PI } else { std::f64::consts::PI };
            let norm = 1.0 / (rho * h * radial * angular).sqrt();
            let orient = (m as f64 * STRIKE_ANGLE).cos();
            let shape = radii.iter().map(|&r| norm * orient * radial_shape(root, r, i_edge, &mut j, &mut i)).collect();
            let lambda = (root.x * root.x / (a * a) * kappa).powi(2);
            Mode { lambda, label: format!("(m,n)=({},{})", m, root.n), shape }
        })
        .collect();

    let info = BankInfo {
        id: "circular-plate",
        name: "Circular plate (free edge)",
        description: format!(
            "A thin circular plate with a free edge, radius {:.0} mm, thickness {:.0} mm, struck along a radius \
             from the centre to the edge at {:.2} rad off the modes' cos(m theta) axis. \
             dimensions_m = [radius, thickness]; size_m = diameter. \
             position_m = [x, y, z] from the centre of the mid-plane, z up; xy = [0.5 + 0.5 x/a, 0.5 + 0.5 y/a]. \
             Modes labelled (m,n) = (nodal diameters, nodal circles); one orientation per m > 0.",
            a * 1e3,
            h * 1e3,
            STRIKE_ANGLE
        ),
        provenance: "Analytic, Kirchhoff thin-plate theory: free-edge frequency equation (Leissa 1969, Vibration of \
                     Plates, eq. 2.13; roots checked against Leissa Table 2.5 for nu = 0.33), solved by scanning and \
                     bisection; shapes [J_m(kr) + C I_m(kr)] cos(m theta), mass-normalised by quadrature; \
                     modes up to 20 kHz. Reference: cartridge brass (E = 110 GPa, rho = 8530 kg/m^3, nu = 0.33)."
            .to_string(),
        reference: BankReference {
            specific_modulus: e / rho,
            poisson: nu,
            density: rho,
            dimensions_m: vec![a, h],
            size_m: 2.0 * a,
        },
        surface: DrawSurface::disc(a, -h / 2.0, h / 2.0, 72),
    };
    assemble(info, points, modes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roots_match_leissa_for_nu_0_33() {
        let roots = free_circular_plate_roots(0.33, 6.0);
        // Leissa 1969 Table 2.5 / Blevins Table 11-1, ν = 0.33: λ² = ω a² sqrt(ρh/D).
        let expected = [((2, 0), 5.251), ((0, 1), 9.076), ((3, 0), 12.23), ((1, 1), 20.52)];
        for (k, ((m, n), lambda2)) in expected.into_iter().enumerate() {
            let r = roots[k];
            let got = r.x * r.x;
            assert_eq!((r.m, r.n), (m, n), "mode {k}");
            let rel = (got / lambda2 - 1.0).abs();
            assert!(rel < 0.005, "(m,n)=({m},{n}): λ² = {got}, expected {lambda2} ({:.3} %)", rel * 100.0);
            println!("(m,n)=({m},{n}): λ² = {got:.4} (Leissa {lambda2})");
        }
    }

    #[test]
    fn shapes_satisfy_the_free_edge_moment_condition() {
        // M_r ∝ W'' + ν(W'/r − m² W/r²) = 0 at r = a, checked by finite differences.
        let nu = 0.33;
        let roots = free_circular_plate_roots(nu, 20.0);
        let m_top = roots.iter().map(|r| r.m).max().unwrap();
        let (mut j, mut i) = (vec![0.0; m_top + 2], vec![0.0; m_top + 2]);
        for root in &roots {
            let mut edge = [0.0; 1];
            bessel_i_scaled(root.x, &mut i[..root.m + 1]);
            edge[0] = i[root.m];
            let mut w = |r: f64| radial_shape(root, r, edge[0], &mut j, &mut i);
            let hh = 1e-3;
            let (w0, w1, w2) = (w(1.0), w(1.0 - hh), w(1.0 - 2.0 * hh));
            let (w3, w4) = (w(1.0 - 3.0 * hh), w(1.0 - 4.0 * hh));
            // One-sided 2nd-order differences at r = 1.
            let d1 = (25.0 * w0 - 48.0 * w1 + 36.0 * w2 - 16.0 * w3 + 3.0 * w4) / (12.0 * hh);
            let d2 = (35.0 * w0 - 104.0 * w1 + 114.0 * w2 - 56.0 * w3 + 11.0 * w4) / (12.0 * hh * hh);
            let m2 = (root.m * root.m) as f64;
            let moment = d2 + nu * (d1 - m2 * w0);
            let scale = d2.abs() + d1.abs() + m2 * w0.abs();
            assert!(moment.abs() < 1e-3 * scale, "(m,n)=({},{}): M_r = {moment}, scale {scale}", root.m, root.n);
        }
    }

    #[test]
    fn normalisation_quadrature_is_converged() {
        let roots = free_circular_plate_roots(PLATE_NU, 40.0);
        let root = roots.last().unwrap();
        let m = root.m;
        let (mut j, mut i) = (vec![0.0; m + 2], vec![0.0; m + 2]);
        bessel_i_scaled(root.x, &mut i[..m + 1]);
        let edge = i[m];
        let coarse_n = (8.0 * root.x).ceil() as usize;
        let coarse = simpson(0.0, 1.0, coarse_n, |r| radial_shape(root, r, edge, &mut j, &mut i).powi(2) * r);
        let fine = simpson(0.0, 1.0, 20_000, |r| radial_shape(root, r, edge, &mut j, &mut i).powi(2) * r);
        assert!((coarse / fine - 1.0).abs() < 1e-6, "x = {}: {coarse} vs {fine}", root.x);
    }
}
