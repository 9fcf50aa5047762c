//! measure: the cube's golden, a sphere's area, degenerate faces,
//! trimesh's icospheres.

use std::f64::consts::PI;

use crate::util::*;
use pcsss::stages::measure;

#[test]
fn measure_cube_matches_the_hand_written_golden() {
    let d = tempdir();
    let cube = fixtures().join("mesh/cube.obj");
    let out = run_in(
        Some(d.path()),
        "measure",
        &[cube.to_str().unwrap(), "-o", "m.ply"],
        b"",
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let golden = fixtures().join("golden/measure_cube.ply");
    let out = run_in(
        Some(d.path()),
        "pcdiff",
        &[
            "m.ply",
            golden.to_str().unwrap(),
            "--only",
            "area,perimeter",
            "--rel",
            "1e-6",
        ],
        b"",
    );
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
}

#[test]
fn sphere_area_converges_to_4_pi() {
    let mut last_err = f64::INFINITY;
    for (rings, segs) in [(8, 16), (32, 64), (128, 256)] {
        let mut s = uv_sphere(rings, segs, 1.0, [0.0; 3]);
        let rep = measure::measure(&mut s).unwrap();
        let err = (4.0 * PI - rep.total_area) / (4.0 * PI);
        assert!(
            err > 0.0 && err < last_err / 3.0,
            "{rings}x{segs}: relative error {err}"
        );
        last_err = err;
    }
    assert!(last_err < 2e-4, "{last_err}");
}

#[test]
fn degenerate_faces_measure_zero_never_nan() {
    let p = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1e-9, 1.0, 0.0],
    ];
    let faces = vec![
        vec![0, 1, 2],
        vec![0, 0, 3],
        vec![0, 1],
        vec![0, 3, 4],
        vec![0, 1, 3],
    ];
    let mut m = mesh_from(&p, &faces);
    let rep = measure::measure(&mut m).unwrap();
    let area = m.faces().unwrap().scalar_f64("area").unwrap();
    assert_eq!(&area[..3], &[0.0, 0.0, 0.0]);
    assert!(area[3] > 0.0 && area[3] < 1e-9, "sliver {}", area[3]);
    assert_eq!(area[4], 0.5);
    assert_eq!(rep.degenerate, 3);
    assert!(m
        .faces()
        .unwrap()
        .scalar_f64("perimeter")
        .unwrap()
        .iter()
        .all(|p| p.is_finite()));
}

#[test]
fn icosphere_fixtures_measure_trimesh_areas_converging_to_4_pi() {
    // trimesh's areas for the same files (fixtures/golden/README.md).
    let trimesh = [11.665931391718317, 12.329848595234669, 12.506492733969928];
    let mut last = f64::INFINITY;
    for (level, want) in [1, 2, 3].into_iter().zip(trimesh) {
        let mut s = icosphere(level);
        let rep = measure::measure(&mut s).unwrap();
        assert!(
            // OBJ positions are f32 (formats/README.md).
            (rep.total_area / want - 1.0).abs() < 1e-7,
            "{level}: {}",
            rep.total_area
        );
        let err = 4.0 * PI - rep.total_area;
        // Each subdivision cuts the error about four times (second order).
        assert!(err > 0.0 && err < last / 3.5, "{level}: {err} after {last}");
        last = err;
    }
}
