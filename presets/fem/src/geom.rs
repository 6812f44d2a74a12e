//! 3-D vector helpers, the signed volume of a tetrahedron and the undercut bar's profile,
//! shared by the mesher, the surface checks, the voxeliser, the tuner and the strike-point code.

/// a − b.
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// a · b.
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// a × b.
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// |a|.
pub fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// The midpoint of a and b.
pub fn mid(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])]
}

/// Signed volume of the tetrahedron with corners `x[t[0..4]]`: positive when t[1], t[2],
/// t[3] turn counter-clockwise seen from outside, i.e. (b − a)·((c − a) × (d − a)) / 6 > 0.
pub fn signed_volume(x: &[[f64; 3]], t: &[u32; 4]) -> f64 {
    let a = x[t[0] as usize];
    dot(sub(x[t[1] as usize], a), cross(sub(x[t[2] as usize], a), sub(x[t[3] as usize], a))) / 6.0
}

/// Thickness of an undercut bar at `x` (see [`crate::Shape::UndercutBar`]).
pub fn undercut_thickness(x: f64, length: f64, thickness: f64, depth: f64, cut: f64, exponent: f64) -> f64 {
    let u = ((x - 0.5 * length) / (0.5 * cut * length)).abs();
    if u >= 1.0 {
        thickness
    } else {
        thickness * (1.0 - depth * (1.0 - u.powf(exponent)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed forms: the unit corner tetrahedron has volume 1/6, negative when two corners
    /// swap; x × y = z; a 3-4-5 vector has length 5.
    #[test]
    fn known_values() {
        let x = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [2.0, 0.0, 0.0]];
        assert!((signed_volume(&x, &[0, 1, 2, 3]) - 1.0 / 6.0).abs() < 1e-15);
        assert!((signed_volume(&x, &[0, 2, 1, 3]) + 1.0 / 6.0).abs() < 1e-15);
        assert!((signed_volume(&x, &[0, 4, 2, 3]) - 2.0 / 6.0).abs() < 1e-15);
        assert_eq!(cross([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]);
        assert_eq!(norm([3.0, 4.0, 0.0]), 5.0);
        assert_eq!(mid([0.0, 2.0, 4.0], [2.0, 0.0, 0.0]), [1.0, 1.0, 2.0]);
        assert_eq!(dot(sub([1.0, 2.0, 3.0], [1.0, 1.0, 1.0]), [0.0, 1.0, 1.0]), 3.0);
    }
}
