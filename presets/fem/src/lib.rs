//! Struck's bank builder (`struck-fem`): modal analysis of real geometry by the finite element
//! method, into [`presets::Bank`]s. The only user of faer's sparse solvers; the plugin does not
//! link it.
//!
//! Pipeline (SCIENCE.md §1): mesh a solid with quadratic (10-node) tetrahedra, assemble the
//! stiffness K and consistent mass M of linear isotropic elasticity (E, ν, ρ), solve
//! K v = λ M v for the lowest modes by spectrum slicing with block shift-invert Lanczos on
//! sparse LDLᵀ factorisations (faer) checked by Sturm counts, check and drop the six
//! rigid-body modes, and evaluate the
//! mass-normalised mode shapes in the surface-normal direction at strike points on the outer
//! surface. The result is a [`presets::Bank`].
//!
//! # Conventions
//! - SI units: metres, pascals, kg/m³; λ = ω² in rad²/s²; frequencies in Hz only where a
//!   name says `hz`.
//! - DOF order: 3·node + axis (x, y, z).
//! - Mode shapes are mass-normalised: ΦᵀMΦ = I, ΦᵀKΦ = diag(λ).
//!
//! # Sources
//! Element: Zienkiewicz, Taylor & Zhu, *The Finite Element Method: Its Basis and
//! Fundamentals*, 7th ed. (2013), §6.6 (10-node tetrahedron). Eigen solver: Ericsson & Ruhe
//! (1980) spectral transformation Lanczos; Grimes, Lewis & Simon (1994) block shifted
//! Lanczos. Validation values: Blevins, *Formulas for Natural Frequency and Mode Shape*
//! (1979) Table 8-1 (free–free beam); Leissa, *Vibration of Plates* NASA SP-160 (1969)
//! §2.2 (free circular plate).

#![warn(missing_docs)]
pub mod assembly;
pub mod eigen;
pub mod element;
pub mod geom;
pub mod gmsh;
pub mod import;
pub mod mesh;
pub mod ordering;
pub mod remesh;
pub mod shell;
pub mod strike;
pub mod surface;
pub mod trisolve;
pub mod tune;
pub mod voxel;

use std::time::Instant;

use presets::{Bank, BankReference, PresetError, StrikePoint, MAX_BANK_MODES, MAX_BANK_POINTS};

/// Largest mesh accepted, imported or voxelised, in corner vertices (a bound on time and
/// memory; see the README).
pub const MAX_IMPORT_VERTICES: usize = 60_000;

pub use assembly::{assemble, System};
pub use gmsh::read_gmsh;
pub use import::{build_bank_from_mesh, surface_strike_points};
pub use mesh::TetMesh;
pub use surface::{check_surface, read_obj, read_stl, SurfaceReport, TriSurface};
pub use voxel::{voxelise, VoxelOptions, VoxelReport};

/// A built-in solid. All lengths in metres.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// Rectangular bar [0, length] × [0, width] × [0, thickness]; struck on the top face
    /// along its centre line.
    Bar {
        /// Length, m.
        length: f64,
        /// Width, m.
        width: f64,
        /// Thickness, m.
        thickness: f64,
    },
    /// A bar with an arch cut from its underside, as on marimba, xylophone and vibraphone
    /// bars: at x the thickness is `thickness`·(1 − `depth`·(1 − |u|^`exponent`)) with
    /// u = (x − length/2)/(`cut`·length/2) over the cut (|u| < 1), the full thickness outside.
    /// `depth` and `cut` are fractions (of the thickness and the length); the top face is
    /// flat and struck along its centre line, like [`Shape::Bar`]. See [`tune`].
    UndercutBar {
        /// Length, m.
        length: f64,
        /// Width, m.
        width: f64,
        /// Thickness, m.
        thickness: f64,
        /// Undercut depth, a fraction of the thickness.
        depth: f64,
        /// Undercut length, a fraction of the length.
        cut: f64,
        /// Flatness of the undercut's bottom (1–16).
        exponent: f64,
    },
    /// Rectangular plate [0, length] × [0, width] × [0, thickness]; struck over the top face.
    Plate {
        /// Length, m.
        length: f64,
        /// Width, m.
        width: f64,
        /// Thickness, m.
        thickness: f64,
    },
    /// Block / tile [0, length] × [0, width] × [0, height]; struck over the top face.
    Block {
        /// Length, m.
        length: f64,
        /// Width, m.
        width: f64,
        /// Height, m.
        height: f64,
    },
    /// Circular plate of `radius`, centred on the z axis, z ∈ [0, thickness]; struck on the
    /// top face along a spiral.
    CircularPlate {
        /// Radius, m.
        radius: f64,
        /// Thickness, m.
        thickness: f64,
    },
    /// Open tube (chime) along z ∈ [0, length]; struck on the outside along a helix.
    Tube {
        /// Length, m.
        length: f64,
        /// Outer radius, m.
        outer_radius: f64,
        /// Wall thickness, m.
        wall: f64,
    },
    /// A tube closed at its top end by a solid plug filling the bore, as a tubular bell's
    /// end plug (Rossing, *Science of Percussion Instruments* (2000), §5.3: the plug moves
    /// the bending modes' ratios, bringing modes 4 : 5 : 6 near 2 : 3 : 4): the wall of
    /// [`Shape::Tube`] along z ∈ [0, length], the bore filled over z ∈ [length − plug,
    /// length] (one piece, one material); struck on the outside along a helix. A plug as long
    /// as the tube makes a solid cylinder.
    PluggedTube {
        /// Length, m.
        length: f64,
        /// Outer radius, m.
        outer_radius: f64,
        /// Wall thickness, m.
        wall: f64,
        /// Length of the plug at the top end, m (at most `length`).
        plug: f64,
    },
    /// Hemispherical bowl, outer radius `radius`, pole at the origin, opening up (+z).
    Bowl {
        /// Radius, m.
        radius: f64,
        /// Wall thickness, m.
        wall: f64,
    },
    /// Cup: flat bottom at z = 0, rounded corner, straight wall up to `height`; outer radius.
    Cup {
        /// Radius, m.
        radius: f64,
        /// Height, m.
        height: f64,
        /// Wall thickness, m.
        wall: f64,
    },
    /// Simplified bell: elliptic crown, flaring body to the lip radius `radius` at z = 0,
    /// crown at z = `height`; constant wall (inner surface of the profile + `wall`).
    Bell {
        /// Radius, m.
        radius: f64,
        /// Height, m.
        height: f64,
        /// Wall thickness, m.
        wall: f64,
    },
    /// Closed spherical shell, outer radius `radius`.
    SphereShell {
        /// Radius, m.
        radius: f64,
        /// Wall thickness, m.
        wall: f64,
    },
}

