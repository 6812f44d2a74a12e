//! The `"bar"` bank: a free–free rectangular bar struck on its top face.
//!
//! Sources: Euler–Bernoulli bending of a free–free beam and St Venant torsion of a thin
//! rectangular section, as in Blevins, *Formulas for Natural Frequency and Mode Shape*
//! (1979), Table 8-1 (beams, free–free) and Table 8-19 / §8.4 (torsion of beams), and
//! Roark's *Formulas for Stress and Strain*, Table 10.7 case 4 (torsion constant of a
//! rectangle). Vertical (thickness-direction) bending and torsion are the families a
//! strike normal to the top face excites; in-plane bending and longitudinal modes are not
//! excited by a normal strike and are left out.

use super::analytic::{assemble, BankInfo, Mode, FACTORY_MAX_FREQ_HZ};
use crate::DrawSurface;
use crate::{Bank, BankReference, StrikePoint};

/// Reference material: aluminium, Young's modulus in Pa.
pub const BAR_E: f64 = 70e9;
/// Reference density, kg/m³.
pub const BAR_RHO: f64 = 2700.0;
/// Reference Poisson's ratio.
pub const BAR_NU: f64 = 0.33;
/// Length L, m.
pub const BAR_LENGTH: f64 = 1.0;
/// Width w, m.
pub const BAR_WIDTH: f64 = 0.030;
/// Thickness t, m.
pub const BAR_THICKNESS: f64 = 0.003;
/// Number of strike points (end to centre).
const N_POINTS: usize = 21;

/// The k-th root (k = 1, 2, …) of cos z cosh z = 1, z = βₖL > 0 (free–free beam):
/// 4.7300, 7.8532, 10.9956, 14.1372, then → (2k+1)π/2.
pub fn free_free_beta_l(k: usize) -> f64 {
    // Newton on g(z) = cos z − sech z (same roots, no overflow), from (2k+1)π/2.
    let mut z = (2 * k + 1) as f64 * std::f64::consts::FRAC_PI_2;
    for _ in 0..50 {
        let sech = 1.0 / z.cosh();
        let g = z.cos() - sech;
        let dg = -z.sin() + sech * z.tanh();
        let step = g / dg;
        z -= step;
        if step.abs() < 1e-15 * z {
            break;
        }
    }
    z
}

/// Free–free beam mode shape φ(x) = cosh βx + cos βx − σ(sinh βx + sin βx) with
/// σ = (cosh z − cos z)/(sinh z − sin z), z = βL, written with only e^(−βx) and
/// e^(−β(L−x)) so that it neither overflows nor cancels for high modes (exact rewrite,
/// not an approximation). ∫₀ᴸ φ² dx = L; φ(0) = 2 for high modes.
pub fn free_free_shape(beta_l: f64, x_over_l: f64) -> f64 {
    let z = beta_l;
    let bx = z * x_over_l;
    let ez = (-z).exp();
    let denom = 1.0 - ez * ez - 2.0 * z.sin() * ez;
    let sigma = (1.0 + ez * ez - 2.0 * z.cos() * ez) / denom;
    bx.cos() - sigma * bx.sin()
        + 0.5 * (1.0 + sigma) * (-bx).exp()
        + (-(z - bx)).exp() * (z.cos() - z.sin() - ez) / denom
}

/// Torsion constant J (m⁴) of a thin w × t rectangle (t ≤ w): (w t³/3)(1 − 0.630 t/w +
/// 0.052 (t/w)⁵) (Roark Table 10.7 case 4, within 4 % for any aspect ratio).
fn torsion_constant(w: f64, t: f64) -> f64 {
    let r = t / w;
    w * t.powi(3) / 3.0 * (1.0 - 0.630 * r + 0.052 * r.powi(5))
}

