//! Mesh import: Gmsh 2.2/4.1 readers, OBJ/STL surfaces, their checks, voxelisation, and the
//! modes of voxelised solids against the built-in mesher and beam theory.

use fem::import::{
    build_bank_from_import, import_mesh_file, import_surface, ImportOptions, MeshFileKind, SurfaceMesher,
};
use fem::{self, BuildOptions, FemError, Material, Shape, TetMesh, TriSurface};
use std::f64::consts::PI;
use std::fmt::Write as _;

fn quiet(_: &str, _: f32) {}

// ---------------------------------------------------------------- Gmsh

/// The mesh as Gmsh 2.2 ASCII (4-node tetrahedra, node ids 1..).
fn to_msh22(m: &TetMesh) -> String {
    let mut s = String::from("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n");
    writeln!(s, "{}", m.corners).unwrap();
    for (i, p) in m.nodes[..m.corners].iter().enumerate() {
        writeln!(s, "{} {:e} {:e} {:e}", i + 1, p[0], p[1], p[2]).unwrap();
    }
    s += "$EndNodes\n$Elements\n";
    writeln!(s, "{}", m.tets.len()).unwrap();
    for (e, t) in m.tets.iter().enumerate() {
        writeln!(s, "{} 4 2 1 1 {} {} {} {}", e + 1, t[0] + 1, t[1] + 1, t[2] + 1, t[3] + 1).unwrap();
    }
    s + "$EndElements\n"
}

/// The same mesh as Gmsh 4.1 ASCII, made awkward on purpose: non-contiguous node tags
/// (7·i + 3), nodes split over a point block, a parametric surface block and a volume block,
/// all 10 nodes of each tetrahedron (type 11), elements split over blocks with boundary
/// triangles in between, and an $Entities section to skip.
fn to_msh41(m: &TetMesh) -> String {
    let tag = |i: usize| 7 * i as u64 + 3;
    let n = m.nodes.len();
    let mut s = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 1 1\n1 0 0 0 1 1 1 0\n1 0 0 0 1 1 1 1 1 1\n$EndEntities\n");
    let blocks = [(0, 3), (3, n / 2), (n / 2, n)];
    writeln!(s, "$Nodes\n3 {n} {} {}", tag(0), tag(n - 1)).unwrap();
    for (b, &(a, z)) in blocks.iter().enumerate() {
        let (dim, param) = [(0, 0), (2, 1), (3, 0)][b];
        writeln!(s, "{dim} {} {param} {}", b + 1, z - a).unwrap();
        for i in a..z {
            writeln!(s, "{}", tag(i)).unwrap();
        }
        for p in &m.nodes[a..z] {
            write!(s, "{:e} {:e} {:e}", p[0], p[1], p[2]).unwrap();
            s += if param == 1 { " 0.5 0.25\n" } else { "\n" };
        }
    }
    s += "$EndNodes\n";
    let half = m.tets.len() / 2;
    let total = m.tets.len() + 1;
    writeln!(s, "$Elements\n3 {total} 1 {total}").unwrap();
    let tet_line = |s: &mut String, e: usize, t: &[u32; 10]| {
        write!(s, "{}", e + 1).unwrap();
        for &v in t {
            write!(s, " {}", tag(v as usize)).unwrap();
        }
        s.push('\n');
    };
    writeln!(s, "3 1 11 {half}").unwrap();
    for (e, t) in m.tets[..half].iter().enumerate() {
        tet_line(&mut s, e, t);
    }
    writeln!(s, "2 1 2 1\n{} {} {} {}", m.tets.len() + 1, tag(0), tag(1), tag(2)).unwrap();
    writeln!(s, "3 1 11 {}", m.tets.len() - half).unwrap();
    for (e, t) in m.tets[half..].iter().enumerate() {
        tet_line(&mut s, half + e, t);
    }
    s + "$EndElements\n"
}

#[test]
fn gmsh_41_and_22_give_the_same_modes() {
    let shape = Shape::Bar { length: 0.2, width: 0.02, thickness: 0.01 };
    let mesh = fem::mesh_shape(&shape, 8).unwrap();
    let m22 = fem::read_gmsh(&to_msh22(&mesh)).unwrap();
    let m41 = fem::read_gmsh(&to_msh41(&mesh)).unwrap();
    assert_eq!(m22.tets.len(), mesh.tets.len());
    assert_eq!(m41.tets.len(), mesh.tets.len());
    assert_eq!(m41.corners, mesh.corners);
    assert!((m41.volume() / (0.2 * 0.02 * 0.01) - 1.0).abs() < 1e-9);
    let opts = BuildOptions { max_modes: 6, ..BuildOptions::default() };
    let a = fem::analyse(&m22, &Material::STEEL, &opts, &quiet).unwrap();
    let b = fem::analyse(&m41, &Material::STEEL, &opts, &quiet).unwrap();
    for (x, y) in a.lambdas.iter().zip(&b.lambdas) {
        assert!((x / y - 1.0).abs() < 1e-9, "{x} vs {y}");
    }
}

