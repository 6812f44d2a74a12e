//! The object view's picture (issue 11 part 6): the bank's drawing surface seen from a fixed
//! camera — an orthographic projection, back faces culled, the rest painted far to near
//! (painter's algorithm) with Lambert shading — and the strike points on it, each marked
//! seen or hidden behind the object.
//!
//! Flat objects (bars, plates, blocks: height under [`FLAT`] of the longer side) are seen
//! from the front at [`FLAT_ELEVATION`] above the horizon, so their top face, where the
//! strike points are, shows; solids of revolution (bowl, bell, cup, tube, sphere) from
//! [`SOLID_ELEVATION`], which shows their side. Banks without a surface fall back to the
//! strike points' own 2-D `xy`.

use presets::Bank;

/// Height / longer side under which an object is drawn from above.
pub const FLAT: f32 = 0.35;
/// Camera elevation for flat objects, degrees.
pub const FLAT_ELEVATION: f32 = 55.0;
/// Camera elevation for solids, degrees.
pub const SOLID_ELEVATION: f32 = 20.0;
/// Thinnest picture drawn to scale (height / width or width / height); thinner ones are
/// stretched across to it.
pub const MIN_ASPECT: f32 = 0.12;
/// Camera azimuth for solids, degrees (a turn about z, so a seam or a helix start is not
/// edge-on).
pub const SOLID_AZIMUTH: f32 = -30.0;

/// One painted triangle: corners in drawing coordinates and its shade (0 dark … 1 lit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Facet {
    /// Corners, drawing coordinates (see [`ObjectDrawing`]).
    pub corners: [[f32; 2]; 3],
    /// Lambert shade, 0..=1.
    pub shade: f32,
}

/// What the object view paints for one bank. Drawing coordinates: x right, y up, the
/// picture inside [0, `size[0]`] × [0, `size[1]`] with the longer side 1.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectDrawing {
    /// Id of the bank drawn.
    pub bank_id: String,
    /// Front-facing triangles, far to near.
    pub facets: Vec<Facet>,
    /// The strike points, in drawing coordinates, in the bank's order.
    pub points: Vec<[f32; 2]>,
    /// Whether each strike point faces the camera (not hidden by the object).
    pub visible: Vec<bool>,
    /// Extent of the picture, the longer side 1.
    pub size: [f32; 2],
}

/// The camera: screen right, screen up and the direction it looks along (unit vectors).
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    /// Screen x in world coordinates.
    pub right: [f32; 3],
    /// Screen y in world coordinates.
    pub up: [f32; 3],
    /// Viewing direction (from the eye into the scene).
    pub forward: [f32; 3],
}

impl Camera {
    /// A camera at `elevation_deg` above the horizon, turned `azimuth_deg` about z, looking at
    /// the object from the −y side (elevation 90: straight down, x right, y up).
    pub fn new(elevation_deg: f32, azimuth_deg: f32) -> Camera {
        let (se, ce) = elevation_deg.to_radians().sin_cos();
        let (sa, ca) = azimuth_deg.to_radians().sin_cos();
        // Unturned: right x, up (0, sin e, cos e), forward (0, cos e, −sin e); then the turn.
        let turn = |v: [f32; 3]| [ca * v[0] - sa * v[1], sa * v[0] + ca * v[1], v[2]];
        Camera { right: turn([1.0, 0.0, 0.0]), up: turn([0.0, se, ce]), forward: turn([0.0, ce, -se]) }
    }

    /// The camera the object view uses for a bank whose drawing spans `extent` (m).
    pub fn for_extent(extent: [f32; 3]) -> Camera {
        if extent[2] < FLAT * extent[0].max(extent[1]) {
            Camera::new(FLAT_ELEVATION, 0.0)
        } else {
            Camera::new(SOLID_ELEVATION, SOLID_AZIMUTH)
        }
    }