/// Builds the bar bank (see the module docs and the bank's `description`).
pub fn bar_bank() -> Bank {
    let (e, rho, nu) = (BAR_E, BAR_RHO, BAR_NU);
    let (l, w, t) = (BAR_LENGTH, BAR_WIDTH, BAR_THICKNESS);
    let area = w * t;
    let second_moment = w * t.powi(3) / 12.0;
    let polar = area * (w * w + t * t) / 12.0; // polar moment of area about the axis, m⁴
    let shear = e / (2.0 * (1.0 + nu));
    let j_t = torsion_constant(w, t);
    let offset = w / 4.0; // strike line: a quarter width off the centreline, so torsion sounds

    // Strike points from one end (x = 0) to the centre (x = L/2); the other half mirrors it.
    let xs: Vec<f64> = (0..N_POINTS).map(|k| 0.5 * l * k as f64 / (N_POINTS - 1) as f64).collect();
    let points = xs
        .iter()
        .map(|&x| StrikePoint {
            label: format!("x = {:.3} L", x / l),
            xy: [(x / l) as f32, (0.5 + offset / w) as f32],
            position_m: [x as f32, offset as f32, (t / 2.0) as f32],
        })
        .collect();

    let lambda_max = (2.0 * std::f64::consts::PI * FACTORY_MAX_FREQ_HZ).powi(2);
    let mut modes = Vec::new();
    // Bending: λ = β⁴ EI/(ρA); mass-normalised shape φ/sqrt(ρAL) since ∫φ² = L.
    let bend_norm = 1.0 / (rho * area * l).sqrt();
    for k in 1.. {
        let bl = free_free_beta_l(k);
        let lambda = (bl / l).powi(4) * e * second_moment / (rho * area);
        if lambda > lambda_max {
            break;
        }
        let shape = xs.iter().map(|&x| bend_norm * free_free_shape(bl, x / l)).collect();
        modes.push(Mode { lambda, label: format!("bend {k}"), shape });
    }
    // Torsion (St Venant): λ = (kπ/L)² GJ/(ρ I_p); rotation θ = sqrt(2/(ρ I_p L)) cos(kπx/L)
    // is mass-normalised (∫ρ I_p θ² dx = 1); the surface moves by offset·θ at the strike line.
    let tors_norm = (2.0 / (rho * polar * l)).sqrt() * offset;
    for k in 1.. {
        let lambda = (k as f64 * std::f64::consts::PI / l).powi(2) * shear * j_t / (rho * polar);
        if lambda > lambda_max {
            break;
        }
        let shape = xs.iter().map(|&x| tors_norm * (k as f64 * std::f64::consts::PI * x / l).cos()).collect();
        modes.push(Mode { lambda, label: format!("torsion {k}"), shape });
    }

    let info = BankInfo {
        id: "bar",
        name: "Bar (free-free)",
        description: format!(
            "A free-free rectangular bar, {:.0} mm long, {:.0} mm wide, {:.0} mm thick, struck on its top face \
             along a line a quarter width off the centreline, from one end to the middle. \
             dimensions_m = [length, width, thickness]; size_m = length. \
             position_m = [x along the length from one end, y across from the centreline, z up from the mid-plane]; \
             xy = [x / length, 0.5 + y / width]. Modes: vertical bending (\"bend k\") and torsion (\"torsion k\").",
            l * 1e3,
            w * 1e3,
            t * 1e3
        ),
        provenance: "Analytic. Bending: Euler-Bernoulli free-free beam, cos(bL) cosh(bL) = 1, \
                     shape cosh + cos - sigma (sinh + sin) (Blevins 1979, Table 8-1). Torsion: St Venant, \
                     thin rectangle J = (w t^3/3)(1 - 0.630 t/w) (Roark Table 10.7), free-free \
                     omega_k = (k pi/L) sqrt(G J/(rho I_p)) (Blevins Table 8-19). Both families mass-normalised, \
                     surface-normal displacement at the strike line; modes up to 20 kHz."
            .to_string(),
        reference: BankReference {
            specific_modulus: e / rho,
            poisson: nu,
            density: rho,
            dimensions_m: vec![l, w, t],
            size_m: l,
        },
        surface: DrawSurface::cuboid([0.0, -w / 2.0, -t / 2.0], [l, w / 2.0, t / 2.0]),
    };
    assemble(info, points, modes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::factory::analytic::simpson;

    #[test]
    fn beta_l_roots_match_the_tables() {
        for (k, expected) in [(1, 4.730_040_7), (2, 7.853_204_6), (3, 10.995_607_8), (4, 14.137_165_5)] {
            assert!((free_free_beta_l(k) - expected).abs() < 1e-6, "k = {k}: {}", free_free_beta_l(k));
        }
        let k = 60;
        assert!((free_free_beta_l(k) - (2 * k + 1) as f64 * std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn shape_is_normalised_and_matches_the_textbook_form() {
        for k in [1, 2, 5, 20, 60] {
            let bl = free_free_beta_l(k);
            let norm = simpson(0.0, 1.0, 4000, |x| free_free_shape(bl, x).powi(2));
            assert!((norm - 1.0).abs() < 1e-6, "k = {k}: ∫φ² = {norm}");
            assert!(free_free_shape(bl, 0.0).abs() > 1.99, "free end moves twice the mean amplitude");
        }
        // Against the direct (cancelling) formula where it is still accurate.
        let bl = free_free_beta_l(2);
        let sigma = (bl.cosh() - bl.cos()) / (bl.sinh() - bl.sin());
        for x in [0.0, 0.13, 0.5, 0.77, 1.0] {
            let z = bl * x;
            let direct = z.cosh() + z.cos() - sigma * (z.sinh() + z.sin());
            assert!((free_free_shape(bl, x) - direct).abs() < 1e-9);
        }
    }
}