#[test]
fn gmsh_41_hand_written_cube() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/cube41.msh")).unwrap();
    let mesh = fem::read_gmsh(&text).unwrap();
    assert_eq!(mesh.tets.len(), 5);
    assert_eq!(mesh.corners, 8);
    assert!((mesh.volume() - 1.0).abs() < 1e-12);
}

/// The error and its line (0 if the error has none).
fn gmsh_err(text: &str) -> (usize, String) {
    match fem::read_gmsh(text) {
        Err(FemError::MeshFile { line, reason }) => (line, reason),
        other => panic!("expected a MeshFile error, got {other:?}"),
    }
}

#[test]
fn broken_gmsh_41_files_name_the_line() {
    let good = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/cube41.msh")).unwrap();
    let lines: Vec<&str> = good.lines().collect();
    let line_of = |s: &str| lines.iter().position(|l| *l == s).unwrap() + 1;
    // Truncated inside $Nodes.
    let cut = lines[..line_of("$Nodes") + 6].join("\n");
    let (line, reason) = gmsh_err(&cut);
    assert!(reason.contains("ends inside $Nodes"), "{reason}");
    assert!(line > line_of("$Nodes"), "line {line}");
    // Header count larger than the blocks hold.
    let (line, reason) = gmsh_err(&good.replace("3 8 10 40", "3 9 10 40"));
    assert!(reason.contains("9 nodes") && reason.contains("hold 8"), "{reason}");
    assert_eq!(line, line_of("$EndNodes"));
    // Block count too small: the next block header is read as coordinates / end marker.
    let (line, reason) = gmsh_err(&good.replace("0 1 0 2\n10", "0 1 0 3\n10"));
    assert!(line > 0, "{reason}");
    // Unknown node tag in an element.
    let (line, reason) = gmsh_err(&good.replace("6 31 32 39 40", "6 31 32 39 41"));
    assert!(reason.contains("node 41"), "{reason}");
    assert_eq!(line, line_of("6 31 32 39 40"));
    // Binary flag.
    let (line, reason) = gmsh_err(&good.replace("4.1 0 8", "4.1 1 8"));
    assert!(reason.contains("binary"), "{reason}");
    assert_eq!(line, 2);
    // Version 4.0 (a different layout) is refused.
    let (line, reason) = gmsh_err(&good.replace("4.1 0 8", "4 0 8"));
    assert!(reason.contains("not supported"), "{reason}");
    assert_eq!(line, 2);
    // A bad number.
    let (line, reason) = gmsh_err(&good.replace("1 1 1\n", "1 x 1\n"));
    assert!(reason.contains("bad coordinate"), "{reason}");
    assert_eq!(line, line_of("1 1 1"));
    // Too few node tags for a tetrahedron.
    let (line, _) = gmsh_err(&good.replace("5 20 32 38 39", "5 20 32 38"));
    assert_eq!(line, line_of("5 20 32 38 39"));
    // A 2.2 file truncated inside $Elements.
    let m = fem::mesh_shape(&Shape::Block { length: 0.1, width: 0.1, height: 0.1 }, 2).unwrap();
    let t22 = to_msh22(&m);
    let cut: String = t22.lines().take(t22.lines().count() - 3).collect::<Vec<_>>().join("\n");
    let (_, reason) = gmsh_err(&cut);
    assert!(reason.contains("ends inside $Elements"), "{reason}");
}

// ---------------------------------------------------------------- OBJ / STL writers

/// A box [0, a] × [0, b] × [0, c] as an OBJ with quads (outward, counter-clockwise), using
/// `v/vt/vn` and negative indices on some faces.
fn box_obj(a: f64, b: f64, c: f64) -> String {
    let mut s = String::from("# box\no box\n");
    for k in 0..8 {
        writeln!(s, "v {} {} {}", a * (k & 1) as f64, b * ((k >> 1) & 1) as f64, c * (k >> 2) as f64).unwrap();
    }
    s += "vt 0 0\nvn 0 0 1\n";
    // Faces by corner index (x + 2y + 4z), outward.
    let faces = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    for (i, f) in faces.iter().enumerate() {
        s += "f";
        for &v in f {
            match i % 3 {
                0 => write!(s, " {}", v + 1).unwrap(),
                1 => write!(s, " {}/1/1", v + 1).unwrap(),
                _ => write!(s, " {}//1", v as i64 - 8).unwrap(), // negative: relative to the end
            }
        }
        s.push('\n');
    }
    s
}

