//! Mesh input from OBJ and PLY faces.

use crate::util::*;
use pcsss::formats::{self, Select};
use pcsss::geom::mesh::Polygons;

fn read(path: &str) -> pcsss::Cloud {
    let b = std::fs::read(fixtures().join(path)).unwrap();
    formats::read_cloud(&b[..], &Select::All).unwrap()
}

#[test]
fn obj_cube_has_eight_points_six_quads_twelve_triangles() {
    let c = read("mesh/cube.obj");
    assert_eq!(c.len(), 8);
    let p = Polygons::of(&c).unwrap();
    assert_eq!(p.len(), 6);
    assert!((0..6).all(|f| p.polygon(f).len() == 4));
    assert_eq!(p.triangle_count(), 12);
    let m = pcsss::geom::mesh::TriMesh::from_cloud(&c).unwrap();
    assert_eq!(m.tri_faces(), vec![0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5]);
    assert!(m.tri_areas().iter().all(|&a| (a - 0.5).abs() < 1e-15));
    // tobj numbers vertices in order of first use: check by position.
    let pos = c.points().vec3_f32("P").unwrap();
    let corners: Vec<[f32; 3]> = p.polygon(0).iter().map(|&i| pos[i as usize]).collect();
    assert_eq!(
        corners,
        vec![
            [0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 0.0, 0.0]
        ]
    );
    let corners: Vec<[f32; 3]> = p.polygon(3).iter().map(|&i| pos[i as usize]).collect();
    assert_eq!(
        corners,
        vec![
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 1.0, 1.0],
            [1.0, 0.0, 1.0]
        ]
    );
    // As PLY and back: the same polygons.
    let back = from_bytes(&to_bytes(&c, ASCII));
    assert_eq!(Polygons::of(&back).unwrap(), p);
}

#[test]
fn a_mesh_without_faces_is_a_clear_error() {
    let c = read("mesh/no_faces.obj");
    let e = Polygons::of(&c).unwrap_err().to_string();
    assert!(e.contains("no faces"), "{e}");
    let c = pcsss::Cloud::with_points(3);
    assert!(Polygons::of(&c)
        .unwrap_err()
        .to_string()
        .contains("no faces"));
}

#[test]
fn faces_pointing_at_missing_vertices_are_an_error() {
    let text = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n";
    let c = formats::read_cloud(&text[..], &Select::All).unwrap();
    let e = Polygons::of(&c).unwrap_err().to_string();
    assert!(
        e.contains("face 0 refers to vertex 7, but the mesh has 3 vertices"),
        "{e}"
    );
}

#[test]
fn obj_sniffing_and_bad_obj() {
    let e = formats::read_cloud(&b"v 0 0 0\nf 1 2 3\n"[..], &Select::All)
        .unwrap_err()
        .to_string();
    assert!(e.contains("OBJ"), "{e}");
}
