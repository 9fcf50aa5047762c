//! facet: flat and smooth normals on the cube and spheres, goldens,
//! a mesh's own vertices.

use crate::util::*;
use pcsss::geom::mesh::TriMesh;
use pcsss::stages::facet::{self, Mode, Weight};
use pcsss::stages::scatter::PtareaMode;

#[test]
fn facet_flat_on_the_cube_gives_axis_normals() {
    let mesh = cube();
    let m = TriMesh::from_cloud(&mesh).unwrap();
    let mut c = scatter_n(&mesh, 600, 2, PtareaMode::Prim);
    let params = facet::Params {
        mode: Mode::Flat,
        weight: Weight::Angle,
        cusp: 60.0,
        weld: true,
    };
    facet::facet_points(&mut c, &m, &params).unwrap();
    let p = c.points().vec3_f64("P").unwrap();
    let n = c.points().vec3_f64("N").unwrap();
    for (q, nn) in p.iter().zip(&n) {
        // The outward axis normal of the face the point lies on.
        let k = (0..3).find(|&k| nn[k] != 0.0).unwrap();
        assert!(
            nn[k].abs() == 1.0 && nn.iter().filter(|x| **x != 0.0).count() == 1,
            "{nn:?}"
        );
        assert_eq!(
            q[k],
            if nn[k] > 0.0 { 1.0 } else { 0.0 },
            "point {q:?} normal {nn:?}"
        );
    }
    // Smooth with a 60 degree cusp keeps the 90 degree edges sharp.
    let mut s = c.clone();
    facet::facet_points(
        &mut s,
        &m,
        &facet::Params {
            mode: Mode::Smooth,
            ..params
        },
    )
    .unwrap();
    assert_eq!(s.points().vec3_f64("N").unwrap(), n);
    // With the cusp at 180 the corners blend: no longer axis-aligned.
    facet::facet_points(
        &mut s,
        &m,
        &facet::Params {
            mode: Mode::Smooth,
            cusp: 180.0,
            weld: true,
            ..params
        },
    )
    .unwrap();
    assert_ne!(s.points().vec3_f64("N").unwrap(), n);
}

#[test]
fn facet_smooth_on_a_sphere_is_radial() {
    let c0 = [3.0, -2.0, 1.0];
    let mesh = uv_sphere(64, 128, 1.0, c0);
    let m = TriMesh::from_cloud(&mesh).unwrap();
    let mut c = scatter_n(&mesh, 5000, 4, PtareaMode::Prim);
    let params = facet::Params {
        mode: Mode::Smooth,
        weight: Weight::Angle,
        cusp: 60.0,
        weld: true,
    };
    facet::facet_points(&mut c, &m, &params).unwrap();
    let p = c.points().vec3_f64("P").unwrap();
    let n = c.points().vec3_f64("N").unwrap();
    let worst = p
        .iter()
        .zip(&n)
        .map(|(q, nn)| {
            let r = glam::DVec3::new(q[0] - c0[0], q[1] - c0[1], q[2] - c0[2]).normalize();
            1.0 - r.dot(glam::DVec3::from_array(*nn))
        })
        .fold(0.0, f64::max);
    assert!(worst < 1e-3, "largest 1 - cos(angle to radial) {worst}");
    // Without sourceprim, the closest point gives the same normals.
    let mut bare = c.clone();
    bare.points_mut().remove("sourceprim");
    bare.points_mut().remove("sourceuv");
    let rep = facet::facet_points(&mut bare, &m, &params).unwrap();
    assert_eq!(rep.projected, 5000);
    let nb = bare.points().vec3_f64("N").unwrap();
    let max_diff = nb
        .iter()
        .zip(&n)
        .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max))
        .fold(0.0, f64::max);
    assert!(max_diff < 1e-5, "{max_diff}");
}

#[test]
fn facet_on_a_mesh_gives_vertex_normals() {
    let mut s = uv_sphere(32, 64, 1.0, [0.0; 3]);
    facet::facet_mesh(&mut s, Weight::Angle, true).unwrap();
    let p = s.points().vec3_f64("P").unwrap();
    let n = s.points().vec3_f64("N").unwrap();
    for (q, nn) in p.iter().zip(&n) {
        let d: f64 = (0..3).map(|k| q[k] * nn[k]).sum();
        assert!(d > 0.999, "{q:?} {nn:?}");
    }
}

#[test]
fn facet_on_points_near_the_cube_matches_the_hand_written_golden() {
    let d = tempdir();
    let pts = fixtures().join("facet/cube_points.ply");
    let cube = fixtures().join("mesh/cube.obj");
    let golden = fixtures().join("golden/facet_cube.ply");
    for mode in ["flat", "smooth"] {
        let out = run_in(
            Some(d.path()),
            "facet",
            &[
                pts.to_str().unwrap(),
                "--mesh",
                cube.to_str().unwrap(),
                "--mode",
                mode,
                "-o",
                "f.ply",
            ],
            b"",
        );
        assert!(out.status.success(), "{}", stderr(&out));
        let out = run_in(
            Some(d.path()),
            "pcdiff",
            // (The normals: what facet recorded of its run is not in the
            // hand-written golden.)
            &[
                "f.ply",
                golden.to_str().unwrap(),
                "--abs",
                "1e-6",
                "--only",
                "P,N",
            ],
            b"",
        );
        assert_eq!(
            out.status.code(),
            Some(0),
            "{mode}: {}",
            String::from_utf8_lossy(&out.stdout)
        );
    }
}

