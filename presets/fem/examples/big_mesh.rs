//! Writes a built-in shape's tetrahedral mesh as a Gmsh 2.2 ASCII file of 4-node tetrahedra
//! (its corner vertices; the importer adds the mid-edge nodes), for trying meshes of any
//! size through `struck bank build --mesh` (issue 14: a 30,000-vertex mesh, ≈ 600k DOFs).
//!
//! `cargo run --release -p struck-fem --example big_mesh -- SHAPE RES OUT.msh`, SHAPE one of
//! bowl (R 0.08 m, wall 4 mm), block (5 cm cube), bar (0.4 × 0.02 × 0.02 m).

use fem::{mesh::mesh_shape_unlimited, Shape};
use std::io::Write;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [shape, res, out] = args.as_slice() else {
        eprintln!("usage: big_mesh SHAPE RES OUT.msh (SHAPE: bowl, block or bar)");
        std::process::exit(2);
    };
    let shape = match shape.as_str() {
        "bowl" => Shape::Bowl { radius: 0.08, wall: 0.004 },
        "block" => Shape::Block { length: 0.05, width: 0.05, height: 0.05 },
        "bar" => Shape::Bar { length: 0.4, width: 0.02, thickness: 0.02 },
        other => {
            eprintln!("unknown shape {other} (bowl, block or bar)");
            std::process::exit(2);
        }
    };
    let Ok(res) = res.parse::<usize>() else {
        eprintln!("RES must be a whole number of elements along the largest side");
        std::process::exit(2);
    };
    // Any size: the build's vertex limit is what these meshes are made to test.
    let mesh = match mesh_shape_unlimited(&shape, res, 1) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    };
    let mut text = String::new();
    text.push_str("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n");
    text.push_str(&format!("{}\n", mesh.corners));
    for (i, p) in mesh.nodes[..mesh.corners].iter().enumerate() {
        text.push_str(&format!("{} {:.17e} {:.17e} {:.17e}\n", i + 1, p[0], p[1], p[2]));
    }
    text.push_str(&format!("$EndNodes\n$Elements\n{}\n", mesh.tets.len()));
    for (i, t) in mesh.tets.iter().enumerate() {
        text.push_str(&format!("{} 4 2 1 1 {} {} {} {}\n", i + 1, t[0] + 1, t[1] + 1, t[2] + 1, t[3] + 1));
    }
    text.push_str("$EndElements\n");
    let written = std::fs::File::create(out).and_then(|mut f| f.write_all(text.as_bytes()));
    if let Err(e) = written {
        eprintln!("cannot write {out}: {e}");
        std::process::exit(1);
    }
    eprintln!(
        "{out}: {} corner vertices, {} tetrahedra ({} nodes, {} DOFs with mid-edge nodes)",
        mesh.corners,
        mesh.tets.len(),
        mesh.nodes.len(),
        3 * mesh.nodes.len()
    );
}
