//! The quadratic (10-node) tetrahedron: shape functions, quadrature, element stiffness and
//! consistent mass for linear isotropic elasticity.
//!
//! Node order: corners 0–3, then mid-edge nodes on the edges [`EDGES`] in that order.
//! Shape functions in barycentric coordinates L₀..L₃ (Zienkiewicz, Taylor & Zhu, *The Finite
//! Element Method: Its Basis and Fundamentals*, 7th ed., §6.6): corner i: Lᵢ(2Lᵢ − 1);
//! edge (i, j): 4LᵢLⱼ. Elements are isoparametric, so curved mid-edge nodes are allowed.

/// Corner pairs of the six mid-edge nodes 4..=9.
pub const EDGES: [(usize, usize); 6] = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)];

/// A quadrature rule on the reference tetrahedron (volume 1/6): barycentric points
/// (L₁, L₂, L₃; L₀ = 1 − ΣLₐ) and weights summing to 1/6.
pub struct Rule {
    /// Barycentric (L₁, L₂, L₃) of each point.
    pub points: Vec<[f64; 3]>,
    /// Weight of each point.
    pub weights: Vec<f64>,
}

/// The 4-point rule, exact for polynomials of degree 2 (Zienkiewicz et al. Table 6.4). Exact
/// for the stiffness of straight-sided quadratic tetrahedra (BᵀDB is quadratic).
pub fn rule_degree2() -> Rule {
    let a = 0.585_410_196_624_968_5;
    let b = 0.138_196_601_125_010_5;
    Rule { points: vec![[b, b, b], [a, b, b], [b, a, b], [b, b, a]], weights: vec![1.0 / 24.0; 4] }
}

/// A collapsed-cube (Duffy / Stroud conical product) rule with 4 Gauss–Legendre points per
/// direction: 64 points, positive weights, exact for degree ≥ 5 on the tetrahedron. Used for
/// the consistent mass (NᵢNⱼ has degree 4).
pub fn rule_mass() -> Rule {
    // Gauss–Legendre on [−1, 1] (Abramowitz & Stegun Table 25.4), mapped to [0, 1].
    let x = [-0.861_136_311_594_052_6, -0.339_981_043_584_856_3, 0.339_981_043_584_856_3, 0.861_136_311_594_052_6];
    let w = [0.347_854_845_137_453_9, 0.652_145_154_862_546_1, 0.652_145_154_862_546_1, 0.347_854_845_137_453_9];
    let mut points = Vec::with_capacity(64);
    let mut weights = Vec::with_capacity(64);
    for i in 0..4 {
        let u = 0.5 * (1.0 + x[i]);
        for j in 0..4 {
            let v = 0.5 * (1.0 + x[j]);
            for k in 0..4 {
                let s = 0.5 * (1.0 + x[k]);
                // ξ = u, η = v(1−u), ζ = s(1−u)(1−v); Jacobian (1−u)²(1−v).
                let xi = u;
                let eta = v * (1.0 - u);
                let zeta = s * (1.0 - u) * (1.0 - v);
                let jac = (1.0 - u) * (1.0 - u) * (1.0 - v);
                points.push([xi, eta, zeta]);
                weights.push(0.125 * w[i] * w[j] * w[k] * jac);
            }
        }
    }
    Rule { points, weights }
}

/// Shape function values N (10) and derivatives dN/dξₐ (10 × 3) at reference point ξ.
pub fn shape(xi: [f64; 3]) -> ([f64; 10], [[f64; 3]; 10]) {
    let l = [1.0 - xi[0] - xi[1] - xi[2], xi[0], xi[1], xi[2]];
    let mut n = [0.0; 10];
    // dN/dLₖ first, then chain rule: dN/dξₐ = dN/dLₐ₊₁ − dN/dL₀.
    let mut dl = [[0.0f64; 4]; 10];
    for i in 0..4 {
        n[i] = l[i] * (2.0 * l[i] - 1.0);
        dl[i][i] = 4.0 * l[i] - 1.0;
    }
    for (e, &(i, j)) in EDGES.iter().enumerate() {
        n[4 + e] = 4.0 * l[i] * l[j];
        dl[4 + e][i] += 4.0 * l[j];
        dl[4 + e][j] += 4.0 * l[i];
    }
    let mut d = [[0.0; 3]; 10];
    for a in 0..10 {
        for k in 0..3 {
            d[a][k] = dl[a][k + 1] - dl[a][0];
        }
    }
    (n, d)
}

/// Lamé parameters (λ, μ) in Pa from Young's modulus E (Pa) and Poisson's ratio ν.
pub fn lame(young: f64, poisson: f64) -> (f64, f64) {
    let lambda = young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson));
    let mu = young / (2.0 * (1.0 + poisson));
    (lambda, mu)
}

/// Precomputed shape data at the quadrature points of both rules.
pub struct ElementKit {
    stiff: Vec<(f64, [[f64; 3]; 10])>,
    mass: Vec<(f64, [f64; 10], [[f64; 3]; 10])>,
}

impl ElementKit {
    /// The shape-function values and derivatives at the quadrature points of both rules.
    pub fn new() -> Self {
        let rs = rule_degree2();
        let rm = rule_mass();
        ElementKit {
            stiff: rs.points.iter().zip(&rs.weights).map(|(p, &w)| (w, shape(*p).1)).collect(),
            mass: rm
                .points
                .iter()
                .zip(&rm.weights)
                .map(|(p, &w)| {
                    let (n, d) = shape(*p);
                    (w, n, d)
                })
                .collect(),
        }
    }