    /// Screen position and depth (larger is farther) of `p`.
    pub fn project(&self, p: [f32; 3]) -> ([f32; 2], f32) {
        ([dot(p, self.right), dot(p, self.up)], dot(p, self.forward))
    }
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// Barycentric coordinates of `q` in the 2-D triangle `t`, or `None` if it is degenerate.
fn barycentric(t: [[f32; 2]; 3], q: [f32; 2]) -> Option<[f32; 3]> {
    let d = (t[1][1] - t[2][1]) * (t[0][0] - t[2][0]) + (t[2][0] - t[1][0]) * (t[0][1] - t[2][1]);
    if d.abs() < 1e-20 {
        return None;
    }
    let a = ((t[1][1] - t[2][1]) * (q[0] - t[2][0]) + (t[2][0] - t[1][0]) * (q[1] - t[2][1])) / d;
    let b = ((t[2][1] - t[0][1]) * (q[0] - t[2][0]) + (t[0][0] - t[2][0]) * (q[1] - t[2][1])) / d;
    Some([a, b, 1.0 - a - b])
}

/// The picture of `bank` (see the module documentation).
pub fn object_drawing(bank: &Bank) -> ObjectDrawing {
    let Some(surface) = bank.surface.as_ref().filter(|s| !s.triangles.is_empty()) else {
        // No surface: the points' own 2-D layout in the unit square.
        return ObjectDrawing {
            bank_id: bank.id.clone(),
            facets: Vec::new(),
            points: bank.points.iter().map(|p| p.xy).collect(),
            visible: vec![true; bank.points.len()],
            size: [1.0, 1.0],
        };
    };
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for v in &surface.vertices {
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
    let camera = Camera::for_extent([hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]]);
    let projected: Vec<([f32; 2], f32)> = surface.vertices.iter().map(|&v| camera.project(v)).collect();
    // Light from the upper left, a little towards the viewer.
    let light = {
        let l = [
            -0.45 * camera.right[0] + 0.65 * camera.up[0] - 0.6 * camera.forward[0],
            -0.45 * camera.right[1] + 0.65 * camera.up[1] - 0.6 * camera.forward[1],
            -0.45 * camera.right[2] + 0.65 * camera.up[2] - 0.6 * camera.forward[2],
        ];
        let n = dot(l, l).sqrt();
        [l[0] / n, l[1] / n, l[2] / n]
    };
    /// A front face: mean depth, screen corners, corner depths, shade.
    struct Front {
        depth: f32,
        corners: [[f32; 2]; 3],
        depths: [f32; 3],
        shade: f32,
    }
    let mut front: Vec<Front> = Vec::new();
    for t in &surface.triangles {
        let [a, b, c] = t.map(|i| surface.vertices[i as usize]);
        let n = cross(sub(b, a), sub(c, a));
        let len = dot(n, n).sqrt();
        if !(len > 0.0) || dot(n, camera.forward) >= 0.0 {
            continue; // degenerate or facing away
        }
        let n = [n[0] / len, n[1] / len, n[2] / len];
        let shade = 0.25 + 0.75 * dot(n, light).max(0.0);
        let corners = t.map(|i| projected[i as usize].0);
        let depths = t.map(|i| projected[i as usize].1);
        front.push(Front { depth: (depths[0] + depths[1] + depths[2]) / 3.0, corners, depths, shade });
    }
    front.sort_by(|x, y| y.depth.total_cmp(&x.depth));

    // Strike points: seen unless a front face covering them lies nearer by more than a
    // hundredth of the object's smallest extent (a plate's thickness, a tube's diameter). A
    // point on a curved front surface is never behind its own facet: the drawing's vertices
    // lie on the surface, so its facets are chords inside it.
    let thinnest = (hi[0] - lo[0]).min(hi[1] - lo[1]).min(hi[2] - lo[2]).max(1e-9);
    let eps = 0.01 * thinnest;
    let point_proj: Vec<([f32; 2], f32)> = bank.points.iter().map(|p| camera.project(p.position_m)).collect();
    let visible: Vec<bool> = point_proj
        .iter()
        .map(|&(q, depth)| {
            !front.iter().any(|f| {
                barycentric(f.corners, q).is_some_and(|w| {
                    w.iter().all(|&x| x >= -1e-4)
                        && w[0] * f.depths[0] + w[1] * f.depths[1] + w[2] * f.depths[2] < depth - eps
                })
            })
        })
        .collect();

    // Fit into [0, 1] on the longer side.
    let (mut slo, mut shi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
    for (q, _) in projected.iter().chain(&point_proj) {
        for k in 0..2 {
            slo[k] = slo[k].min(q[k]);
            shi[k] = shi[k].max(q[k]);
        }
    }
    let span = (shi[0] - slo[0]).max(shi[1] - slo[1]).max(1e-12);
    // A picture thinner than MIN_ASPECT (a long bar seen from above) is stretched across
    // its length to that, so its strike points stay apart on screen.
    let (w, h) = ((shi[0] - slo[0]) / span, (shi[1] - slo[1]) / span);
    let stretch = [
        if w < MIN_ASPECT { MIN_ASPECT / w.max(1e-6) } else { 1.0 },
        if h < MIN_ASPECT { MIN_ASPECT / h.max(1e-6) } else { 1.0 },
    ];
    let fit = |q: [f32; 2]| [(q[0] - slo[0]) / span * stretch[0], (q[1] - slo[1]) / span * stretch[1]];
    ObjectDrawing {
        bank_id: bank.id.clone(),
        facets: front.iter().map(|f| Facet { corners: f.corners.map(fit), shade: f.shade }).collect(),
        points: point_proj.iter().map(|&(q, _)| fit(q)).collect(),
        visible,
        size: [w * stretch[0], h * stretch[1]],
    }
}

/// Distance (drawing units) from `q` to the painted picture: 0 inside a facet.
pub fn distance_to_picture(drawing: &ObjectDrawing, q: [f32; 2]) -> f32 {
    let segment = |a: [f32; 2], b: [f32; 2]| {
        let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
        let t = (((q[0] - a[0]) * ex + (q[1] - a[1]) * ey) / (ex * ex + ey * ey).max(1e-30)).clamp(0.0, 1.0);
        (q[0] - a[0] - t * ex).hypot(q[1] - a[1] - t * ey)
    };
    drawing
        .facets
        .iter()
        .map(|f| {
            if barycentric(f.corners, q).is_some_and(|w| w.iter().all(|&x| x >= 0.0)) {
                0.0
            } else {
                let c = f.corners;
                segment(c[0], c[1]).min(segment(c[1], c[2])).min(segment(c[2], c[0]))
            }
        })
        .fold(f32::INFINITY, f32::min)
}

/// The strike point nearest to `q` among the seen ones (all of them if none is seen).
pub fn nearest_seen(drawing: &ObjectDrawing, q: [f32; 2]) -> Option<usize> {
    let any_seen = drawing.visible.iter().any(|&v| v);
    drawing
        .points
        .iter()
        .enumerate()
        .filter(|&(i, _)| !any_seen || drawing.visible[i])
        .map(|(i, p)| (i, (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)))
        .filter(|(_, d)| d.is_finite())
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}