#[test]
fn facet_on_icosphere_vertices_is_radial_and_converges() {
    let mut last = f64::INFINITY;
    for level in [1, 2, 3] {
        let mut s = icosphere(level);
        facet::facet_mesh(&mut s, Weight::Angle, true).unwrap();
        let p = s.points().vec3_f64("P").unwrap();
        let n = s.points().vec3_f64("N").unwrap();
        let worst = p
            .iter()
            .zip(&n)
            .map(|(p, n)| {
                let r = glam::DVec3::from_array(*p).normalize();
                let n = glam::DVec3::from_array(*n);
                assert!((n.length() - 1.0).abs() < 1e-6);
                r.angle_between(n)
            })
            .fold(0.0, f64::max);
        // Angle-weighted normals of an icosphere's vertices: level 1 is
        // symmetric (every vertex radial to f32 rounding); after it, close
        // everywhere and closer as it refines.
        assert!(worst < 0.02, "{level}: {worst} rad");
        if level == 1 {
            assert!(worst < 1e-6, "{worst}");
        } else {
            assert!(worst < last, "{level}: {worst} after {last}");
            last = worst;
        }
    }
}

/// A UV sphere as an OBJ with texture coordinates: the seam at longitude 0
/// and the poles have several `vt` per `v`, so the reader splits their
/// vertices (as Blender's exports do).
fn seamed_sphere_obj(rings: usize, segs: usize) -> String {
    use std::f64::consts::PI;
    use std::fmt::Write;
    let mut s = String::new();
    let v = |i: usize, j: usize| -> usize {
        match i {
            0 => 1,
            i if i == rings => 2 + (rings - 1) * segs,
            i => 2 + (i - 1) * segs + j % segs,
        }
    };
    writeln!(s, "v 0 0 1").unwrap();
    for i in 1..rings {
        let th = PI * i as f64 / rings as f64;
        for j in 0..segs {
            let ph = 2.0 * PI * j as f64 / segs as f64;
            writeln!(
                s,
                "v {} {} {}",
                th.sin() * ph.cos(),
                th.sin() * ph.sin(),
                th.cos()
            )
            .unwrap();
        }
    }
    writeln!(s, "v 0 0 -1").unwrap();
    // One vt per (ring, column), columns 0..=segs: the seam doubles.
    for i in 0..=rings {
        for j in 0..=segs {
            writeln!(
                s,
                "vt {} {}",
                j as f64 / segs as f64,
                1.0 - i as f64 / rings as f64
            )
            .unwrap();
        }
    }
    let t = |i: usize, j: usize| 1 + i * (segs + 1) + j;
    for i in 0..rings {
        for j in 0..segs {
            // A pole's corners collapse: its faces are triangles.
            let c: Vec<(usize, usize)> = if i == 0 {
                vec![(0, j), (1, j), (1, j + 1)]
            } else if i + 1 == rings {
                vec![(i, j), (i + 1, j), (i, j + 1)]
            } else {
                vec![(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
            };
            let corners: Vec<String> = c
                .iter()
                .map(|&(a, b)| format!("{}/{}", v(a, b), t(a, b)))
                .collect();
            writeln!(s, "f {}", corners.join(" ")).unwrap();
        }
    }
    s
}

#[test]
fn facet_welds_the_copies_of_a_vertex_split_at_a_uv_seam() {
    let text = seamed_sphere_obj(16, 32);
    let mesh = pcsss::formats::obj::read_obj(text.as_bytes()).unwrap();
    // The reader split the seam: more vertices than positions.
    assert!(mesh.points().len() > 2 + 15 * 32, "{}", mesh.points().len());
    let worst = |weld: bool| {
        let mut s = mesh.clone();
        facet::facet_mesh(&mut s, Weight::Angle, weld).unwrap();
        let p = s.points().vec3_f64("P").unwrap();
        let n = s.points().vec3_f64("N").unwrap();
        p.iter()
            .zip(&n)
            .map(|(p, n)| {
                let r = glam::DVec3::from_array(*p).normalize();
                r.angle_between(glam::DVec3::from_array(*n)).to_degrees()
            })
            .fold(0.0, f64::max)
    };
    // Away from the seam a vertex normal of this sphere is within a
    // degree of the radius; the seam's copies without the weld see only
    // half their faces (and the poles' copies one face each).
    let (welded, split) = (worst(true), worst(false));
    assert!(welded < 1.0, "welded: {welded} degrees");
    assert!(split > 5.0, "split: {split} degrees");

    // Points scattered on the mesh take the same welded corner normals.
    let m = TriMesh::from_cloud(&mesh).unwrap();
    let mut c = scatter_n(&mesh, 20000, 3, PtareaMode::Prim);
    let p = facet::Params {
        mode: Mode::Smooth,
        weight: Weight::Angle,
        cusp: 60.0,
        weld: true,
    };
    facet::facet_points(&mut c, &m, &p).unwrap();
    assert_eq!(
        c.detail("facet_weld"),
        Some(&pcsss::cloud::DetailValue::I32(1))
    );
    let pos = c.points().vec3_f64("P").unwrap();
    let n = c.points().vec3_f64("N").unwrap();
    let worst_pt = pos
        .iter()
        .zip(&n)
        .map(|(p, n)| {
            let r = glam::DVec3::from_array(*p).normalize();
            r.angle_between(glam::DVec3::from_array(*n)).to_degrees()
        })
        .fold(0.0, f64::max);
    assert!(worst_pt < 6.0, "points: {worst_pt} degrees");
}
