//! Thin-walled surfaces against refined solves (issue 14, item 1): a closed triangle surface
//! of a bowl, a cup or a tube, written here by revolving the object's meridian outline (the
//! way a CAD export facets it), meshed as a user's STL is (`import_surface`), against the
//! built-in shape of the same geometry meshed by its own revolved mesher, refined and with
//! several elements through the wall.
//!
//! `cargo run --release -p struck-fem --example thin_wall -- CASE [MESHER] [REF_RES REF_LAYERS [RESOLUTION]]`
//! CASE: bowl | cup | tube; MESHER: auto (default) | voxel | none (the reference only);
//! RESOLUTION: as `bank build --resolution` (default: by the DOF budget). With STL_OUT=FILE in
//! the environment it only writes the case's surface there as an ASCII STL.
//! Prints the mesh, the time and peak memory of the import + solve, then the first 20 elastic
//! modes against the reference (nearest frequency).

use std::f64::consts::PI;
use std::time::Instant;

use fem::import::{import_surface, ImportOptions, SurfaceMesher};
use fem::{analyse, analyse_within, mesh_shape_layers, BuildOptions, Material, Shape, TriSurface};

#[path = "../tests/support/outline.rs"]
mod outline;
#[path = "../tests/support/reference.rs"]
mod reference;
use outline::{arc, join, line, revolve};

struct Case {
    shape: Shape,
    material: Material,
    surface: TriSurface,
}

fn case(name: &str) -> Case {
    let glass = Material { young: 63e9, density: 2500.0, poisson: 0.22 };
    match name {
        // The glass bowl: hemisphere, outer radius 0.08 m, wall 4 mm, flat rim.
        "bowl" => {
            let (r, w) = (0.08, 0.004);
            let outline = join(vec![arc([0.0, r], r, 0.0, PI / 2.0, 48), arc([0.0, r], r - w, PI / 2.0, 0.0, 48)]);
            Case { shape: Shape::Bowl { radius: r, wall: w }, material: glass, surface: revolve(&outline, 160) }
        }
        // A porcelain-like cup: radius 4 cm, height 10 cm, wall 3 mm, the built-in cup's fillet.
        "cup" => {
            let (r, h, w): (f64, f64, f64) = (0.04, 0.1, 0.003);
            let f = (0.2 * r).min(0.5 * h).max(2.0 * w);
            let outline = join(vec![
                line([0.0, 0.0], [r - f, 0.0], 16),
                arc([r - f, f], f, 0.0, PI / 2.0, 12),
                line([r, f], [r, h], 48),
                line([r - w, h], [r - w, f], 48),
                arc([r - f, f], f - w, PI / 2.0, 0.0, 12),
                line([r - f, w], [0.0, w], 16),
            ]);
            Case {
                shape: Shape::Cup { radius: r, height: h, wall: w },
                material: glass,
                surface: revolve(&outline, 128),
            }
        }
        // A steel tube 0.3 m long, outer radius 2 cm, wall 2 mm, open ends.
        "tube" => {
            let (l, r, w) = (0.3, 0.02, 0.002);
            let outline = join(vec![
                line([r - w, 0.0], [r, 0.0], 1),
                line([r, 0.0], [r, l], 120),
                line([r - w, l], [r - w, 0.0], 120),
            ]);
            Case {
                shape: Shape::Tube { length: l, outer_radius: r, wall: w },
                material: Material::STEEL,
                surface: revolve(&outline, 64),
            }
        }
        other => panic!("unknown case {other}: bowl, cup or tube"),
    }
}