/// A closed cylinder of `n` segments along x from 0 to `len`, radius `r`, as OBJ (the caps
/// are single n-gons, fan-triangulated by the reader).
fn cylinder_obj(len: f64, r: f64, n: usize) -> String {
    let mut s = String::new();
    for end in 0..2 {
        for k in 0..n {
            let a = 2.0 * PI * k as f64 / n as f64;
            writeln!(s, "v {} {} {}", len * end as f64, r * a.cos(), r * a.sin()).unwrap();
        }
    }
    for k in 0..n {
        let (i, j) = (k + 1, (k + 1) % n + 1);
        writeln!(s, "f {i} {j} {} {}", j + n, i + n).unwrap();
    }
    s += "f";
    for k in (1..=n).rev() {
        write!(s, " {k}").unwrap();
    }
    s += "\nf";
    for k in 1..=n {
        write!(s, " {}", k + n).unwrap();
    }
    s + "\n"
}

/// A UV sphere of radius `r` centred at `c`; `inward` reverses every face.
fn sphere_tris(r: f64, c: [f64; 3], inward: bool, s: &mut TriSurface) {
    let (nu, nv) = (24, 12);
    let base = s.vertices.len() as u32;
    s.vertices.push([c[0], c[1], c[2] - r]);
    for j in 1..nv {
        let th = PI * j as f64 / nv as f64 - PI / 2.0;
        for i in 0..nu {
            let ph = 2.0 * PI * i as f64 / nu as f64;
            s.vertices.push([c[0] + r * th.cos() * ph.cos(), c[1] + r * th.cos() * ph.sin(), c[2] + r * th.sin()]);
        }
    }
    s.vertices.push([c[0], c[1], c[2] + r]);
    let ring = |j: usize, i: usize| base + 1 + ((j - 1) * nu + i % nu) as u32;
    let top = base + 1 + ((nv - 1) * nu) as u32;
    let mut push = |t: [u32; 3]| s.triangles.push(if inward { [t[0], t[2], t[1]] } else { t });
    for i in 0..nu {
        push([base, ring(1, i + 1), ring(1, i)]);
        push([top, ring(nv - 1, i), ring(nv - 1, i + 1)]);
        for j in 1..nv - 1 {
            push([ring(j, i), ring(j, i + 1), ring(j + 1, i + 1)]);
            push([ring(j, i), ring(j + 1, i + 1), ring(j + 1, i)]);
        }
    }
}

fn stl_ascii(s: &TriSurface) -> String {
    let mut o = String::from("solid test\n");
    for t in 0..s.triangles.len() {
        o += "  facet normal 0 0 0\n    outer loop\n";
        for p in s.corners(t) {
            writeln!(o, "      vertex {:e} {:e} {:e}", p[0], p[1], p[2]).unwrap();
        }
        o += "    endloop\n  endfacet\n";
    }
    o + "endsolid test\n"
}

fn stl_binary(s: &TriSurface, header: &[u8]) -> Vec<u8> {
    let mut o = vec![0u8; 80];
    o[..header.len()].copy_from_slice(header);
    o.extend((s.triangles.len() as u32).to_le_bytes());
    for t in 0..s.triangles.len() {
        o.extend([0u8; 12]);
        for p in s.corners(t) {
            for c in p {
                o.extend((c as f32).to_le_bytes());
            }
        }
        o.extend([0u8; 2]);
    }
    o
}

fn mesh_err<T>(r: Result<T, FemError>) -> String {
    match r {
        Err(e) => e.to_string(),
        Ok(_) => panic!("expected an error"),
    }
}

// ---------------------------------------------------------------- readers

