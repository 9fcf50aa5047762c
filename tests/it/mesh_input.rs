//! Mesh input from OBJ and PLY faces.

use crate::util::*;
use pcsss::formats::{self, Select};
use pcsss::geom::mesh::{Polygons, TriMesh};

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

/// An OBJ grid of `w` x `h` cells, each a quad, or two triangles where
/// `split(cell)`, faces in order.
fn grid_obj(w: usize, h: usize, split: impl Fn(usize) -> bool) -> String {
    let mut s = String::new();
    for y in 0..=h {
        for x in 0..=w {
            s += &format!("v {x} {y} 0\n");
        }
    }
    let v = |x: usize, y: usize| y * (w + 1) + x + 1;
    for y in 0..h {
        for x in 0..w {
            let (a, b, c, d) = (v(x, y), v(x + 1, y), v(x + 1, y + 1), v(x, y + 1));
            if split(y * w + x) {
                s += &format!("f {a} {b} {c}\nf {a} {c} {d}\n");
            } else {
                s += &format!("f {a} {b} {c} {d}\n");
            }
        }
    }
    s
}

#[test]
fn many_faces_triangulate_in_order_and_cover_the_mesh() {
    // More faces than one parallel chunk of triangulation (16,384),
    // quads and triangles mixed.
    let (w, h) = (200, 120);
    let split = |c: usize| c % 7 == 3;
    let c = formats::read_cloud(grid_obj(w, h, split).as_bytes(), &Select::All).unwrap();
    let m = TriMesh::from_cloud(&c).unwrap();
    let faces = m.polys.len();
    assert_eq!(faces, w * h + (0..w * h).filter(|&c| split(c)).count());
    // Each face owns its polygon's n - 2 triangles, in face order, and
    // they use its corners only.
    assert_eq!(m.face_tris.len(), faces + 1);
    for f in 0..faces {
        let ts = m.face_tris[f] as usize..m.face_tris[f + 1] as usize;
        let corners = m.polys.offsets[f] as u32..m.polys.offsets[f + 1] as u32;
        assert_eq!(ts.len(), corners.len() - 2, "face {f}");
        for t in ts {
            assert!(m.tris[t].iter().all(|k| corners.contains(k)), "face {f}");
        }
    }
    // The triangles tile the grid: every cell's area once.
    let area: f64 = m.tri_areas().iter().sum();
    assert!((area - (w * h) as f64).abs() < 1e-9, "{area}");
}

#[test]
fn the_first_face_at_fault_is_named() {
    // 20,001 triangles over 3 vertices; faces 20,000 and 19,000 (in
    // different parallel chunks) point past the vertices: the earlier is
    // named.
    let faces = 20_001;
    let mut text = format!("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face {faces}\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n");
    for f in 0..faces {
        text += match f {
            19_000 => "3 0 1 8\n",
            20_000 => "3 0 1 9\n",
            _ => "3 0 1 2\n",
        };
    }
    let c = formats::read_cloud(text.as_bytes(), &Select::All).unwrap();
    let e = Polygons::of(&c).unwrap_err().to_string();
    assert!(
        e.contains("face 19000 refers to vertex 8, but the mesh has 3 vertices"),
        "{e}"
    );
}