fn peak_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .map(|l| l.split_whitespace().nth(1).unwrap_or("0").parse::<f64>().unwrap_or(0.0))
        })
        .unwrap_or(0.0)
        / 1024.0
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map_or("bowl", String::as_str);
    let mesher = args.get(1).map_or("auto", String::as_str);
    let ref_res: usize = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(64);
    let ref_layers: usize = args.get(3).and_then(|a| a.parse().ok()).unwrap_or(3);
    let resolution: Option<usize> = args.get(4).and_then(|a| a.parse().ok());
    let c = case(name);
    if let Some(path) = std::env::var_os("STL_OUT") {
        // The surface as a user would give it to `struck bank build --mesh` (ASCII STL, m).
        let mut stl = String::from("solid thin_wall\n");
        for t in &c.surface.triangles {
            let [a, b, d] = t.map(|i| c.surface.vertices[i as usize]);
            stl.push_str("facet normal 0 0 0\nouter loop\n");
            for v in [a, b, d] {
                stl.push_str(&format!("vertex {:e} {:e} {:e}\n", v[0], v[1], v[2]));
            }
            stl.push_str("endloop\nendfacet\n");
        }
        stl.push_str("endsolid thin_wall\n");
        std::fs::write(&path, stl).expect("write STL_OUT");
        return;
    }
    let quiet = |_: &str, _: f32| {};
    const MODES: usize = 20;
    let opts = BuildOptions { max_modes: MODES + 4, ..BuildOptions::default() };
    let mut got = None;
    if mesher != "none" {
        let t0 = Instant::now();
        let m = if mesher == "voxel" { SurfaceMesher::Voxel } else { SurfaceMesher::Auto };
        let imp = import_surface(
            c.surface.clone(),
            "generated",
            &ImportOptions { mesher: m, resolution, ..ImportOptions::default() },
            &quiet,
        )
        .expect("import");
        let modes = analyse(&imp.mesh, &c.material, &opts, &quiet).expect("analysis");
        let secs = t0.elapsed().as_secs_f64();
        println!("{name} {mesher}: {}", imp.summary);
        println!(
            "{name} {mesher}: {} DOFs, import + solve {secs:.1} s, peak memory {:.0} MiB, surface {} triangles",
            modes.dofs,
            peak_mib(),
            c.surface.triangles.len()
        );
        got = Some(modes.frequencies_hz());
    }
    if let (Some(f), "bowl") = (&got, name) {
        // The bowl also against the independent axisymmetric reference (the bowl in
        // another glass: the frequencies scale with √(E/ρ) at the same ν).
        let r = reference::reference("bowl");
        assert_eq!((&r.shape, r.material.poisson), (&c.shape, c.material.poisson));
        let scale = (c.material.young / c.material.density / (r.material.young / r.material.density)).sqrt();
        let axi: Vec<f64> = r.frequencies_hz.iter().map(|x| x * scale).collect();
        let mut e: Vec<f64> = reference::errors(&f[..MODES], &axi).iter().map(|x| 100.0 * x.abs()).collect();
        e.sort_by(f64::total_cmp);
        println!(
            "{name} {mesher}: against the axisymmetric reference: max error {:.3} %, median {:.3} % over {MODES} modes",
            e[MODES - 1],
            e[MODES / 2]
        );
    }
    let t0 = Instant::now();
    let mesh = mesh_shape_layers(&c.shape, ref_res, ref_layers).expect("reference mesh");
    let reference = analyse_within(&mesh, &c.material, &opts, 16 << 30, &quiet).expect("reference analysis");
    println!(
        "{name} reference: built-in {:?} at resolution {ref_res}, >= {ref_layers} layers: {} DOFs, {:.1} s",
        c.shape,
        reference.dofs,
        t0.elapsed().as_secs_f64()
    );
    let rf = reference.frequencies_hz();
    let Some(f) = got else {
        println!("{:?}", &rf[..MODES.min(rf.len())]);
        return;
    };
    let mut errs = Vec::new();
    for (i, &want) in rf.iter().take(MODES).enumerate() {
        let near = f.iter().copied().min_by(|a, b| (a - want).abs().total_cmp(&(b - want).abs())).unwrap_or(f64::NAN);
        let e = 100.0 * (near / want - 1.0);
        println!("  mode {:2}: reference {want:9.2} Hz, {mesher} {near:9.2} Hz, {e:+.3} %", i + 1);
        errs.push(e.abs());
    }
    let mut sorted = errs.clone();
    sorted.sort_by(f64::total_cmp);
    println!(
        "{name} {mesher}: max error {:.3} %, median {:.3} % over {} modes",
        sorted[sorted.len() - 1],
        sorted[sorted.len() / 2],
        sorted.len()
    );
}