impl Shape {
    /// Short kebab-case name of the shape kind, e.g. `"circular-plate"`.
    pub fn kind(&self) -> &'static str {
        match self {
            Shape::Bar { .. } => "bar",
            Shape::UndercutBar { .. } => "undercut-bar",
            Shape::Plate { .. } => "plate",
            Shape::Block { .. } => "block",
            Shape::CircularPlate { .. } => "circular-plate",
            Shape::Tube { .. } => "tube",
            Shape::PluggedTube { .. } => "plugged-tube",
            Shape::Bowl { .. } => "bowl",
            Shape::Cup { .. } => "cup",
            Shape::Bell { .. } => "bell",
            Shape::SphereShell { .. } => "sphere-shell",
        }
    }

    /// The dimensions in metres, in the order of the variant's fields.
    pub fn dimensions(&self) -> Vec<f64> {
        match *self {
            Shape::Bar { length, width, thickness } | Shape::Plate { length, width, thickness } => {
                vec![length, width, thickness]
            }
            Shape::Block { length, width, height } => vec![length, width, height],
            Shape::UndercutBar { length, width, thickness, depth, cut, exponent } => {
                vec![length, width, thickness, depth, cut, exponent]
            }
            Shape::CircularPlate { radius, thickness } => vec![radius, thickness],
            Shape::Tube { length, outer_radius, wall } => vec![length, outer_radius, wall],
            Shape::PluggedTube { length, outer_radius, wall, plug } => vec![length, outer_radius, wall, plug],
            Shape::Bowl { radius, wall } | Shape::SphereShell { radius, wall } => vec![radius, wall],
            Shape::Cup { radius, height, wall } | Shape::Bell { radius, height, wall } => {
                vec![radius, height, wall]
            }
        }
    }

    /// The same kind of shape with other dimensions (in the order of [`Shape::dimensions`];
    /// missing ones keep their value).
    pub fn with_dimensions(&self, d: &[f64]) -> Shape {
        let mut v = self.dimensions();
        for (slot, &x) in v.iter_mut().zip(d) {
            *slot = x;
        }
        match self {
            Shape::Bar { .. } => Shape::Bar { length: v[0], width: v[1], thickness: v[2] },
            Shape::UndercutBar { .. } => Shape::UndercutBar {
                length: v[0],
                width: v[1],
                thickness: v[2],
                depth: v[3],
                cut: v[4],
                exponent: v[5],
            },
            Shape::Plate { .. } => Shape::Plate { length: v[0], width: v[1], thickness: v[2] },
            Shape::Block { .. } => Shape::Block { length: v[0], width: v[1], height: v[2] },
            Shape::CircularPlate { .. } => Shape::CircularPlate { radius: v[0], thickness: v[1] },
            Shape::Tube { .. } => Shape::Tube { length: v[0], outer_radius: v[1], wall: v[2] },
            Shape::PluggedTube { .. } => {
                Shape::PluggedTube { length: v[0], outer_radius: v[1], wall: v[2], plug: v[3] }
            }
            Shape::Bowl { .. } => Shape::Bowl { radius: v[0], wall: v[1] },
            Shape::Cup { .. } => Shape::Cup { radius: v[0], height: v[1], wall: v[2] },
            Shape::Bell { .. } => Shape::Bell { radius: v[0], height: v[1], wall: v[2] },
            Shape::SphereShell { .. } => Shape::SphereShell { radius: v[0], wall: v[1] },
        }
    }

    /// Names of the dimensions, in the order of [`Shape::dimensions`].
    pub fn field_names(&self) -> &'static [&'static str] {
        match self {
            Shape::Bar { .. } | Shape::Plate { .. } => &["length", "width", "thickness"],
            Shape::Block { .. } => &["length", "width", "height"],
            Shape::UndercutBar { .. } => &["length", "width", "thickness", "depth", "cut", "exponent"],
            Shape::CircularPlate { .. } => &["radius", "thickness"],
            Shape::Tube { .. } => &["length", "outer_radius", "wall"],
            Shape::PluggedTube { .. } => &["length", "outer_radius", "wall", "plug"],
            Shape::Bowl { .. } | Shape::SphereShell { .. } => &["radius", "wall"],
            Shape::Cup { .. } | Shape::Bell { .. } => &["radius", "height", "wall"],
        }
    }

    /// Characteristic size in metres (the largest extent).
    pub fn size(&self) -> f64 {
        match *self {
            Shape::CircularPlate { radius, .. } | Shape::Bowl { radius, .. } | Shape::SphereShell { radius, .. } => {
                2.0 * radius
            }
            Shape::Tube { length, outer_radius, .. } | Shape::PluggedTube { length, outer_radius, .. } => {
                length.max(2.0 * outer_radius)
            }
            Shape::Cup { radius, height, .. } | Shape::Bell { radius, height, .. } => (2.0 * radius).max(height),
            Shape::UndercutBar { length, width, thickness, .. } => length.max(width).max(thickness),
            _ => self.dimensions().into_iter().fold(0.0, f64::max),
        }
    }

    /// Checks that every dimension is finite and positive and walls fit inside radii.
    ///
    /// # Errors
    /// [`FemError::InvalidShape`] naming the dimension.
    pub fn validate(&self) -> Result<(), FemError> {
        for (i, (name, v)) in self.field_names().iter().zip(self.dimensions()).enumerate() {
            // An undercut's depth, cut and exponent are ratios, not lengths (a tester's
            // `--exponent 0` was told "exponent must be a length in metres").
            let ratio = matches!(self, Shape::UndercutBar { .. }) && i >= 3;
            if !(v.is_finite() && v > 0.0 && (ratio || v <= MAX_DIMENSION_M)) {
                let what = if ratio {
                    "a ratio above 0 (depth under 0.95 of the thickness, cut at most 1 of the length, exponent 1..=16)"
                        .to_string()
                } else {
                    format!("a length in metres above 0 and at most {MAX_DIMENSION_M}")
                };
                return Err(FemError::InvalidShape {
                    shape: self.kind(),
                    reason: format!("{name} must be {what}, found {v}"),
                });
            }
        }
        // A ratio no mesh of a few thousand elements can resolve (and beyond double
        // precision's reach in K − σM: a 1 nm plate 0.3 m wide failed in the factorisation).
        let mut dims = self.dimensions();
        match self {
            // The cut's depth, extent and exponent are ratios, not lengths.
            Shape::UndercutBar { .. } => dims.truncate(3),
            // A plug may shrink to nothing (the plain tube).
            Shape::PluggedTube { .. } => dims.truncate(3),
            _ => {}
        }
        let (lo, hi) = dims.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        if hi > MAX_ASPECT * lo {
            return Err(FemError::InvalidShape {
                shape: self.kind(),
                reason: format!(
                    "its largest dimension ({hi} m) is over {MAX_ASPECT:.0} times its smallest ({lo} m); check the units of --dims"
                ),
            });
        }
        // Whether the wall fits, and the limit said if not.
        let (wall_ok, limit) = match *self {
            Shape::Tube { outer_radius, wall, .. } => (wall < outer_radius, "thinner than the outer radius"),
            Shape::PluggedTube { length, outer_radius, wall, plug } => {
                if plug > length {
                    return Err(FemError::InvalidShape {
                        shape: self.kind(),
                        reason: format!("the plug ({plug} m) must not be longer than the tube ({length} m)"),
                    });
                }
                (wall < outer_radius, "thinner than the outer radius")
            }
            Shape::Bowl { radius, wall } | Shape::SphereShell { radius, wall } => {
                (wall < 0.5 * radius, "under half the radius")
            }
            Shape::Cup { radius, height, wall } | Shape::Bell { radius, height, wall } => {
                (wall < 0.25 * radius && wall < 0.25 * height, "under a quarter of the radius and of the height")
            }
            Shape::UndercutBar { depth, cut, exponent, .. } => {
                if !(depth < 0.95 && cut <= 1.0 && (1.0..=16.0).contains(&exponent)) {
                    return Err(FemError::InvalidShape {
                        shape: self.kind(),
                        reason: format!(
                            "depth must be under 0.95 (of the thickness), cut at most 1 (of the length) and the exponent in 1..=16; found {depth}, {cut}, {exponent}"
                        ),
                    });
                }
                (true, "")
            }
            _ => (true, ""),
        };
        if !wall_ok {
            return Err(FemError::InvalidShape {
                shape: self.kind(),
                reason: format!("the wall is too thick; use a wall {limit}"),
            });
        }
        Ok(())
    }
}