    /// Element stiffness (30 × 30, DOF order node-major: 3a + i) and the scalar consistent
    /// mass (10 × 10; the 30 × 30 mass is it ⊗ I₃) for nodes `x` (m), Lamé λ, μ (Pa) and
    /// density ρ (kg/m³). Returns `None` if the element is inverted or degenerate at a
    /// quadrature point (det J ≤ 0).
    ///
    /// Kₐᵦ[i][j] = ∫ λ ∂ᵢNₐ ∂ⱼNᵦ + μ ∂ⱼNₐ ∂ᵢNᵦ + μ δᵢⱼ ∇Nₐ·∇Nᵦ dV (weak form of linear
    /// elasticity, Zienkiewicz et al. §6.2).
    pub fn matrices(
        &self,
        x: &[[f64; 3]; 10],
        lambda: f64,
        mu: f64,
        rho: f64,
        k: &mut [[f64; 30]; 30],
        m: &mut [[f64; 10]; 10],
    ) -> Option<()> {
        for row in k.iter_mut() {
            row.fill(0.0);
        }
        for row in m.iter_mut() {
            row.fill(0.0);
        }
        for (w, d) in &self.stiff {
            let (g, det) = gradients(x, d)?;
            let wd = w * det;
            for a in 0..10 {
                for b in a..10 {
                    let dot = g[a][0] * g[b][0] + g[a][1] * g[b][1] + g[a][2] * g[b][2];
                    for i in 0..3 {
                        for j in 0..3 {
                            let mut v = lambda * g[a][i] * g[b][j] + mu * g[a][j] * g[b][i];
                            if i == j {
                                v += mu * dot;
                            }
                            k[3 * a + i][3 * b + j] += wd * v;
                        }
                    }
                }
            }
        }
        // Fill the lower blocks by symmetry (exact, so K stays bit-symmetric).
        for a in 0..10 {
            for b in 0..a {
                for i in 0..3 {
                    for j in 0..3 {
                        k[3 * a + i][3 * b + j] = k[3 * b + j][3 * a + i];
                    }
                }
            }
        }
        for (w, n, d) in &self.mass {
            let det = jacobian_det(x, d);
            if det <= 0.0 {
                return None;
            }
            let wd = w * det * rho;
            for a in 0..10 {
                for b in a..10 {
                    m[a][b] += wd * n[a] * n[b];
                }
            }
        }
        for a in 0..10 {
            for b in 0..a {
                m[a][b] = m[b][a];
            }
        }
        Some(())
    }
}

impl Default for ElementKit {
    fn default() -> Self {
        Self::new()
    }
}

fn jacobian(x: &[[f64; 3]; 10], d: &[[f64; 3]; 10]) -> [[f64; 3]; 3] {
    // J[r][a] = Σₙ xₙ[r] ∂Nₙ/∂ξₐ
    let mut j = [[0.0; 3]; 3];
    for n in 0..10 {
        for r in 0..3 {
            for a in 0..3 {
                j[r][a] += x[n][r] * d[n][a];
            }
        }
    }
    j
}

fn det3(j: &[[f64; 3]; 3]) -> f64 {
    j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1]) - j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0])
        + j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0])
}

fn jacobian_det(x: &[[f64; 3]; 10], d: &[[f64; 3]; 10]) -> f64 {
    det3(&jacobian(x, d))
}

/// Physical gradients ∇Nₙ = J⁻ᵀ ∂N/∂ξ and det J; `None` if det J ≤ 0.
fn gradients(x: &[[f64; 3]; 10], d: &[[f64; 3]; 10]) -> Option<([[f64; 3]; 10], f64)> {
    let j = jacobian(x, d);
    let det = det3(&j);
    if det.is_nan() || det <= 0.0 {
        return None;
    }
    // inv[a][r] = (J⁻¹)[a][r]; ∂N/∂x_r = Σₐ ∂N/∂ξₐ (J⁻¹)[a][r].
    let c = |r0: usize, c0: usize, r1: usize, c1: usize| j[r0][c0] * j[r1][c1] - j[r0][c1] * j[r1][c0];
    let inv = [
        [c(1, 1, 2, 2) / det, -c(0, 1, 2, 2) / det, c(0, 1, 1, 2) / det],
        [-c(1, 0, 2, 2) / det, c(0, 0, 2, 2) / det, -c(0, 0, 1, 2) / det],
        [c(1, 0, 2, 1) / det, -c(0, 0, 2, 1) / det, c(0, 0, 1, 1) / det],
    ];
    let mut g = [[0.0; 3]; 10];
    for n in 0..10 {
        for r in 0..3 {
            g[n][r] = d[n][0] * inv[0][r] + d[n][1] * inv[1][r] + d[n][2] * inv[2][r];
        }
    }
    Some((g, det))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn partition_of_unity_and_rules() {
        for p in rule_mass().points {
            let (n, d) = shape(p);
            assert!((n.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            for a in 0..3 {
                assert!(d.iter().map(|r| r[a]).sum::<f64>().abs() < 1e-12);
            }
        }
        let s: f64 = rule_mass().weights.iter().sum();
        assert!((s - 1.0 / 6.0).abs() < 1e-14);
        // ∫ ξ⁴ over the reference tet = 4!·3!/7! = 1/210.
        let r = rule_mass();
        let i4: f64 = r.points.iter().zip(&r.weights).map(|(p, w)| w * p[0].powi(4)).sum();
        assert!((i4 - 1.0 / 210.0).abs() < 1e-14);
    }
}
