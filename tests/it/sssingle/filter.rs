//! ssS through filter and render: stored or computed lazily for the cloud
//! points read (and only those the eye sees), the same values either way;
//! the beauty sums ssM and ssS.

use super::*;
use pcsss::stages::filter::{self, Reach, SingleSetup, Source};

/// A unit sphere (UV mesh) and points on it with radial normals.
fn sphere_scene(points: usize) -> (Cloud, Cloud) {
    let mesh = uv_sphere(48, 96, 1.0, [0.0; 3]);
    let cloud = scatter_n(&mesh, points, 3, pcsss::stages::scatter::PtareaMode::Prim);
    let p = cloud.points().vec3_f64("P").unwrap();
    let n: Vec<[f32; 3]> = p
        .iter()
        .map(|q| DVec3::from_array(*q).normalize().as_vec3().to_array())
        .collect();
    let mut c = cloud;
    c.points_mut().set_vec3("N", Role::Normal, &n).unwrap();
    (mesh, c)
}

#[test]
fn lazy_sss_equals_the_stored_one_and_computes_only_what_the_eye_needs() {
    let (mesh_cloud, cloud) = sphere_scene(20_000);
    let mesh = TriMesh::from_cloud(&mesh_cloud).unwrap();
    let lights = distant(120.0, [1.0, 0.9, 0.8]);
    let params = Params {
        model: Model::Physical,
        mfp: [0.05, 0.1, 0.2],
        g: 0.5,
        samples: 8,
        eye: DVec3::new(0.0, 0.0, 5.0),
        ..Params::default()
    };
    let mut full = cloud.clone();
    let rep = sssingle::sssingle(&mut full, &mesh, &lights, &params, &Progress::hidden()).unwrap();
    // The eye at z = 5 sees the cap z > 0.2 of the sphere.
    assert!((0.35..0.45).contains(&(rep.computed as f64 / cloud.len() as f64)));
    // Shade points on both sides: z > 0.5 and z < -0.5.
    let shade_p: Vec<[f64; 3]> = cloud
        .points()
        .vec3_f64("P")
        .unwrap()
        .into_iter()
        .filter(|q| q[2].abs() > 0.5)
        .collect();
    let mut shade = Cloud::with_points(shade_p.len());
    shade
        .points_mut()
        .set_vec3("P", Role::Point, &shade_p)
        .unwrap();
    let fp = filter::Params {
        reach: Reach::Radius(0.03),
        facing: false,
    };
    let mut eager = shade.clone();
    filter::filter(
        &full,
        "cloud",
        &mut eager,
        &fp,
        &[Source::Stored("ssS")],
        &Progress::hidden(),
    )
    .unwrap();
    let setup = SingleSetup {
        mesh: &mesh,
        lights: &lights,
        params: &params,
    };
    let mut lazy = shade.clone();
    let frep = filter::filter(
        &cloud,
        "cloud",
        &mut lazy,
        &fp,
        &[Source::Single(&setup)],
        &Progress::hidden(),
    )
    .unwrap();
    assert_eq!(
        eager.points().vec3_f32("ssS").unwrap(),
        lazy.points().vec3_f32("ssS").unwrap(),
        "lazy and stored differ"
    );
    let (name, read, computed) = frep.lazy[0].clone();
    assert_eq!(name, "ssS");
    // The shade points read both caps (about 2 x 25% of the cloud); only
    // the one the eye sees is computed.
    let (r, c) = (
        read as f64 / cloud.len() as f64,
        computed as f64 / cloud.len() as f64,
    );
    eprintln!("lazy ssS: read {r:.3}, computed {c:.3} of the cloud");
    assert!((0.45..0.6).contains(&r), "read {r}");
    assert!(c < 0.6 * r && c > 0.2, "computed {c}");
}

#[test]
fn the_beauty_sums_ssm_and_sss_and_writes_both_layers() {
    let dir = tempdir();
    let (mesh_cloud, mut cloud) = sphere_scene(5_000);
    let n = cloud.len();
    cloud
        .points_mut()
        .set_vec3("ssM", Role::Color, &vec![[0.25f32, 0.5, 0.125]; n])
        .unwrap();
    cloud
        .points_mut()
        .set_vec3("ssS", Role::Color, &vec![[0.5f32, 0.25, 1.0]; n])
        .unwrap();
    cloud.set_detail("ssmulti_sd", pcsss::DetailValue::F64(0.3));
    let write = |name: &str, c: &Cloud| {
        let p = dir.path().join(name);
        std::fs::write(&p, to_bytes(c, pcsss::formats::Format::DEFAULT)).unwrap();
        p.display().to_string()
    };
    let (cloud_path, mesh_path) = (write("cloud.ply", &cloud), write("mesh.ply", &mesh_cloud));
    let cam = dir.path().join("cam.json");
    std::fs::write(
        &cam,
        r#"{"position": [0, 0, 4], "look_at": [0, 0, 0], "width": 32, "height": 32}"#,
    )
    .unwrap();
    let out = dir.path().join("r.exr").display().to_string();
    let o = run_in(
        Some(dir.path()),
        "render",
        &[
            "--mesh",
            &mesh_path,
            "--camera",
            &cam.display().to_string(),
            "--cloud",
            &cloud_path,
            "-o",
            &out,
        ],
        b"",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let img =
        pcsss::formats::read_cloud_file(std::path::Path::new(&out), &pcsss::formats::Select::All)
            .unwrap();
    let b = img.points().vec3_f32("beauty").unwrap();
    let s = img.points().vec3_f32("ssS").unwrap();
    assert!(!b.is_empty());
    for (x, y) in b.iter().zip(&s) {
        assert_eq!(*x, [0.75, 0.75, 1.125]);
        assert_eq!(*y, [0.5, 0.25, 1.0]);
    }
}