/// Largest dimension of a built-in shape, m.
pub const MAX_DIMENSION_M: f64 = 100.0;

/// Largest ratio of a built-in shape's largest dimension to its smallest.
pub const MAX_ASPECT: f64 = 1e4;

/// Young's moduli a struck solid can have, Pa: a thousandth of the softest foam's to ten
/// times diamond's (1.2·10¹²). Outside, a value is a typing error, not a material (a
/// black-box tester's `--young 1e-300` was told the eigensolver "converged 11 of 11 modes
/// … ask for fewer modes"; `--density 1e308` wrote a bank with γ₀ = 2·10⁻²⁹⁷).
pub const YOUNG_RANGE_PA: (f64, f64) = (1e2, 1e13);
/// Densities a struck solid can have, kg/m³: aerogels (≈ 1 and up) to four times osmium's
/// (22,590).
pub const DENSITY_RANGE: (f64, f64) = (1.0, 1e5);

/// An isotropic linear-elastic material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Young's modulus E, Pa.
    pub young: f64,
    /// Density ρ, kg/m³.
    pub density: f64,
    /// Poisson's ratio ν, in (−1, 0.5).
    pub poisson: f64,
}

impl Material {
    /// Steel: E = 200 GPa, ρ = 7850 kg/m³, ν = 0.3.
    pub const STEEL: Material = Material { young: 200e9, density: 7850.0, poisson: 0.3 };
    /// Aluminium: E = 69 GPa, ρ = 2700 kg/m³, ν = 0.33.
    pub const ALUMINIUM: Material = Material { young: 69e9, density: 2700.0, poisson: 0.33 };
    /// Bell bronze: E = 105 GPa, ρ = 8600 kg/m³, ν = 0.34.
    pub const BRONZE: Material = Material { young: 105e9, density: 8600.0, poisson: 0.34 };
    /// Soda-lime glass: E = 70 GPa, ρ = 2500 kg/m³, ν = 0.22.
    pub const GLASS: Material = Material { young: 70e9, density: 2500.0, poisson: 0.22 };

    /// Specific modulus γ = E/ρ, m²/s².
    pub fn specific_modulus(&self) -> f64 {
        self.young / self.density
    }

    /// # Errors
    /// [`FemError::InvalidMaterial`] for E or ρ not finite, not positive or outside
    /// [`YOUNG_RANGE_PA`] / [`DENSITY_RANGE`], or ν outside (−1, 0.5).
    pub fn validate(&self) -> Result<(), FemError> {
        if !(self.young.is_finite() && self.young > 0.0) {
            return Err(FemError::InvalidMaterial(format!("Young's modulus must be > 0 Pa, found {}", self.young)));
        }
        if !(self.density.is_finite() && self.density > 0.0) {
            return Err(FemError::InvalidMaterial(format!("density must be > 0 kg/m^3, found {}", self.density)));
        }
        let (lo, hi) = YOUNG_RANGE_PA;
        if !(lo..=hi).contains(&self.young) {
            return Err(FemError::InvalidMaterial(format!(
                "Young's modulus must be {lo:e}..={hi:e} Pa (soft rubber 1e6, oak 11e9, steel 200e9, diamond 1.2e12), found {:e}",
                self.young
            )));
        }
        let (lo, hi) = DENSITY_RANGE;
        if !(lo..=hi).contains(&self.density) {
            return Err(FemError::InvalidMaterial(format!(
                "density must be {lo}..={hi:e} kg/m^3 (foam 30, glass 2500, steel 7850, osmium 22590), found {:e}",
                self.density
            )));
        }
        if !(self.poisson.is_finite() && self.poisson > -1.0 && self.poisson < 0.5) {
            return Err(FemError::InvalidMaterial(format!(
                "Poisson's ratio must be in (-1, 0.5), found {}",
                self.poisson
            )));
        }
        Ok(())
    }
}

/// What to compute.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildOptions {
    /// Most elastic modes to keep (rigid modes excluded).
    pub max_modes: usize,
    /// Keep only modes at or below this frequency (Hz), if set.
    pub max_freq_hz: Option<f64>,
    /// Elements along the largest dimension of the shape (the element size is that dimension
    /// divided by `resolution`; thin walls get at least one element through).
    pub resolution: usize,
    /// Least number of strike points (some paths round up to full rows).
    pub strike_points: usize,
    /// Built-in shapes: choose the mesh by the build budget ([`choose_mesh`]) instead of
    /// `resolution`, and estimate its error ([`discretisation_error`]).
    pub auto_resolution: bool,
    /// With `auto_resolution`: the largest relative frequency error wanted over the first
    /// [`ERROR_MODES`] modes (e.g. 0.002 for 0.2 %). A mesh whose estimated error is larger is
    /// refined towards the resolution predicted to reach it, as far as [`ACCURACY_DOFS`] and
    /// the factor limit ([`eigen::MAX_FACTOR_BYTES`]) allow, and solved again.
    pub accuracy: Option<f64>,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            max_modes: 100,
            max_freq_hz: None,
            resolution: 40,
            strike_points: 64,
            auto_resolution: false,
            accuracy: None,
        }
    }
}

/// DOFs the automatic resolution aims at: for 30 modes on a 2-core machine about 10 s and
/// 1.4 GiB for a shell (a 98,667-DOF bowl: 10.1 s), more for a solid (a 89,373-DOF cube:
/// 26 s, 1.9 GiB), whose factor fills in more.
pub const AUTO_DOFS: usize = 100_000;
/// Finest automatic resolution (elements along the largest dimension).
pub const MAX_AUTO_RESOLUTION: usize = 160;

/// Modes the error estimate covers.
pub const ERROR_MODES: usize = 20;

/// Least number of element layers through a wall or plate when the mesh is chosen by budget.
/// One layer of quadratic tetrahedra (split prisms) is stiff in bending: measured against
/// the independent axisymmetric references (tests/data/axisymmetric.json) at about 93k DOFs,
/// the glass bowl was 0.55 % sharp with one layer and 0.37 % with two at the coarser
/// resolution the same budget affords; the aluminium disc 0.39 % either way.
pub const AUTO_LAYERS: usize = 2;

/// Roache's safety factor for a grid convergence index from three solves (Roache,
/// *Verification and Validation in Computational Science and Engineering* (1998), §5.6).
const GCI_SAFETY: f64 = 1.25;
/// Range the observed order of convergence is held to. The quadratic element's eigenvalues
/// converge as h⁴ in the limit (Strang & Fix 1973, §6.3), but at the resolutions a build
/// affords the thin shapes are not there yet: against the independent references
/// (tests/data/axisymmetric.json, 2 layers) the largest frequency error fell as h^2.4 to
/// h^3.2 on the disc (resolutions 28, 35, 44) and about h^2.8 on the bowl. The meshes of
/// two resolutions are not nested, so an order seen above 3 is noise that would understate
/// the error; one below 2 is held there too.
const ORDER_RANGE: (f64, f64) = (2.0, 3.0);

/// An estimate of a mesh's frequency error.
#[derive(Clone, Debug)]
pub struct ErrorEstimate {
    /// Largest relative frequency error over the modes compared.
    pub relative: f64,
    /// Modes compared.
    pub modes: usize,
    /// Observed order of convergence, frequency error ∝ h^order.
    pub order: f64,
    /// How it was made.
    pub method: String,
}

/// How finely a built-in shape is meshed: elements along its largest dimension, and the least
/// number of elements through a thin wall or plate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshDensity {
    /// Elements along the largest dimension.
    pub resolution: usize,
    /// Least number of elements through the thickness of a wall or plate.
    pub layers: usize,
}