#[test]
fn obj_quads_vt_vn_and_negative_indices() {
    let s = fem::read_obj(&box_obj(0.3, 0.03, 0.02)).unwrap();
    assert_eq!(s.vertices.len(), 8);
    assert_eq!(s.triangles.len(), 12);
    assert!((s.signed_volume() - 0.3 * 0.03 * 0.02).abs() < 1e-15);
    // Cylinder caps are 48-gons.
    let c = fem::read_obj(&cylinder_obj(0.1, 0.01, 48)).unwrap();
    assert_eq!(c.triangles.len(), 48 * 2 + 2 * 46);
    // Errors name the line.
    let e = mesh_err(fem::read_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n"));
    assert!(e.contains("line 4") && e.contains("out of range"), "{e}");
    let e = mesh_err(fem::read_obj("v 0 0 nan\n"));
    assert!(e.contains("line 1"), "{e}");
    let e = mesh_err(fem::read_obj("v 0 0 0\nv 1 0 0\nf 1 2\n"));
    assert!(e.contains("line 3") && e.contains("three"), "{e}");
    let e = mesh_err(fem::read_obj("v 0 0 0\n"));
    assert!(e.contains("no faces"), "{e}");
}

#[test]
fn stl_ascii_and_binary_agree_even_with_a_solid_header() {
    let mut s = TriSurface::default();
    sphere_tris(0.05, [0.0; 3], false, &mut s);
    let a = fem::read_stl(stl_ascii(&s).as_bytes()).unwrap();
    // A binary STL whose header starts with "solid" (as some exporters write).
    let b = fem::read_stl(&stl_binary(&s, b"solid exported by a careless tool")).unwrap();
    assert_eq!(a.vertices.len(), s.vertices.len());
    assert_eq!(b.vertices.len(), s.vertices.len());
    assert_eq!(a.triangles.len(), s.triangles.len());
    assert!((a.signed_volume() / b.signed_volume() - 1.0).abs() < 1e-5);
    // Truncated binary: not a valid size and no ASCII facets.
    let mut bin = stl_binary(&s, b"solid x");
    bin.truncate(bin.len() - 7);
    let e = mesh_err(fem::read_stl(&bin));
    assert!(e.contains("truncated"), "{e}");
    let e = mesh_err(fem::read_stl(b"hello, world"));
    assert!(e.contains("not an STL"), "{e}");
    // ASCII facet with four vertices.
    let quad = "solid q\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid q\n";
    let e = mesh_err(fem::read_stl(quad.as_bytes()));
    assert!(e.contains("line 9") && e.contains("4 vertices"), "{e}");
}

// ---------------------------------------------------------------- surface checks

fn obj(text: &str) -> TriSurface {
    fem::read_obj(text).unwrap()
}

#[test]
fn bad_surfaces_are_clear_errors() {
    let boxed = box_obj(1.0, 1.0, 1.0);
    // Open: drop the last face (two triangles).
    let open: String = boxed.lines().take(boxed.lines().count() - 1).map(|l| format!("{l}\n")).collect();
    let e = mesh_err(fem::check_surface(&mut obj(&open)));
    assert!(e.contains("not closed: 4 open edges") && e.contains("near ("), "{e}");
    // Non-manifold: two boxes sharing an edge.
    let mut s = obj(&boxed);
    let mut t = obj(&boxed);
    for p in &mut t.vertices {
        p[0] += 1.0;
        p[1] += 1.0;
    }
    let n = s.vertices.len() as u32;
    s.vertices.extend(t.vertices);
    s.triangles.extend(t.triangles.iter().map(|tr| tr.map(|v| v + n)));
    s.merge_vertices(0.0);
    let e = mesh_err(fem::check_surface(&mut s));
    assert!(e.contains("not manifold"), "{e}");
    // Self-intersecting: two overlapping boxes.
    let mut s = obj(&boxed);
    let mut t = obj(&boxed);
    for p in &mut t.vertices {
        // Offsets that make the crossings generic (not on the quads' diagonals).
        p[0] += 0.5;
        p[1] += 0.3;
        p[2] += 0.2;
    }
    let n = s.vertices.len() as u32;
    s.vertices.extend(t.vertices);
    s.triangles.extend(t.triangles.iter().map(|tr| tr.map(|v| v + n)));
    let e = mesh_err(fem::check_surface(&mut s));
    assert!(e.contains("intersects itself"), "{e}");
    // Flat.
    let e = mesh_err(fem::check_surface(&mut obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 3 2\n")));
    assert!(e.contains("no volume"), "{e}");
    // Many zero-area triangles.
    let mut s = obj(&boxed);
    for _ in 0..20 {
        s.triangles.push([0, 0, 1]);
    }
    let e = mesh_err(fem::check_surface(&mut s));
    assert!(e.contains("zero area"), "{e}");
    // Empty.
    assert!(mesh_err(fem::check_surface(&mut TriSurface::default())).contains("empty"));
}

#[test]
fn orientation_is_repaired_and_cavities_point_inward() {
    // Outer sphere with half its faces reversed, inner sphere (a cavity) listed outward.
    let mut s = TriSurface::default();
    sphere_tris(0.05, [0.0; 3], false, &mut s);
    for t in s.triangles.iter_mut().step_by(2) {
        t.swap(1, 2);
    }
    sphere_tris(0.02, [0.003, 0.0, 0.0], false, &mut s);
    s.triangles.push([0, 0, 1]); // one degenerate triangle: dropped with a warning
    let rep = fem::check_surface(&mut s).unwrap();
    assert_eq!(rep.pieces, 2);
    assert_eq!(rep.bodies, 1, "a cavity's wall is not a body");
    assert_eq!(rep.degenerate_dropped, 1);
    assert!(rep.warnings.iter().any(|w| w.contains("reversed")), "{:?}", rep.warnings);
    // Outer minus inner (the polyhedral volumes): the cavity is oriented inward.
    let mut outer = TriSurface::default();
    sphere_tris(0.05, [0.0; 3], false, &mut outer);
    let mut inner = TriSurface::default();
    sphere_tris(0.02, [0.0; 3], false, &mut inner);
    let want = outer.signed_volume() - inner.signed_volume();
    assert!((rep.volume / want - 1.0).abs() < 1e-9, "{} vs {want}", rep.volume);
    // The voxeliser leaves the cavity empty: volume within a few % at resolution 20.
    let imp = import_surface(
        s,
        "test",
        &ImportOptions { resolution: Some(20), mesher: SurfaceMesher::Voxel, ..ImportOptions::default() },
        &quiet,
    )
    .unwrap();
    let v = imp.mesh.volume();
    println!("hollow sphere: mesh {v:.4e} m^3, surface {want:.4e} m^3; {}", imp.summary);
    assert!((v / want - 1.0).abs() < 0.05, "voxel volume {v} vs {want}");
}

#[test]
fn voxel_limits_and_thin_objects() {
    let s = obj(&box_obj(1.0, 0.5, 0.5));
    let o = |r| ImportOptions { resolution: Some(r), mesher: SurfaceMesher::Voxel, ..ImportOptions::default() };
    let e = mesh_err(import_surface(s.clone(), "t", &o(1), &quiet));
    assert!(e.contains("at least 2"), "{e}");
    let e = mesh_err(import_surface(s.clone(), "t", &o(300), &quiet));
    assert!(e.contains("lower resolution"), "{e}");
    let e = mesh_err(import_surface(s.clone(), "t", &o(80), &quiet));
    assert!(e.contains("over the limit of 60000") && e.contains("resolution of about"), "{e}");
    // A sheet thinner than a voxel: nothing inside.
    let e = mesh_err(import_surface(obj(&box_obj(1.0, 1.0, 0.001)), "t", &o(10), &quiet));
    assert!(e.contains("thinner than a voxel"), "{e}");
    // Two separate boxes: the larger is kept, with a warning.
    let mut two = obj(&box_obj(0.5, 0.5, 0.5));
    let mut small = obj(&box_obj(0.2, 0.2, 0.2));
    for p in &mut small.vertices {
        p[0] += 0.8;
    }
    let n = two.vertices.len() as u32;
    two.vertices.extend(small.vertices);
    two.triangles.extend(small.triangles.iter().map(|t| t.map(|v| v + n)));
    let imp = import_surface(two, "t", &o(10), &quiet).unwrap();
    assert!(imp.warnings.iter().any(|w| w.contains("kept the largest")), "{:?}", imp.warnings);
    assert!((imp.mesh.volume() - 0.125).abs() < 1e-9, "{}", imp.mesh.volume());
    // Unknown extension.
    let e = mesh_err(MeshFileKind::of(std::path::Path::new("part.step")));
    assert!(e.contains(".msh") && e.contains(".obj") && e.contains(".stl"), "{e}");
    assert_eq!(MeshFileKind::of(std::path::Path::new("A.STL")).unwrap(), MeshFileKind::Stl);
}

// ---------------------------------------------------------------- modes

/// Frequencies (Hz) of the lowest `n` elastic modes of a mesh.
fn freqs(mesh: &TetMesh, n: usize) -> Vec<f64> {
    let opts = BuildOptions { max_modes: n, ..BuildOptions::default() };
    fem::analyse(mesh, &Material::STEEL, &opts, &quiet).unwrap().frequencies_hz()
}

#[test]
fn voxelised_box_bar_matches_the_built_in_bar() {
    // 0.3 × 0.03 × 0.02 m at resolution 30: h = 10 mm, 30 × 3 × 2 voxels, no staircase.
    let (l, w, t) = (0.3, 0.03, 0.02);
    let dir = std::env::temp_dir().join(format!("struck-mesh-import-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bar.OBJ");
    // In millimetres, read with scale 0.001.
    std::fs::write(&path, box_obj(1000.0 * l, 1000.0 * w, 1000.0 * t)).unwrap();
    let imp = import_mesh_file(
        &path,
        &ImportOptions { scale: 1e-3, resolution: Some(30), ..ImportOptions::default() },
        &quiet,
    )
    .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    assert!((imp.mesh.volume() / (l * w * t) - 1.0).abs() < 1e-9);
    let direct = fem::mesh_shape(&Shape::Bar { length: l, width: w, thickness: t }, 30).unwrap();
    assert_eq!(imp.mesh.corners, direct.corners, "same vertex lattice");
    let n = 8;
    let fv = freqs(&imp.mesh, n);
    let fd = freqs(&direct, n);
    println!("voxel bar (Hz): {:?}", fv.iter().map(|f| f.round()).collect::<Vec<_>>());
    println!("shape bar (Hz): {:?}", fd.iter().map(|f| f.round()).collect::<Vec<_>>());
    for k in 0..n {
        let abs = fv[k] / fd[k] - 1.0;
        let ratio = (fv[k] / fv[0]) / (fd[k] / fd[0]) - 1.0;
        println!(
            "mode {k}: {:.1} vs {:.1} Hz ({:+.2} %), ratio to f1 {:+.2} %",
            fv[k],
            fd[k],
            100.0 * abs,
            100.0 * ratio
        );
        assert!(abs.abs() < 0.03, "mode {k}: {} vs {} Hz", fv[k], fd[k]);
        assert!(ratio.abs() < 0.02, "mode {k} ratio off by {ratio}");
    }
}

#[test]
fn voxelised_cylinder_bends_like_a_beam() {
    // Solid steel cylinder, length 0.3 m, radius 15 mm (L/d = 10), 48 segments.
    let (len, r) = (0.3, 0.015);
    let surf = obj(&cylinder_obj(len, r, 48));
    let res = 40;
    let imp = import_surface(surf, "OBJ", &ImportOptions { resolution: Some(res), ..ImportOptions::default() }, &quiet)
        .unwrap();
    println!("{}; warnings {:?}", imp.summary, imp.warnings);
    let opts = BuildOptions { max_modes: 6, resolution: res, ..BuildOptions::default() };
    let (bank, report) =
        build_bank_from_import("cyl", "Cylinder", "cylinder.obj", &imp, &Material::STEEL, &opts, &quiet).unwrap();
    println!(
        "cylinder: {} vertices, {} tets, {} dofs, {:.2} s; f = {:?} Hz",
        report.vertices,
        report.elements,
        report.dofs,
        report.seconds,
        bank.frequencies_hz().iter().map(|f| f.round()).collect::<Vec<_>>()
    );
    assert_eq!(report.rigid_eigenvalues.len(), 6);
    assert!(bank.num_points() >= 64, "{} strike points", bank.num_points());
    // Euler–Bernoulli free–free: f = (βL)²/(2πL²)·sqrt(E I/(ρ A)), I/A = r²/4 (Blevins 1979
    // Table 8-1). The first bending mode is a degenerate pair (round section).
    let m = Material::STEEL;
    let f_eb = 4.730_040_745f64.powi(2) / (2.0 * PI * len * len) * (m.young * r * r / (4.0 * m.density)).sqrt();
    // Timoshenko beam (shear coefficient 6(1+ν)/(7+6ν), Cowper 1966) at L/d = 10: f1 is
    // 0.9746 × Euler–Bernoulli (computed with a 600-element Timoshenko beam model).
    let f_timo = 0.9746 * f_eb;
    let f = bank.frequencies_hz();
    let err_eb = f[0] / f_eb - 1.0;
    let err = f[0] / f_timo - 1.0;
    println!(
        "f1 = {:.1} Hz: Euler-Bernoulli {f_eb:.1} Hz ({:+.2} %), Timoshenko {f_timo:.1} Hz ({:+.2} %)",
        f[0],
        100.0 * err_eb,
        100.0 * err
    );
    // Tolerance: the section is 4 voxels across, its boundary snapped onto the 48-gon but
    // partly left as a staircase (volume −3 %), which changes I/A by a few per cent.
    assert!(err.abs() < 0.03, "f1 {:.1} Hz vs Timoshenko {f_timo:.1} Hz", f[0]);
    assert!(err_eb.abs() < 0.06, "f1 {:.1} Hz vs Euler-Bernoulli {f_eb:.1} Hz", f[0]);
    assert!((f[1] / f[0] - 1.0).abs() < 0.02, "the first bending pair splits: {} vs {}", f[0], f[1]);
    assert!(bank.gains.iter().all(|g| g.iter().all(|x| x.is_finite())));
}

#[test]
fn automatic_resolution_fits_the_vertex_budget() {
    use fem::voxel::{auto_resolution, DEFAULT_VERTEX_BUDGET};
    let cyl = obj(&cylinder_obj(0.3, 0.015, 48));
    let mut ball = TriSurface::default();
    sphere_tris(0.05, [0.0; 3], false, &mut ball);
    let (rc, rs) = (auto_resolution(&cyl, DEFAULT_VERTEX_BUDGET), auto_resolution(&ball, DEFAULT_VERTEX_BUDGET));
    println!("automatic resolution: cylinder L/d = 10 -> {rc}, sphere -> {rs}");
    assert!((60..=100).contains(&rc) && (15..=24).contains(&rs), "{rc} {rs}");
    let imp = import_surface(ball, "t", &ImportOptions::default(), &quiet).unwrap();
    println!("{}", imp.summary);
    assert!(
        imp.mesh.corners <= 2 * DEFAULT_VERTEX_BUDGET && imp.mesh.corners >= DEFAULT_VERTEX_BUDGET / 2,
        "{}",
        imp.mesh.corners
    );
}

/// Separate bodies are named: of a surface whose bodies lie apart, the largest is kept with a
/// warning that says so (two spheres side by side); bodies whose boxes overlap are kept
/// together with a warning (a ball loose in a hollow ball's cavity: nested shells, two
/// bodies); a tetrahedral mesh of two blocks sharing no node is refused before the solve. One
/// hollow ball is one body.
#[test]
fn separate_bodies_are_named_not_solved() {
    let mut two = TriSurface::default();
    sphere_tris(0.02, [0.0; 3], false, &mut two);
    sphere_tris(0.02, [0.1, 0.0, 0.0], false, &mut two);
    assert_eq!(fem::check_surface(&mut two.clone()).unwrap().bodies, 2);
    // Equal bodies: one is kept, with a warning naming both and the way out; the mesh
    // is one sphere (the volume check does not mistake the other for a thin part).
    let imp = import_surface(two, "test", &ImportOptions { resolution: Some(12), ..ImportOptions::default() }, &quiet)
        .unwrap();
    assert!(
        imp.warnings.iter().any(|w| w.contains("2 separate bodies") && w.contains("own file")),
        "{:?}",
        imp.warnings
    );
    let one = 4.0 / 3.0 * PI * 0.02f64.powi(3);
    assert!((imp.mesh.volume() / one - 1.0).abs() < 0.1, "{} vs one sphere {one}", imp.mesh.volume());

    let mut rattle = TriSurface::default();
    sphere_tris(0.05, [0.0; 3], false, &mut rattle);
    sphere_tris(0.04, [0.0; 3], true, &mut rattle);
    sphere_tris(0.01, [0.005, 0.0, 0.0], false, &mut rattle);
    let rep = fem::check_surface(&mut rattle).unwrap();
    assert_eq!((rep.pieces, rep.bodies), (3, 2), "{rep:?}");
    // Bodies whose boxes overlap are kept together (as shells that touch must be), with a
    // warning: the hollow ball and the ball inside.
    assert!(rep.warnings.iter().any(|w| w.contains("kept together")), "{:?}", rep.warnings);
    let mut parts = TriSurface::default();
    sphere_tris(0.05, [0.0; 3], false, &mut parts);
    sphere_tris(0.04, [0.0; 3], true, &mut parts);
    sphere_tris(0.01, [0.005, 0.0, 0.0], false, &mut parts);
    assert!((rep.volume / parts.signed_volume() - 1.0).abs() < 1e-9, "{} vs {}", rep.volume, parts.signed_volume());

    let block = fem::mesh_shape(&Shape::Block { length: 0.02, width: 0.02, height: 0.02 }, 4).unwrap();
    let mut pair = block.clone();
    let off = pair.nodes.len() as u32;
    pair.nodes.extend(block.nodes.iter().map(|p| [p[0] + 0.1, p[1], p[2]]));
    pair.tets.extend(block.tets.iter().map(|t| t.map(|n| n + off)));
    let e = mesh_err(fem::import::check_one_body(&pair));
    assert!(e.contains("2 separate bodies") && e.contains(&format!("{0}, {0} tetrahedra", block.tets.len())), "{e}");
    assert!(fem::import::check_one_body(&block).is_ok());
}

/// A file in other units is warned about with the --scale that fixes it: a 5 cm cube saved
/// in millimetres reads as 50 m; a 0.5 mm object is far above hearing; 5 cm is fine.
#[test]
fn wrong_units_are_warned_about_with_the_scale_hint() {
    let w = fem::import::units_warning(50.0, 1.0).expect("50 m is not a percussion object");
    assert!(w.contains("--scale 0.001"), "{w}");
    assert!(fem::import::units_warning(5e-4, 1.0).is_some_and(|w| w.contains("--scale")));
    assert!(fem::import::units_warning(0.05, 1.0).is_none());
    let imp = import_surface(
        fem::read_obj(&box_obj(50.0, 50.0, 50.0)).unwrap(),
        "OBJ",
        &ImportOptions { resolution: Some(4), ..ImportOptions::default() },
        &quiet,
    )
    .unwrap();
    assert!(imp.warnings.iter().any(|w| w.contains("--scale 0.001")), "{:?}", imp.warnings);
}

/// A block of `l` × `w` × `h` with a fin `t` thick and `f` tall standing on the middle of its
/// top face along y, as OBJ: the profile in x–z extruded along y, caps triangulated by hand
/// (the profile is not convex, so no fan from one corner).
fn block_with_fin_obj(l: f64, w: f64, h: f64, t: f64, f: f64) -> String {
    let (x1, x2) = (0.5 * (l - t), 0.5 * (l + t));
    let profile = [[0.0, 0.0], [l, 0.0], [l, h], [x2, h], [x2, h + f], [x1, h + f], [x1, h], [0.0, h]];
    let mut s = String::from("o fin\n");
    for y in [0.0, w] {
        for [x, z] in profile {
            writeln!(s, "v {x} {y} {z}").unwrap();
        }
    }
    // Caps (1-based): the block part fanned from corner 1, then the fin.
    let cap = [[1, 2, 3], [1, 3, 4], [1, 4, 7], [1, 7, 8], [7, 4, 5], [7, 5, 6]];
    for [a, b, c] in cap {
        writeln!(s, "f {a} {b} {c}").unwrap(); // y = 0: the profile runs counter-clockwise in x–z, facing −y
        writeln!(s, "f {} {} {}", a + 8, c + 8, b + 8).unwrap();
    }
    for i in 0..8 {
        let j = (i + 1) % 8;
        writeln!(s, "f {} {} {} {}", i + 1, i + 9, j + 9, j + 1).unwrap();
    }
    s
}

/// Parts thinner than two voxels are warned about (a voxel mesh cannot follow them: a 1 mm fin
/// on a 6 cm block at 2.4 mm voxels rang 28 % high, silently); the block alone at the same
/// voxels is not.
#[test]
fn parts_thinner_than_the_voxels_are_warned_about() {
    let o = ImportOptions { resolution: Some(25), mesher: SurfaceMesher::Voxel, ..ImportOptions::default() };
    let fin = obj(&block_with_fin_obj(0.06, 0.04, 0.03, 0.001, 0.02));
    let imp = import_surface(fin, "t", &o, &quiet).unwrap();
    assert!(!imp.warnings.iter().any(|w| w.contains("reversed")), "{:?}", imp.warnings);
    let w: Vec<&String> = imp.warnings.iter().filter(|w| w.contains("thinner than two voxels")).collect();
    assert_eq!(w.len(), 1, "{:?}", imp.warnings);
    // The fin's two sides are about 13 % of the area; it is 1 mm thick; 2.4 mm voxels; two
    // voxels across it need resolution 25 × 2 × 2.4 / 1 = 120.
    assert!(w[0].starts_with("13 % ") && w[0].contains("1.00e-3 m") && w[0].contains("--resolution 120"), "{}", w[0]);
    let block = obj(&box_obj(0.06, 0.04, 0.03));
    let imp = import_surface(block, "t", &o, &quiet).unwrap();
    assert!(!imp.warnings.iter().any(|w| w.contains("thinner than two voxels")), "{:?}", imp.warnings);
}