/// The frequencies (Hz) of the lowest `n` elastic modes of `shape` meshed at `density`.
fn solve_frequencies(shape: &Shape, material: &Material, density: MeshDensity, n: usize) -> Result<Vec<f64>, FemError> {
    let mesh = mesh_shape_layers(shape, density.resolution, density.layers)?;
    let opts = BuildOptions { max_modes: n, resolution: density.resolution, ..BuildOptions::default() };
    Ok(analyse(&mesh, material, &opts, &|_, _| {})?.frequencies_hz())
}

/// The observed order of convergence from three solves of the same shape at decreasing
/// resolutions (`(resolution, frequencies)`, finest first, the same layers through walls):
/// the RMS over the first [`ERROR_MODES`] modes of the changes between successive solves
/// (each mode against the next solve's nearest frequency), and p solved by bisection from
/// e = C·h^p (Roache 1998, §5.4), held to [`ORDER_RANGE`].
fn observed_order(solves: &[(usize, Vec<f64>); 3]) -> f64 {
    let f1 = &solves[0].1;
    let n = ERROR_MODES.min(f1.len());
    let (mut d21, mut d32) = (0.0, 0.0);
    for &f in &f1[..n] {
        let f2 = nearest(&solves[1].1, f);
        let f3 = nearest(&solves[2].1, f2);
        d21 += ((f2 - f) / f).powi(2);
        d32 += ((f3 - f2) / f).powi(2);
    }
    let h = solves.each_ref().map(|s| 1.0 / s.0 as f64);
    let ratio = (d32 / d21.max(1e-300)).sqrt();
    // g(p) = (h₃^p − h₂^p) / (h₂^p − h₁^p) grows with p for h₁ < h₂ < h₃.
    let g = |p: f64| (h[2].powf(p) - h[1].powf(p)) / (h[1].powf(p) - h[0].powf(p));
    if !ratio.is_finite() || ratio <= g(ORDER_RANGE.0) {
        return ORDER_RANGE.0;
    }
    if ratio >= g(ORDER_RANGE.1) {
        return ORDER_RANGE.1;
    }
    let (mut lo, mut hi) = ORDER_RANGE;
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if g(mid) < ratio {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The frequency in `list` nearest to `f` (`f` itself if the list is empty).
fn nearest(list: &[f64], f: f64) -> f64 {
    list.iter().copied().min_by(|a, b| (a - f).abs().total_cmp(&(b - f).abs())).unwrap_or(f)
}

/// The grid convergence index (Roache 1998, §5.6) of the frequencies of `fine` from a
/// coarser solve `coarse` (`(resolution, frequencies)`) and the order of convergence: for each
/// of the first [`ERROR_MODES`] modes 1.25 × |f_c − f| / f / ((r/r_c)^order − 1), the coarse
/// solve's nearest frequency against the fine one. The largest over the modes.
fn grid_convergence(fine: &(usize, Vec<f64>), coarse: &(usize, Vec<f64>), order: f64, layers: usize) -> ErrorEstimate {
    let n = ERROR_MODES.min(fine.1.len());
    let factor = (fine.0 as f64 / coarse.0 as f64).powf(order) - 1.0;
    let relative = fine.1[..n]
        .iter()
        .map(|&f| GCI_SAFETY * ((nearest(&coarse.1, f) - f) / f).abs() / factor.max(1e-12))
        .fold(0.0, f64::max);
    ErrorEstimate {
        relative,
        modes: n,
        order,
        method: format!(
            "grid convergence index (Roache 1998) against a solve at resolution {}, order {order:.1} observed over three solves, {layers} element layer(s) through walls",
            coarse.0
        ),
    }
}

/// Largest mesh (DOFs) built at an explicit `--resolution` that also gets the budget path's
/// error estimate: its two coarser solves then take under a second or two; a bigger one is
/// the user's own trade of time for accuracy, built as asked.
pub const EXPLICIT_ESTIMATE_MAX_DOFS: usize = 10_000;
/// An explicit resolution whose estimated frequency error is over this is warned about.
pub const EXPLICIT_WARN_ERROR: f64 = 0.01;

/// The error estimate of a build at an explicit resolution (when its mesh is small: see
/// [`EXPLICIT_ESTIMATE_MAX_DOFS`]) and what to warn about: a black-box tester's
/// `--resolution 6` on a 30 cm bar (351 DOFs) gave 100 modes up to 194 kHz without a word.
fn explicit_resolution_check(
    shape: &Shape,
    material: &Material,
    density: MeshDensity,
    modes: &Modes,
) -> (Option<ErrorEstimate>, Vec<String>) {
    if modes.dofs > EXPLICIT_ESTIMATE_MAX_DOFS {
        return (None, Vec::new());
    }
    let r = density.resolution;
    match discretisation_error(shape, material, density, &modes.frequencies_hz()) {
        Ok(e) if e.relative > EXPLICIT_WARN_ERROR => {
            let w = format!(
                "--resolution {r} is coarse for this shape: its frequencies are off by an estimated {:.1} % over the first {} modes (the higher modes more); raise it, or leave it out to mesh within the budget",
                100.0 * e.relative,
                e.modes
            );
            (Some(e), vec![w])
        }
        Ok(e) => (Some(e), Vec::new()),
        Err(e) => (
            None,
            vec![format!(
                "--resolution {r}: no error estimate ({e}); its modes may be far off: raise it, or leave it out to mesh within the budget"
            )],
        ),
    }
}

/// The error estimate of the finest of three solves (finest first): [`grid_convergence`]
/// with the [`observed_order`].
fn three_grid_estimate(solves: &[(usize, Vec<f64>); 3], layers: usize) -> ErrorEstimate {
    grid_convergence(&solves[0], &solves[1], observed_order(solves), layers)
}

/// The two coarser resolutions of an error estimate at `resolution`: about 0.8× and 0.64×.
fn coarser(resolution: usize) -> Option<(usize, usize)> {
    let r1 = ((resolution as f64 * 0.8).round() as usize).min(resolution.saturating_sub(1));
    let r2 = ((r1 as f64 * 0.8).round() as usize).min(r1.saturating_sub(1));
    (r2 >= 2).then_some((r1, r2))
}

/// Estimates the discretisation error of `freqs` (Hz, the elastic modes of `shape` meshed at
/// `density`) by two more, coarser solves at about 0.8× and 0.64× the resolution and the grid
/// convergence index ([`grid_convergence`]). An estimate: the layers through a thin wall are
/// the same in all three solves, so their part of the error is not seen (two layers keep it
/// small, see [`AUTO_LAYERS`]).
///
/// # Errors
/// As [`analyse`] for the coarse meshes; [`FemError::InvalidOptions`] below resolution 4.
pub fn discretisation_error(
    shape: &Shape,
    material: &Material,
    density: MeshDensity,
    freqs: &[f64],
) -> Result<ErrorEstimate, FemError> {
    let (r1, r2) = coarser(density.resolution).ok_or_else(|| {
        FemError::InvalidOptions(format!("resolution {} is too coarse for an error estimate", density.resolution))
    })?;
    let n = ERROR_MODES.min(freqs.len()) + 4;
    let coarse = |r| solve_frequencies(shape, material, MeshDensity { resolution: r, ..density }, n);
    Ok(three_grid_estimate(
        &[(density.resolution, freqs.to_vec()), (r1, coarse(r1)?), (r2, coarse(r2)?)],
        density.layers,
    ))
}

/// The mesh a build of `shape` gets by budget: [`AUTO_LAYERS`] layers through walls and
/// plates, and the finest resolution, in steps of about 12 % from 4 up to
/// [`MAX_AUTO_RESOLUTION`], that [`fits_budget`] with [`AUTO_DOFS`]. So a slender bar gets
/// several elements across its section (its torsion in tune) and a chunky block a mesh it can
/// solve (a 5 cm cube at 40 elements per side would need an 80 GiB factor).
///
/// # Errors
/// As [`mesh_shape`]; [`FemError::Mesh`] if even resolution 4 is over the budget.
pub fn choose_mesh(shape: &Shape) -> Result<MeshDensity, FemError> {
    let mut best = None;
    let mut r = 4;
    while r <= MAX_AUTO_RESOLUTION && fits_budget(shape, MeshDensity { resolution: r, layers: AUTO_LAYERS }, AUTO_DOFS)?
    {
        best = Some(r);
        r = (r * 9).div_ceil(8);
    }
    best.map(|resolution| MeshDensity { resolution, layers: AUTO_LAYERS })
        .ok_or_else(|| FemError::Mesh(format!("{} does not fit the build budget even at resolution 4", shape.kind())))
}

/// The resolution of [`choose_mesh`].
///
/// # Errors
/// As [`choose_mesh`].
pub fn choose_resolution(shape: &Shape) -> Result<usize, FemError> {
    Ok(choose_mesh(shape)?.resolution)
}

/// Whether `shape` meshed at `density` has at most `max_dofs` DOFs and a sparse factor
/// estimated ([`eigen::factor_bytes_estimate`]) within 90 % of [`eigen::MAX_FACTOR_BYTES`]
/// (10 % margin: the estimate is within 7 % of the real factor on the bar).
///
/// # Errors
/// As [`mesh_shape`] and [`eigen::factor_bytes_estimate`].
fn fits_budget(shape: &Shape, density: MeshDensity, max_dofs: usize) -> Result<bool, FemError> {
    let mesh = mesh_shape_layers(shape, density.resolution, density.layers)?;
    Ok(3 * mesh.nodes.len() <= max_dofs && eigen::factor_bytes_estimate(&mesh)? <= 0.9 * eigen::MAX_FACTOR_BYTES as f64)
}

/// Most refinements an accuracy target may ask for after the budget's solve.
const MAX_REFINEMENTS: usize = 3;
/// Largest step of one refinement (resolution ratio): a noisy estimate must not ask for an
/// enormous mesh at once.
const MAX_REFINE_STEP: f64 = 1.5;
/// Most DOFs an accuracy target may refine to: with the factor within
/// [`eigen::MAX_FACTOR_BYTES`], the Lanczos basis (2 × 320 vectors of 8 bytes per DOF, 1.5 GB
/// here) keeps the build within about 4 GiB.
pub const ACCURACY_DOFS: usize = 300_000;

/// The resolution predicted to bring an estimated error `error` at `resolution` down to
/// `target` (error ∝ h^order), with 10 % to spare.
fn resolution_for(resolution: usize, error: &ErrorEstimate, target: f64) -> usize {
    let scale = (error.relative / target).powf(1.0 / error.order) * 1.1;
    ((resolution as f64 * scale).ceil() as usize).max(resolution + 1)
}

impl BuildOptions {
    fn validate(&self) -> Result<(), FemError> {
        if self.max_modes == 0 || self.max_modes > MAX_BANK_MODES {
            return Err(FemError::InvalidOptions(format!(
                "max_modes must be in 1..={MAX_BANK_MODES}, found {}",
                self.max_modes
            )));
        }
        if let Some(f) = self.max_freq_hz {
            if !(f.is_finite() && f > 0.0) {
                return Err(FemError::InvalidOptions(format!("max_freq_hz must be > 0 Hz, found {f}")));
            }
        }
        if let Some(a) = self.accuracy {
            if !(a.is_finite() && a > 0.0 && a < 1.0) {
                return Err(FemError::InvalidOptions(format!(
                    "the accuracy must be a relative error in (0, 1), e.g. 0.002 for 0.2 %, found {a}"
                )));
            }
        }
        if self.strike_points == 0 || self.strike_points > MAX_BANK_POINTS {
            return Err(FemError::InvalidOptions(format!(
                "strike_points must be in 1..={}, found {}",
                MAX_BANK_POINTS, self.strike_points
            )));
        }
        Ok(())
    }
}

/// Why a bank could not be built. Messages say what to change.
#[derive(Debug, thiserror::Error)]
pub enum FemError {
    /// A dimension is invalid.
    #[error("invalid {shape}: {reason}")]
    InvalidShape {
        /// The shape kind.
        shape: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// The shape is not supported by this builder.
    #[error("the shape `{0}` is not supported yet; use bar, plate, block, circular-plate, tube, plugged-tube, bowl, cup, bell or sphere-shell, or import a mesh")]
    UnsupportedShape(String),
    /// A material constant is invalid.
    #[error("invalid material: {0}")]
    InvalidMaterial(String),
    /// An option is invalid.
    #[error("invalid build option: {0}")]
    InvalidOptions(String),
    /// The mesh cannot be used.
    #[error("bad mesh: {0}")]
    Mesh(String),
    /// A mesh file could not be parsed.
    #[error("cannot read mesh file, line {line}: {reason}")]
    MeshFile {
        /// 1-based line number (0 if not specific).
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// A factorisation failed.
    #[error("factorisation failed: {0}")]
    Factorization(String),
    /// The eigensolver hit its basis limit before the wanted modes converged.
    #[error("the eigensolver converged {converged} of {wanted} modes with a basis of {basis} vectors; ask for fewer modes or a lower max frequency")]
    NotConverged {
        /// Modes converged.
        converged: usize,
        /// Modes wanted (rigid included).
        wanted: usize,
        /// Basis size reached.
        basis: usize,
    },
    /// Not exactly six rigid-body modes: the object is not one free, connected solid.
    #[error("expected 6 rigid-body (zero) eigenvalues but found {found} ({eigenvalues:?} rad^2/s^2); the mesh may be disconnected (several pieces) or constrained")]
    RigidModes {
        /// How many near-zero eigenvalues were found.
        found: usize,
        /// The lowest eigenvalues, rad²/s².
        eigenvalues: Vec<f64>,
    },
    /// No elastic mode is in range.
    #[error("no elastic modes below the frequency limit; raise it (--max-freq)")]
    NoModes,
    /// The bank failed validation.
    #[error("the built bank is invalid: {0}")]
    Bank(#[from] PresetError),
}

/// The modes of a mesh.
#[derive(Clone, Debug)]
pub struct Modes {
    /// Elastic eigenvalues λ (rad²/s²), ascending, rigid modes removed.
    pub lambdas: Vec<f64>,
    /// The six rigid-body eigenvalues as computed (≈ 0), rad²/s².
    pub rigid_lambdas: Vec<f64>,
    /// Number of DOFs (3 per node).
    pub dofs: usize,
    /// Mass-normalised mode shapes, column-major: mode i is `vectors[i*dofs..(i+1)*dofs]`
    /// (units m·kg^(−1/2)).
    pub vectors: Vec<f64>,
    /// Block operator applications (sparse solves with `block` right-hand sides).
    pub iterations: usize,
    /// Final Lanczos basis size.
    pub basis: usize,
    /// First shift σ of the spectrum slicing, rad²/s².
    pub sigma: f64,
    /// Seconds spent assembling K and M.
    pub assembly_seconds: f64,
    /// Seconds spent in the sparse factorisations.
    pub factor_seconds: f64,
    /// Seconds in all.
    pub seconds: f64,
    /// The factor's fill-reducing ordering ([`eigen::Profile::ordering`]).
    pub ordering: &'static str,
}

impl Modes {
    /// Mode `i`'s shape (length `dofs`).
    pub fn mode(&self, i: usize) -> &[f64] {
        &self.vectors[i * self.dofs..(i + 1) * self.dofs]
    }

    /// Undamped frequencies in Hz.
    pub fn frequencies_hz(&self) -> Vec<f64> {
        self.lambdas.iter().map(|l| l.sqrt() / (2.0 * std::f64::consts::PI)).collect()
    }
}

/// What a build did and cost.
#[derive(Clone, Debug)]
pub struct BuildReport {
    /// Corner vertices of the mesh.
    pub vertices: usize,
    /// All nodes (corners + mid-edge), i.e. DOFs / 3.
    pub nodes: usize,
    /// 10-node tetrahedra.
    pub elements: usize,
    /// Degrees of freedom.
    pub dofs: usize,
    /// Elastic modes kept.
    pub modes: usize,
    /// The six rigid-body eigenvalues that were removed (rad²/s²).
    pub rigid_eigenvalues: Vec<f64>,
    /// Block Lanczos steps.
    pub iterations: usize,
    /// Lanczos basis size.
    pub basis: usize,
    /// Wall-clock seconds in all.
    pub seconds: f64,
    /// Of which in the factorisations.
    pub factor_seconds: f64,
    /// Peak resident memory of the process so far (Linux VmHWM), bytes, if known.
    pub peak_memory_bytes: Option<u64>,
    /// Estimated discretisation error of the frequencies, relative (largest over the first
    /// [`ERROR_MODES`] modes), when the resolution was chosen by budget
    /// ([`discretisation_error`]).
    pub error_estimate: Option<f64>,
    /// The mesh's resolution and least layers through walls.
    pub density: Option<MeshDensity>,
    /// What the user should know: e.g. an accuracy that the memory budget could not reach.
    pub warnings: Vec<String>,
}

/// Meshes a built-in shape with 10-node tetrahedra, `resolution` elements along its largest
/// dimension.
///
/// # Errors
/// [`FemError::InvalidShape`], [`FemError::InvalidOptions`] (resolution < 2) or
/// [`FemError::Mesh`].
pub fn mesh_shape(shape: &Shape, resolution: usize) -> Result<TetMesh, FemError> {
    Ok(mesh::mesh_with_geometry(shape, resolution)?.0)
}

/// [`mesh_shape`] with at least `min_layers` elements through the wall of the shells of
/// revolution (tube, bowl, sphere shell, cup, bell), for reference solves finer than the
/// default meshes.
///
/// # Errors
/// As [`mesh_shape`].
pub fn mesh_shape_layers(shape: &Shape, resolution: usize, min_layers: usize) -> Result<TetMesh, FemError> {
    Ok(mesh::mesh_with_layers(shape, resolution, min_layers.max(1))?.0)
}

/// Number of rigid-body modes of a free solid.
const RIGID: usize = 6;
/// Lanczos block size.
const BLOCK: usize = 8;
/// Eigenvalues each shift of the spectrum slicing aims at (see [`eigen::solve_sliced`]).
const SLICE: usize = 64;
/// Largest Lanczos basis of one shift.
const SLICE_BASIS: usize = 320;

/// Modal analysis of `mesh`: the lowest `opts.max_modes` elastic modes (at most up to
/// `opts.max_freq_hz`), mass-normalised, rigid modes checked and removed.
///
/// # Errors
/// [`FemError::InvalidMaterial`], [`FemError::Mesh`] (degenerate elements),
/// [`FemError::Factorization`], [`FemError::NotConverged`], [`FemError::RigidModes`] (not
/// exactly six zero eigenvalues) or [`FemError::NoModes`].
pub fn analyse(
    mesh: &TetMesh,
    material: &Material,
    opts: &BuildOptions,
    progress: &dyn Fn(&str, f32),
) -> Result<Modes, FemError> {
    analyse_within(mesh, material, opts, eigen::MAX_FACTOR_BYTES, progress)
}

/// [`analyse`] with another limit on the sparse factor (bytes): for reference solves larger
/// than a bank build may take.
///
/// # Errors
/// As [`analyse`].
pub fn analyse_within(
    mesh: &TetMesh,
    material: &Material,
    opts: &BuildOptions,
    max_factor_bytes: usize,
    progress: &dyn Fn(&str, f32),
) -> Result<Modes, FemError> {
    material.validate()?;
    opts.validate()?;
    let t0 = Instant::now();
    progress("assemble", 0.0);
    let sys = assemble(mesh, material)?;
    let assembly_seconds = t0.elapsed().as_secs_f64();
    let (lo, hi) = mesh.bounds();
    let diag2: f64 = (0..3).map(|i| (hi[i] - lo[i]).powi(2)).sum();
    // A shift below the lowest elastic mode of most objects (a slender bar has λ₁ of the
    // order of 1e-3·γ/L²): keeps K − σM positive definite and the wanted modes near σ.
    let sigma = -1e-2 * material.specific_modulus() / diag2.max(f64::MIN_POSITIVE);
    let nev = opts.max_modes + RIGID;
    let eopts = eigen::EigenOptions {
        nev,
        lambda_max: opts.max_freq_hz.map(|f| (2.0 * std::f64::consts::PI * f).powi(2)),
        sigma,
        block: BLOCK,
        tol: 1e-8,
        max_basis: SLICE_BASIS,
        slice: SLICE,
        max_factor_bytes,
    };
    progress("factorise", 0.0);
    let res = eigen::solve(&sys, &eopts, progress)?;
    let n = sys.n;
    // Rigid modes: |λ| far below the shift (their computed values are rounding noise).
    let sigma = res.sigma;
    let thr = 1e-4 * sigma.abs();
    let found = res.lambdas.iter().filter(|l| l.abs() < thr).count();
    let lowest_elastic_ok = res.lambdas.get(RIGID).is_none_or(|l| l.abs() >= thr);
    if found != RIGID || !lowest_elastic_ok {
        return Err(FemError::RigidModes { found, eigenvalues: res.lambdas.iter().take(RIGID + 3).copied().collect() });
    }
    let lmax = eopts.lambda_max.unwrap_or(f64::INFINITY);
    let keep: Vec<usize> =
        (RIGID..res.lambdas.len()).filter(|&i| res.lambdas[i] <= lmax).take(opts.max_modes).collect();
    if keep.is_empty() {
        return Err(FemError::NoModes);
    }
    let mut vectors = Vec::with_capacity(keep.len() * n);
    for &i in &keep {
        vectors.extend((0..n).map(|r| res.vectors[(r, i)]));
    }
    Ok(Modes {
        lambdas: keep.iter().map(|&i| res.lambdas[i]).collect(),
        rigid_lambdas: res.lambdas[..RIGID].to_vec(),
        dofs: n,
        vectors,
        iterations: res.iterations,
        basis: res.basis,
        sigma,
        assembly_seconds,
        factor_seconds: res.factor_seconds,
        seconds: t0.elapsed().as_secs_f64(),
        ordering: res.profile.ordering,
    })
}

/// Surface-normal gains (`[point][mode]`, not normalised) of `modes` at `points` on `mesh`.
pub fn strike_gains(mesh: &TetMesh, modes: &Modes, points: &[[f64; 3]]) -> Vec<Vec<f64>> {
    let surface = strike::Surface::new(mesh);
    points
        .iter()
        .map(|&p| match surface.locate(mesh, p) {
            Some((nodes, w, nrm)) => (0..modes.lambdas.len())
                .map(|m| {
                    let v = modes.mode(m);
                    let mut g = 0.0;
                    for (k, &nd) in nodes.iter().enumerate() {
                        let d = 3 * nd as usize;
                        g += w[k] * (v[d] * nrm[0] + v[d + 1] * nrm[1] + v[d + 2] * nrm[2]);
                    }
                    g
                })
                .collect(),
            None => vec![0.0; modes.lambdas.len()],
        })
        .collect()
}

/// A built-in shape's solve.
struct Solved {
    density: MeshDensity,
    mesh: TetMesh,
    geom: mesh::Geometry,
    modes: Modes,
    error: Option<ErrorEstimate>,
    warnings: Vec<String>,
}

/// The solve of a build by budget: the mesh of [`choose_mesh`], its error estimate, and with
/// `opts.accuracy` a finer solve where the estimate is over it. The error estimate is best
/// effort: if a coarse solve fails, the bank is still built, without one.
fn solve_by_budget(
    shape: &Shape,
    material: &Material,
    opts: &BuildOptions,
    progress: &dyn Fn(&str, f32),
) -> Result<Solved, FemError> {
    let density = choose_mesh(shape)?;
    let (mesh, geom) = mesh::mesh_with_layers(shape, density.resolution, density.layers)?;
    let modes = analyse(&mesh, material, opts, progress)?;
    let mut prev = (density.resolution, modes.frequencies_hz());
    let mut solved = Solved { density, mesh, geom, modes, error: None, warnings: Vec::new() };
    let no_estimate = |solved: &mut Solved, why: &str| {
        if let Some(t) = opts.accuracy {
            solved.warnings.push(format!(
                "the accuracy {:.2} % could not be checked ({why}); built with the budget's mesh",
                100.0 * t
            ));
        }
    };
    let mut error = match discretisation_error(shape, material, density, &prev.1) {
        Ok(e) => e,
        Err(e) => {
            no_estimate(&mut solved, &format!("no error estimate: {e}"));
            return Ok(solved);
        }
    };
    let Some(target) = opts.accuracy else {
        solved.error = Some(error);
        return Ok(solved);
    };
    // Refine towards the resolution predicted to reach the target (error ∝ h^order, the order
    // observed on the budget's three solves), at most 1.5× per step, as far as the DOFs
    // ([`ACCURACY_DOFS`]) and the factor allow; again if the new estimate (against the
    // previous solve) is still over it. A refinement that fails keeps the previous solve.
    let fits = |r: usize| fits_budget(shape, MeshDensity { resolution: r, ..density }, ACCURACY_DOFS);
    let mut limited = None;
    for _ in 0..MAX_REFINEMENTS {
        if error.relative <= target {
            break;
        }
        let want = resolution_for(prev.0, &error, target);
        let step = want.min((prev.0 as f64 * MAX_REFINE_STEP).ceil() as usize);
        let (mut lo, mut hi) = (prev.0, step);
        if !fits(hi)? {
            while hi - lo > 1 {
                let mid = (lo + hi) / 2;
                if fits(mid)? {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            hi = lo;
            limited = Some(want);
        }
        if hi == prev.0 {
            break;
        }
        let fine = MeshDensity { resolution: hi, ..density };
        let attempt = mesh::mesh_with_layers(shape, fine.resolution, fine.layers)
            .and_then(|(mesh, geom)| Ok((analyse(&mesh, material, opts, progress)?, mesh, geom)));
        let (modes, mesh, geom) = match attempt {
            Ok(done) => done,
            Err(e) => {
                solved
                    .warnings
                    .push(format!("the refinement to resolution {hi} failed ({e}); kept resolution {}", prev.0));
                break;
            }
        };
        let next = (hi, modes.frequencies_hz());
        error = grid_convergence(&next, &prev, error.order, fine.layers);
        prev = next;
        solved = Solved { density: fine, mesh, geom, modes, error: None, warnings: solved.warnings };
    }
    if error.relative > target {
        let limit = match limited {
            Some(want) => format!(
                " (the build's memory budget, {} DOFs and a 1.5 GiB factor, allows no finer mesh; about resolution {want} would be needed)",
                ACCURACY_DOFS
            ),
            None => String::new(),
        };
        solved.warnings.push(format!(
            "the accuracy {:.2} % was not reached: resolution {}{limit} gives an estimated {:.2} %",
            100.0 * target,
            prev.0,
            100.0 * error.relative
        ));
    }
    solved.error = Some(error);
    Ok(solved)
}

/// Builds a bank for a built-in shape: mesh, modal analysis, strike points and gains.
///
/// `progress(stage, fraction)` is called with stages `"mesh"`, `"assemble"`,
/// `"factorise"`, `"eigen"` (fraction of the basis limit used) and `"strike"`.
///
/// # Errors
/// Any [`FemError`]; the bank is validated with [`Bank::validate`] before it is returned.
pub fn build_bank(
    id: &str,
    name: &str,
    shape: &Shape,
    material: &Material,
    opts: &BuildOptions,
    progress: &dyn Fn(&str, f32),
) -> Result<(Bank, BuildReport), FemError> {
    let t0 = start_build(material, opts)?;
    progress("mesh", 0.0);
    let Solved { density, mesh, geom, modes, error, warnings } = if opts.auto_resolution {
        solve_by_budget(shape, material, opts, progress)?
    } else {
        let density = MeshDensity { resolution: opts.resolution, layers: 1 };
        let (mesh, geom) = mesh::mesh_with_layers(shape, density.resolution, density.layers)?;
        let modes = analyse(&mesh, material, opts, progress)?;
        let (error, warnings) = explicit_resolution_check(shape, material, density, &modes);
        Solved { density, mesh, geom, modes, error, warnings }
    };
    let resolution = density.resolution;
    progress("strike", 0.0);
    let path = strike::strike_path(&geom, opts.strike_points);
    let positions: Vec<[f64; 3]> = path.iter().map(|p| p.position).collect();
    let gains = strike_gains(&mesh, &modes, &positions);
    let dims = shape.dimensions();
    let dims_text =
        shape.field_names().iter().zip(&dims).map(|(n, v)| format!("{n} {v} m")).collect::<Vec<_>>().join(", ");
    let frame = match shape {
        Shape::Bar { .. } | Shape::UndercutBar { .. } | Shape::Plate { .. } | Shape::Block { .. } => {
            "Frame: box [0, length] x [0, width] x [0, thickness]; strike points on the top face; xy = (x/length, y/width)."
        }
        Shape::CircularPlate { .. } => {
            "Frame: centre on the z axis, z in [0, thickness]; strike points on a spiral over the top face; xy = top view scaled to the radius."
        }
        Shape::Bowl { .. } => {
            "Frame: pole at the origin, opening up (+z); strike points on a spiral over the outer surface; xy = top view scaled to the radius."
        }
        _ => "Frame: axis of revolution z; strike points on a helix over the outer surface; xy = (angle / 360 deg, arc-length fraction along the profile).",
    };
    let description = format!(
        "{} ({dims_text}), computed by FEM for E = {:.4e} Pa, rho = {} kg/m^3, nu = {}. {frame}",
        shape.kind(),
        material.young,
        material.density,
        material.poisson
    );
    let provenance = format!(
        "FEM (struck-presets fem): {} 10-node tetrahedra (Zienkiewicz et al. 2013 §6.6), {} nodes ({} corner vertices), {} DOFs, resolution {}{}; consistent mass; spectrum slicing with block shift-invert Lanczos, full reorthogonalisation and Sturm-count checks (Ericsson & Ruhe 1980; Grimes, Lewis & Simon 1994) on faer sparse LDL^T factorisations ({} ordering), first shift sigma = {:.4e} rad^2/s^2; 6 rigid modes removed; built {}",
        mesh.tets.len(),
        mesh.nodes.len(),
        mesh.corners,
        modes.dofs,
        resolution,
        if density.layers > 1 { format!(" with at least {} element layers through walls and plates", density.layers) } else { String::new() },
        modes.ordering,
        modes.sigma,
        today()
    );
    let provenance = match &error {
        Some(e) => format!(
            "{provenance}; estimated discretisation error of the frequencies ~{:.2} % over the first {} modes ({}; it does not see the error of the element layers through a wall, the same in every solve)",
            100.0 * e.relative,
            e.modes,
            e.method
        ),
        None => provenance,
    };
    let parts = BankParts {
        description,
        provenance,
        dimensions_m: dims,
        size_m: shape.size(),
        points: path
            .iter()
            .map(|p| StrikePoint {
                label: p.label.clone(),
                xy: [p.xy[0].clamp(0.0, 1.0) as f32, p.xy[1].clamp(0.0, 1.0) as f32],
                position_m: [p.position[0] as f32, p.position[1] as f32, p.position[2] as f32],
            })
            .collect(),
        surface: drawing_surface(shape, resolution),
    };
    let bank = fem_bank(id, name, material, &modes, &gains, parts);
    let (bank, mut report) = finish_bank(bank, &mesh, &modes, t0, progress)?;
    report.error_estimate = error.as_ref().map(|e| e.relative);
    report.density = Some(density);
    report.warnings = warnings;
    Ok((bank, report))
}

/// Most triangles of the drawing surface a shape's bank carries (a few tens of kB of JSON).
pub const DRAW_TRIANGLES: usize = 6000;

/// A coarse drawing of `shape` (the boundary of a coarser mesh of it, the finest of
/// resolutions up to `resolution` and 16 whose boundary has at most [`DRAW_TRIANGLES`]
/// triangles), or `None` when no mesh that coarse can be made.
pub fn drawing_surface(shape: &Shape, resolution: usize) -> Option<presets::DrawSurface> {
    let mut r = resolution.min(16);
    while r >= 4 {
        if let Ok((mesh, _)) = mesh::mesh_with_geometry(shape, r) {
            if let Some(d) = strike::Surface::new(&mesh).drawing(&mesh, DRAW_TRIANGLES) {
                return Some(d);
            }
        }
        r = r * 3 / 4;
    }
    None
}

/// The preamble of every bank build (shared by [`build_bank`] and the imports): starts the
/// clock, then checks the material and the options.
pub(crate) fn start_build(material: &Material, opts: &BuildOptions) -> Result<Instant, FemError> {
    let t0 = Instant::now();
    material.validate()?;
    opts.validate()?;
    Ok(t0)
}

/// The parts of a bank that depend on where the mesh came from (a built-in shape or an
/// imported mesh).
pub(crate) struct BankParts {
    /// What the bank models.
    pub description: String,
    /// How it was computed.
    pub provenance: String,
    /// The reference dimensions, m.
    pub dimensions_m: Vec<f64>,
    /// The reference size, m.
    pub size_m: f64,
    /// Strike points, one per row of the gains.
    pub points: Vec<StrikePoint>,
    /// A drawing of the object.
    pub surface: Option<presets::DrawSurface>,
}

/// A bank of `modes` with `gains` (`[point][mode]`, not normalised): the fields every FEM
/// build fills the same way (the material as reference, eigenvalues, gains, frequency
/// labels) and the `parts` that differ.
pub(crate) fn fem_bank(
    id: &str,
    name: &str,
    material: &Material,
    modes: &Modes,
    gains: &[Vec<f64>],
    parts: BankParts,
) -> Bank {
    Bank {
        schema_version: presets::SCHEMA_VERSION,
        id: id.to_string(),
        name: name.to_string(),
        description: parts.description,
        provenance: parts.provenance,
        reference: BankReference {
            specific_modulus: material.specific_modulus(),
            poisson: material.poisson,
            density: material.density,
            dimensions_m: parts.dimensions_m,
            size_m: parts.size_m,
        },
        lambdas: modes.lambdas.clone(),
        points: parts.points,
        gains: gains.iter().map(|r| r.iter().map(|&g| g as f32).collect()).collect(),
        mode_labels: modes.frequencies_hz().iter().map(|f| format!("{f:.1} Hz")).collect(),
        surface: parts.surface,
        recorded_strike: None,
    }
}

/// Normalises and validates a freshly built bank and reports how it was made (shared by
/// [`build_bank`] and [`import::build_bank_from_mesh`]).
pub(crate) fn finish_bank(
    mut bank: Bank,
    mesh: &TetMesh,
    modes: &Modes,
    t0: Instant,
    progress: &dyn Fn(&str, f32),
) -> Result<(Bank, BuildReport), FemError> {
    bank.normalize_gains();
    bank.validate()?;
    progress("done", 1.0);
    let report = BuildReport {
        vertices: mesh.corners,
        nodes: mesh.nodes.len(),
        elements: mesh.tets.len(),
        dofs: modes.dofs,
        modes: modes.lambdas.len(),
        rigid_eigenvalues: modes.rigid_lambdas.clone(),
        iterations: modes.iterations,
        basis: modes.basis,
        seconds: t0.elapsed().as_secs_f64(),
        factor_seconds: modes.factor_seconds,
        peak_memory_bytes: peak_memory_bytes(),
        error_estimate: None,
        density: None,
        warnings: Vec::new(),
    };
    Ok((bank, report))
}

/// Peak resident set size of this process (Linux `/proc/self/status` VmHWM), bytes.
pub fn peak_memory_bytes() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Today's UTC date as YYYY-MM-DD (civil-from-days, H. Hinnant's algorithm).
pub(crate) fn today() -> String {
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0);
    let z = (secs / 86_400) as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    format!("{:04}-{:02}-{:02}", if m <= 2 { y + 1 } else { y }, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Frequencies whose error is exactly C·h^p (h = 1/r), mode i at 100·(i+1) Hz with its
    /// own C: the observed order and the error estimate come out as the closed form says.
    fn power_law(r: usize, p: f64) -> (usize, Vec<f64>) {
        let h = 1.0 / r as f64;
        (r, (0..24).map(|i| 100.0 * (i + 1) as f64 * (1.0 + (2.0 + 0.1 * i as f64) * h.powf(p))).collect())
    }

    #[test]
    fn the_observed_order_and_the_estimate_follow_a_power_law() {
        for p in [2.2, 2.5, 2.9] {
            let solves = [power_law(44, p), power_law(35, p), power_law(28, p)];
            let order = observed_order(&solves);
            // The modes' C differ, so the RMS change is a weighted mix: still the order.
            assert!((order - p).abs() < 0.02, "order {order} for {p}");
            let est = three_grid_estimate(&solves, 2);
            // The true largest error of the finest solve, and the safety factor 1.25 over it.
            let truth = (0..20).map(|i| (2.0 + 0.1 * i as f64) * (1.0f64 / 44.0).powf(p)).fold(0.0, f64::max);
            let ratio = est.relative / truth;
            assert!((ratio - GCI_SAFETY).abs() < 0.03, "estimate {:.3e} vs {truth:.3e} at p = {p}", est.relative);
        }
        // Orders outside the range are held to it: h⁵ reads as 3, h^1.5 as 2.
        assert_eq!(observed_order(&[power_law(44, 5.0), power_law(35, 5.0), power_law(28, 5.0)]), ORDER_RANGE.1);
        assert_eq!(observed_order(&[power_law(44, 1.5), power_law(35, 1.5), power_law(28, 1.5)]), ORDER_RANGE.0);
    }

    #[test]
    fn an_estimate_needs_two_coarser_resolutions() {
        assert_eq!(coarser(44), Some((35, 28)));
        assert_eq!(coarser(4), Some((3, 2)));
        assert_eq!(coarser(3), None);
    }
}
