//! `illum` against closed forms: cosine law, inverse square, exact
//! shadows of a box, light masks that add up, translation and scale
//! invariance, area lights, and bad input.

use glam::DVec3;

use crate::util::*;
use pcsss::cloud::Role;
use pcsss::geom::bvh::Occluder;
use pcsss::geom::mesh::TriMesh;
use pcsss::lights::{self, Light};
use pcsss::progress::Progress;
use pcsss::stages::facet::{self, Mode, Weight};
use pcsss::stages::illum;
use pcsss::stages::scatter::{self, Amount, Params, PtareaMode};
use pcsss::Cloud;

fn parse(json: &str) -> Vec<Light> {
    lights::parse(json, "test.json").unwrap()
}

/// A square grid of `k` x `k` quads on the plane z = `z`, side `s`,
/// centred on `c`.
fn plane(k: usize, s: f64, c: DVec3) -> Cloud {
    let mut p = Vec::new();
    for i in 0..=k {
        for j in 0..=k {
            let x = (i as f64 / k as f64 - 0.5) * s;
            let y = (j as f64 / k as f64 - 0.5) * s;
            p.push((c + DVec3::new(x, y, 0.0)).to_array());
        }
    }
    let id = |i: usize, j: usize| (i * (k + 1) + j) as i32;
    let mut f = Vec::new();
    for i in 0..k {
        for j in 0..k {
            f.push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    mesh_from(&p, &f)
}

/// Two meshes as one.
fn join(a: &Cloud, b: &Cloud) -> Cloud {
    let pa = a.points().vec3_f64("P").unwrap();
    let pb = b.points().vec3_f64("P").unwrap();
    let fa = pcsss::geom::mesh::Polygons::of(a).unwrap();
    let fb = pcsss::geom::mesh::Polygons::of(b).unwrap();
    let mut faces: Vec<Vec<i32>> = (0..fa.len())
        .map(|f| fa.polygon(f).iter().map(|&v| v as i32).collect())
        .collect();
    faces.extend((0..fb.len()).map(|f| {
        fb.polygon(f)
            .iter()
            .map(|&v| (v as usize + pa.len()) as i32)
            .collect()
    }));
    let p: Vec<[f64; 3]> = pa.iter().chain(&pb).copied().collect();
    mesh_from(&p, &faces)
}

/// An axis-aligned box from `lo` to `hi`, outward quads.
fn boxed(lo: DVec3, hi: DVec3) -> Cloud {
    let p: Vec<[f64; 3]> = (0..8)
        .map(|k| {
            [
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            ]
        })
        .collect();
    let f = vec![
        vec![0, 2, 3, 1],
        vec![4, 5, 7, 6],
        vec![0, 1, 5, 4],
        vec![2, 6, 7, 3],
        vec![0, 4, 6, 2],
        vec![1, 3, 7, 5],
    ];
    mesh_from(&p, &f)
}

/// Points on `mesh` with flat normals and f64 positions.
fn points_on(mesh: &Cloud, n: usize) -> Cloud {
    let mut c = scatter::scatter(
        mesh,
        &Params {
            amount: Amount::Count(n),
            seed: 7,
            ptarea: PtareaMode::Prim,
            relax: 0,
            ..pcsss::stages::scatter::Params::new(pcsss::stages::scatter::Amount::Count(0))
        },
    )
    .unwrap();
    let m = TriMesh::from_cloud(mesh).unwrap();
    facet::facet_points(
        &mut c,
        &m,
        &facet::Params {
            mode: Mode::Flat,
            weight: Weight::Angle,
            cusp: 60.0,
            weld: true,
        },
    )
    .unwrap();
    c
}

fn run_illum(
    cloud: &Cloud,
    lights: &[Light],
    shadows: Option<&Cloud>,
) -> (Vec<[f64; 3]>, illum::Report) {
    let mut c = cloud.clone();
    let tris = shadows.map(|m| TriMesh::from_cloud(m).unwrap());
    let occ = tris.as_ref().map(Occluder::new);
    let sh = tris
        .as_ref()
        .zip(occ.as_ref())
        .map(|(t, o)| illum::Shadows::new(t, o, None));
    let rep = illum::illum(&mut c, lights, sh.as_ref(), 0, &Progress::hidden()).unwrap();
    (c.points().vec3_f64("illum").unwrap(), rep)
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-30
}

#[test]
fn a_plane_under_a_distant_light_gets_cl_cos_theta() {
    for centre in [DVec3::ZERO, DVec3::new(1e6, -1e6, 1e6)] {
        let mesh = plane(8, 4.0, centre);
        let pts = points_on(&mesh, 2000);
        for (dir, cos) in [
            ([0.0, 0.0, -1.0], 1.0),
            ([0.6, 0.0, -0.8], 0.8),
            ([0.0, -0.96, -0.28], 0.28),
        ] {
            let l = parse(&format!(
                r#"{{"lights": [{{"name": "sun", "type": "distant", "color": [1, 0.5, 0.25], "intensity": 3, "direction": {dir:?}}}]}}"#
            ));
            let (e, rep) = run_illum(&pts, &l, Some(&mesh));
            assert_eq!(rep.blocked, 0);
            assert_eq!(rep.rays, 2000);
            for v in &e {
                for (c, want) in v.iter().zip([3.0 * cos, 1.5 * cos, 0.75 * cos]) {
                    assert!(close(*c, want, 2e-7), "{c} vs {want} at {centre}");
                }
            }
        }
        // From below: nothing, and no ray cast.
        let l =
            parse(r#"{"lights": [{"name": "s", "type": "distant", "direction": [0, 0.2, 1]}]}"#);
        let (e, rep) = run_illum(&pts, &l, Some(&mesh));
        assert_eq!(rep.rays, 0);
        assert!(e.iter().all(|v| *v == [0.0; 3]));
    }
}

#[test]
fn a_point_light_falls_off_as_the_inverse_square() {
    let mesh = plane(4, 10.0, DVec3::ZERO);
    let pts = points_on(&mesh, 3000);
    let light = DVec3::new(0.3, -0.2, 2.5);
    let l = parse(
        r#"{"lights": [
            {"name": "a", "type": "point", "position": [0.3, -0.2, 2.5], "intensity": 7},
            {"name": "b", "type": "point", "position": [0.3, -0.2, 2.5], "intensity": 7, "falloff": "none"}
        ]}"#,
    );
    let p = pts.points().vec3_f64("P").unwrap();
    for (k, inverse_square) in [(0, true), (1, false)] {
        let (e, _) = run_illum(&pts, &l[k..k + 1], Some(&mesh));
        for (q, v) in p.iter().zip(&e) {
            let to = light - DVec3::from_array(*q);
            let d = to.length();
            let cos = to.z / d;
            let want = 7.0 * cos / if inverse_square { d * d } else { 1.0 };
            assert!(close(v[0], want, 1e-6), "{v:?} vs {want}");
            assert_eq!(v[0], v[2]);
        }
    }
}

/// The sphere, a slab over its x < 0 half, and a distant light from +z:
/// exactly the upper points with x < 0 are dark.
fn sphere_and_slab(offset: DVec3, scale: f64) -> (Cloud, Cloud) {
    let sphere = uv_sphere(24, 48, scale, offset.to_array());
    let slab = boxed(
        offset + DVec3::new(-3.0, -3.0, 2.0) * scale,
        offset + DVec3::new(0.0, 3.0, 2.5) * scale,
    );
    let pts = points_on(&sphere, 4000);
    (join(&sphere, &slab), pts)
}

#[test]
fn a_box_shadows_exactly_the_points_behind_it() {
    let (scene, pts) = sphere_and_slab(DVec3::ZERO, 1.0);
    let l = parse(r#"{"lights": [{"name": "top", "type": "distant", "direction": [0, 0, -1]}]}"#);
    let (e, rep) = run_illum(&pts, &l, Some(&scene));
    let p = pts.points().vec3_f64("P").unwrap();
    let n = pts.points().vec3_f64("N").unwrap();
    let (mut lit, mut dark) = (0, 0);
    for i in 0..p.len() {
        let cos = n[i][2];
        if cos <= 0.0 {
            assert_eq!(e[i], [0.0; 3]);
            continue;
        }
        // Straight up from x < 0 the ray meets the slab (x in [-3, 0]).
        let shadowed = p[i][0] < 0.0;
        if p[i][0].abs() < 1e-6 {
            continue; // on the slab's edge: either answer is right
        }
        if shadowed {
            assert_eq!(e[i], [0.0; 3], "point {i} at {:?} is lit", p[i]);
            dark += 1;
        } else {
            assert!(
                close(e[i][0], cos, 1e-6),
                "point {i} at {:?}: {:?} vs {cos}",
                p[i],
                e[i]
            );
            lit += 1;
        }
    }
    assert!(lit > 800 && dark > 800, "{lit} lit, {dark} dark");
    assert_eq!(rep.blocked, dark as u64);
}

#[test]
fn a_light_mask_removes_exactly_a_lights_contribution() {
    let (scene, pts) = sphere_and_slab(DVec3::ZERO, 1.0);
    let json = std::fs::read_to_string(fixtures().join("lights/three.json")).unwrap();
    let all = parse(&json);
    let pick = |m: &str| -> Vec<Light> {
        lights::mask(&all, m)
            .unwrap()
            .into_iter()
            .map(|i| all[i].clone())
            .collect()
    };
    let (whole, _) = run_illum(&pts, &pick("*"), Some(&scene));
    let mut sum = vec![[0.0f64; 3]; whole.len()];
    for name in ["key", "rim", "fill_area"] {
        let (one, _) = run_illum(&pts, &pick(name), Some(&scene));
        for (s, o) in sum.iter_mut().zip(&one) {
            for c in 0..3 {
                s[c] += o[c];
            }
        }
    }
    for (s, w) in sum.iter().zip(&whole) {
        for c in 0..3 {
            // f32 outputs: each run rounds once.
            assert!(close(s[c], w[c], 3e-7), "{s:?} vs {w:?}");
        }
    }
    // Exclusion and globs select what they say.
    let names = |m: &str| -> Vec<String> { pick(m).into_iter().map(|l| l.name).collect() };
    assert_eq!(names("^key"), ["rim", "fill_area"]);
    assert_eq!(names("*i*,^fill*"), ["rim"]);
    assert_eq!(names("key rim"), ["key", "rim"]);
    let (rest, _) = run_illum(&pts, &pick("^key"), Some(&scene));
    let (key, _) = run_illum(&pts, &pick("key"), Some(&scene));
    for i in 0..whole.len() {
        assert!(close(rest[i][1] + key[i][1], whole[i][1], 3e-7));
    }
}

#[test]
fn translation_and_scale_change_nothing() {
    let json = |o: DVec3, s: f64| {
        let p = |v: DVec3| format!("[{}, {}, {}]", o.x + v.x * s, o.y + v.y * s, o.z + v.z * s);
        format!(
            r#"{{"lights": [
            {{"name": "sun", "type": "distant", "direction": [0.3, 0.1, -1]}},
            {{"name": "bulb", "type": "point", "position": {}, "intensity": {}}},
            {{"name": "panel", "type": "rect", "position": {}, "u": [{}, 0, 0], "v": [0, {}, 0], "intensity": {}, "samples": 9}}
        ]}}"#,
            p(DVec3::new(2.0, 1.0, 3.0)),
            5.0 * s * s,
            p(DVec3::new(1.0, -1.0, 4.0)),
            s,
            s,
            3.0 * s * s
        )
    };
    let (scene0, pts0) = sphere_and_slab(DVec3::ZERO, 1.0);
    let (e0, r0) = run_illum(&pts0, &parse(&json(DVec3::ZERO, 1.0)), Some(&scene0));
    assert!(r0.blocked > 1000, "{r0:?}");
    for (o, s) in [
        (DVec3::new(1e6, -1e6, 1e6), 1.0),
        (DVec3::ZERO, 1e-4),
        (DVec3::ZERO, 1e4),
        (DVec3::new(3.0, 2.0, 1.0), 1e-4),
    ] {
        let (scene, pts) = sphere_and_slab(o, s);
        let (e, r) = run_illum(&pts, &parse(&json(o, s)), Some(&scene));
        assert_eq!(r.blocked, r0.blocked, "offset {o}, scale {s}");
        for i in 0..e.len() {
            for c in 0..3 {
                assert!(
                    close(e[i][c], e0[i][c], 1e-5),
                    "offset {o}, scale {s}, point {i}: {:?} vs {:?}",
                    e[i],
                    e0[i]
                );
            }
        }
    }
}

#[test]
fn area_lights_match_their_closed_forms() {
    // A disk of radius R facing a point on its axis at height h:
    // E = Cl / (h^2 + R^2).
    let mut pt = Cloud::with_points(1);
    pt.points_mut()
        .set_vec3("P", Role::Point, &[[0.0f64, 0.0, 0.0]])
        .unwrap();
    pt.points_mut()
        .set_vec3("N", Role::Normal, &[[0.0f32, 0.0, 1.0]])
        .unwrap();
    for (h, r) in [(1.0, 0.5), (2.0, 2.0), (0.5, 3.0)] {
        let l = parse(&format!(
            r#"{{"lights": [{{"name": "d", "type": "disk", "position": [0, 0, {h}], "normal": [0, 0, -1], "radius": {r}, "intensity": 4, "samples": 4096}}]}}"#
        ));
        let (e, _) = run_illum(&pt, &l, None);
        let want = 4.0 / (h * h + r * r);
        assert!(
            close(e[0][0], want, 2e-3),
            "h {h} r {r}: {} vs {want}",
            e[0][0]
        );
    }
    // Small area lights of any shape equal the point light at their centre.
    let point = parse(
        r#"{"lights": [{"name": "p", "type": "point", "position": [0.4, 0.2, 3], "intensity": 2}]}"#,
    );
    let (want, _) = run_illum(&pt, &point, None);
    for shape in [
        r#""type": "rect", "u": [1e-4, 0, 0], "v": [0, 1e-4, 0], "two_sided": true"#,
        r#""type": "disk", "normal": [-0.4, -0.2, -3], "radius": 1e-4"#,
        r#""type": "sphere", "radius": 1e-4"#,
    ] {
        let l = parse(&format!(
            r#"{{"lights": [{{"name": "a", {shape}, "position": [0.4, 0.2, 3], "intensity": 2, "samples": 64}}]}}"#
        ));
        let (e, _) = run_illum(&pt, &l, None);
        // The disk faces the point: its emitter cosine is 1; the rect is
        // tilted by the point's offset, so compare with its cosine.
        let tilt = if shape.contains("rect") {
            3.0 / DVec3::new(0.4, 0.2, 3.0).length()
        } else {
            1.0
        };
        assert!(
            close(e[0][0], want[0][0] * tilt, 1e-3),
            "{shape}: {:?} vs {:?}",
            e[0],
            want[0]
        );
    }
}

#[test]
fn a_spot_lights_only_inside_its_cone() {
    let mesh = plane(4, 20.0, DVec3::ZERO);
    let pts = points_on(&mesh, 4000);
    // Straight down from height 2, half-angle 30, soft edge 10 degrees.
    let l = parse(
        r#"{"lights": [{"name": "s", "type": "spot", "position": [0, 0, 2], "direction": [0, 0, -1], "cone_angle": 30, "cone_delta": 10, "intensity": 4}]}"#,
    );
    let (e, rep) = run_illum(&pts, &l, Some(&mesh));
    let p = pts.points().vec3_f64("P").unwrap();
    let mut inside = 0;
    for (q, v) in p.iter().zip(&e) {
        let r = (q[0] * q[0] + q[1] * q[1]).sqrt();
        let a = r.atan2(2.0).to_degrees();
        let d2 = r * r + 4.0;
        let cos = 2.0 / d2.sqrt();
        let full = 4.0 * cos / d2;
        if a > 30.0 + 1e-6 {
            assert_eq!(v[0], 0.0);
        } else if a < 20.0 - 1e-6 {
            assert!(close(v[0], full, 1e-6));
            inside += 1;
        } else {
            assert!(v[0] > 0.0 && v[0] <= full * (1.0 + 1e-6));
        }
    }
    assert!(inside > 10);
    // Points outside the cone cast no ray.
    let in_cone = p
        .iter()
        .filter(|q| (q[0] * q[0] + q[1] * q[1]).sqrt().atan2(2.0).to_degrees() < 30.0)
        .count();
    assert_eq!(rep.rays, in_cone as u64);
}

#[test]
fn lights_files_with_mistakes_name_the_key() {
    let cases: &[(&str, &str)] = &[
        (
            r#"{"lights": [{"name": "a", "type": "point", "position": [0,0,1], "intensity": -2}]}"#,
            "lights[0].intensity: -2 is not finite and >= 0",
        ),
        (
            r#"{"lights": [{"name": "a", "type": "point", "position": [0,0,1], "colour": [1,1,1]}]}"#,
            "unknown field `colour`",
        ),
        (
            r#"{"lights": [{"name": "a", "type": "point"}]}"#,
            "missing field `position`",
        ),
        (
            r#"{"lights": [{"name": "a", "type": "laser", "position": [0,0,1]}]}"#,
            "unknown variant `laser`",
        ),
        (
            r#"{"lights": [{"name": "a", "type": "point", "position": [0,0,1], "intensity": NaN}]}"#,
            "lights[0].intensity",
        ),
        (
            r#"{"lights": [{"name": "a", "type": "distant", "direction": [0,0,0]}]}"#,
            "lights[0].direction: [0.0, 0.0, 0.0] has no direction",
        ),
        (
            r#"{"lights": [{"name": "a", "type": "disk", "position": [0,0,1], "normal": [0,0,1], "radius": 0}]}"#,
            "lights[0].radius",
        ),
        (
            r#"{"lights": [{"name": "a", "type": "rect", "position": [0,0,1], "u": [1,0,0], "v": [2,0,0]}]}"#,
            "span no area",
        ),
        (
            r#"{"lights": [{"name": "a", "type": "sphere", "position": [0,0,1], "radius": 1, "samples": 0}]}"#,
            "lights[0].samples: 0",
        ),
        (
            r#"{"lights": [{"name": "a", "type": "spot", "position": [0,0,1], "direction": [0,0,-1], "cone_angle": 10, "cone_delta": 20}]}"#,
            "lights[0].cone_delta",
        ),
        (
            r#"{"lights": [{"name": "a", "type": "point", "position": [0,0,1]}, {"name": "a", "type": "point", "position": [0,0,2]}]}"#,
            "lights[1].name: 'a' is already",
        ),
        (r#"{"light": []}"#, "unknown field `light`"),
        (
            r#"{"lights": [{"name": "", "type": "point", "position": [0,0,1]}]}"#,
            "lights[0].name: is empty",
        ),
    ];
    for (json, want) in cases {
        let e = lights::parse(json, "scene.json").unwrap_err().to_string();
        assert!(
            e.contains("scene.json") && e.contains(want),
            "'{e}' lacks '{want}'"
        );
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}

#[test]
fn illum_runs_in_a_pipe_and_bad_input_is_a_clear_error() {
    let d = tempdir();
    let write =
        |name: &str, c: &Cloud| std::fs::write(d.path().join(name), to_bytes(c, LE)).unwrap();
    let sphere = uv_sphere(12, 24, 1.0, [0.0; 3]);
    write("mesh.ply", &sphere);
    let pts = points_on(&sphere, 3000);
    write("cloud.ply", &pts);
    let lights = fixtures().join("lights/three.json");
    let lights = lights.to_str().unwrap();
    // Equal bytes on one and two threads, from stdin to stdout.
    let mut outs = Vec::new();
    for threads in ["1", "2"] {
        outs.push(run_env(
            d.path(),
            "illum",
            &["--lights", lights, "--mesh", "mesh.ply"],
            &[("RAYON_NUM_THREADS", threads)],
            Some("cloud.ply"),
        ));
    }
    assert_eq!(outs[0], outs[1]);
    let c = from_bytes(&outs[0]);
    assert!(c.points().has("illum") && c.points().has("ptarea") && c.points().has("sourceuv"));
    assert_eq!(
        c.detail("illum_lights"),
        Some(&pcsss::cloud::DetailValue::Str("key,rim,fill_area".into()))
    );
    assert!(c.points().has("illum_cos") && !c.points().has("thickness"));
    // With the thickness (the sphere's diameter along -N, about 2).
    let out = run_in(
        Some(d.path()),
        "illum",
        &[
            "cloud.ply",
            "--lights",
            lights,
            "--mesh",
            "mesh.ply",
            "--thickness",
        ],
        b"",
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let t = from_bytes(&out.stdout)
        .points()
        .scalar_f64("thickness")
        .unwrap();
    assert!(t.iter().all(|&t| t > 1.9 && t < 2.0), "{:?}", &t[..4]);
    // Bad input.
    let mut zero_n = pts.clone();
    let mut n = zero_n.points().vec3_f32("N").unwrap();
    n[17] = [0.0; 3];
    zero_n.points_mut().set_vec3("N", Role::Normal, &n).unwrap();
    write("zero_n.ply", &zero_n);
    let mut no_n = pts.clone();
    no_n.points_mut().remove("N");
    write("no_n.ply", &no_n);
    std::fs::write(
        d.path().join("neg.json"),
        r#"{"lights": [{"name": "a", "type": "point", "position": [0,0,3], "intensity": -1}]}"#,
    )
    .unwrap();
    let cases: &[(&[&str], &str)] = &[
        (
            &["no_n.ply", "--lights", lights, "--no-shadows"],
            "missing point attribute 'N' (run 'facet' first",
        ),
        (
            &["zero_n.ply", "--lights", lights, "--no-shadows"],
            "zero_n.ply: invalid: point 17 has normal N [0.0, 0.0, 0.0]",
        ),
        (
            &["cloud.ply", "--lights", "neg.json", "--no-shadows"],
            "neg.json at lights[0].intensity",
        ),
        (
            &[
                "cloud.ply",
                "--lights",
                lights,
                "--no-shadows",
                "--lmask",
                "nope*",
            ],
            "--lmask: 'nope*' selects no light (the lights are: key, rim, fill_area)",
        ),
        (
            &["cloud.ply", "--lights", lights, "--mesh", "missing.ply"],
            "missing.ply",
        ),
        (
            &["cloud.ply", "--lights", "missing.json", "--no-shadows"],
            "missing.json",
        ),
        (&["cloud.ply", "--lights", lights], "--mesh"),
        (
            &[
                "cloud.ply",
                "--lights",
                lights,
                "--no-shadows",
                "--thickness",
            ],
            "--thickness: needs --mesh",
        ),
    ];
    for (args, want) in cases {
        let out = run_in(Some(d.path()), "illum", args, b"");
        let e = stderr(&out);
        assert_ne!(out.status.code(), Some(0), "{args:?}");
        assert_eq!(e.trim().lines().count(), 1, "{args:?}: {e}");
        assert!(e.contains(want), "{args:?}: '{e}' lacks '{want}'");
    }
}

/// Globs with alternatives and quoted names with spaces select what the
/// mask's documentation says (formats/LIGHTS.md).
#[test]
fn light_masks_take_brace_alternatives_and_quoted_names() {
    let all = lights::parse(
        r#"{"lights": [
            {"type": "distant", "name": "key", "direction": [0, -1, 0]},
            {"type": "distant", "name": "rim", "direction": [0, -1, 0]},
            {"type": "distant", "name": "fill light", "direction": [0, -1, 0]},
            {"type": "distant", "name": "top,2", "direction": [0, -1, 0]}
        ]}"#,
        "test",
    )
    .unwrap();
    let m = |p: &str| lights::mask(&all, p).map_err(|e| e.to_string());
    assert_eq!(m("{key,rim}"), Ok(vec![0, 1]));
    assert_eq!(m("^{key,rim}"), Ok(vec![2, 3]));
    assert_eq!(m("{key,rim} \"fill light\""), Ok(vec![0, 1, 2]));
    assert_eq!(m("\"top,2\""), Ok(vec![3]));
    assert_eq!(m("key,rim"), Ok(vec![0, 1]));
    for bad in ["{key,rim", "\"fill", "nosuch"] {
        let e = m(bad).unwrap_err();
        assert!(e.contains("parameter lmask"), "{bad}: {e}");
    }
}

/// `illum_cos` is the mean cosine of the light's arrival, each arrival
/// weighted by the irradiance it brings (its channels summed); 1 where no
/// light arrives.
#[test]
fn illum_cos_is_the_irradiance_weighted_mean_cosine() {
    let mesh = plane(8, 4.0, DVec3::ZERO);
    let pts = points_on(&mesh, 500);
    let l = parse(
        r#"{"lights": [
            {"name": "top", "type": "distant", "direction": [0, 0, -1]},
            {"name": "low", "type": "distant", "color": [1, 0.5, 0.25], "intensity": 2, "direction": [0, -0.96, -0.28]}]}"#,
    );
    let cosine = |lights: &[Light]| {
        let mut c = pts.clone();
        let tris = TriMesh::from_cloud(&mesh).unwrap();
        let occ = Occluder::new(&tris);
        let sh = illum::Shadows::new(&tris, &occ, None);
        illum::illum(&mut c, lights, Some(&sh), 0, &Progress::hidden()).unwrap();
        c.points().scalar_f64("illum_cos").unwrap()
    };
    // Weights: 3 x 1 from the top, 3.5 x 0.28 from the low light.
    let (wt, wl) = (3.0, 3.5 * 0.28);
    let want = (wt * 1.0 + wl * 0.28) / (wt + wl);
    assert!(cosine(&l).iter().all(|&c| close(c, want, 1e-6)));
    assert!(cosine(&l[1..]).iter().all(|&c| close(c, 0.28, 1e-6)));
    let below =
        parse(r#"{"lights": [{"name": "s", "type": "distant", "direction": [0, 0.2, 1]}]}"#);
    assert!(cosine(&below).iter().all(|&c| c == 1.0));
}

/// `illum --thickness`: how far the mesh goes on behind each point along
/// `-N`, a box's height from its top and bottom faces, its width from its
/// sides, at any offset; an open mesh's points that see no back get the
/// float maximum, and are counted.
#[test]
fn thickness_is_how_far_the_mesh_goes_on_behind_a_point() {
    for centre in [DVec3::ZERO, DVec3::new(1e5, -1e5, 3e4)] {
        let (lo, hi) = (
            centre + DVec3::new(-2.0, -1.5, 0.0),
            centre + DVec3::new(2.0, 1.5, 0.3),
        );
        let mesh = boxed(lo, hi);
        let mut c = points_on(&mesh, 3000);
        let m = TriMesh::from_cloud(&mesh).unwrap();
        let open = illum::thickness(&mut c, &m, &Progress::hidden()).unwrap();
        assert_eq!(open, 0);
        let t = c.points().scalar_f64("thickness").unwrap();
        let n = c.points().vec3_f64("N").unwrap();
        for (t, n) in t.iter().zip(&n) {
            let want = [4.0, 3.0, 0.3][(0..3).find(|&k| n[k].abs() > 0.5).unwrap()];
            assert!(close(*t, want, 1e-5), "{t} against {want} at N {n:?}");
        }
    }
    // One face alone: nothing behind it.
    let quad = plane(4, 2.0, DVec3::ZERO);
    let mut c = points_on(&quad, 100);
    let open = illum::thickness(
        &mut c,
        &TriMesh::from_cloud(&quad).unwrap(),
        &Progress::hidden(),
    )
    .unwrap();
    assert_eq!(open, 100);
    assert!(c
        .points()
        .scalar_f64("thickness")
        .unwrap()
        .iter()
        .all(|&t| t == f32::MAX as f64));
}

/// `mesh` with every face turned the other way (its outward normals
/// reversed).
fn flipped(mesh: &Cloud) -> Cloud {
    let p = mesh.points().vec3_f64("P").unwrap();
    let f = pcsss::geom::mesh::Polygons::of(mesh).unwrap();
    let faces: Vec<Vec<i32>> = (0..f.len())
        .map(|k| f.polygon(k).iter().rev().map(|&v| v as i32).collect())
        .collect();
    mesh_from(&p, &faces)
}

/// The physical model's shadows: a shadow ray that crosses the medium for
/// `d` carries `exp(-d / mfp)` of the light per channel, times the
/// boundary's Fresnel transmittance where it enters and where it leaves
/// (`(1 - ((eta - 1) / (eta + 1))^2)^2` along the normal); two slabs
/// multiply. Without the medium the same points are dark.
#[test]
fn a_mediums_shadow_lets_through_what_crosses_it_unscattered() {
    let floor = plane(8, 4.0, DVec3::ZERO);
    let pts = points_on(&floor, 400);
    let slab = |z0: f64, z1: f64| boxed(DVec3::new(-3.0, -3.0, z0), DVec3::new(3.0, 3.0, z1));
    let one = join(&floor, &slab(2.0, 2.5));
    let two = join(&one, &slab(3.0, 3.3));
    let l = parse(r#"{"lights": [{"name": "top", "type": "distant", "direction": [0, 0, -1]}]}"#);
    let mfp = DVec3::new(0.25, 0.5, 1.0);
    for (scene, d) in [(&one, 0.5), (&two, 0.8)] {
        let crossings = if d == 0.5 { 2 } else { 4 };
        for eta in [1.0, 1.5] {
            let m = illum::Passage {
                sigma_t: 1.0 / mfp,
                eta,
            };
            let mut c = pts.clone();
            let tris = TriMesh::from_cloud(scene).unwrap();
            let occ = Occluder::new(&tris);
            let sh = illum::Shadows::new(&tris, &occ, Some(m));
            let rep = illum::illum(&mut c, &l, Some(&sh), 0, &Progress::hidden()).unwrap();
            assert_eq!(rep.blocked, 400);
            let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
            let want = (-d / mfp).exp() * (1.0 - f0).powi(crossings);
            for e in c.points().vec3_f64("illum").unwrap() {
                for ch in 0..3 {
                    assert!(
                        close(e[ch], want[ch], 1e-5),
                        "d {d}, eta {eta}: {e:?} against {want:?}"
                    );
                }
            }
            // The light's cosine is that of the light that got through.
            assert!(c
                .points()
                .scalar_f64("illum_cos")
                .unwrap()
                .iter()
                .all(|&x| close(x, 1.0, 1e-6)));
        }
        let (e, _) = run_illum(&pts, &l, Some(scene));
        assert!(e.iter().all(|e| *e == [0.0; 3]));
    }
}

/// The view factor from a point to a parallel rectangle of half-sides
/// `a`, `b` centred `h` above it (four corner rectangles).
fn view_factor(a: f64, b: f64, h: f64) -> f64 {
    let (x, y) = (a / h, b / h);
    let corner = (x / (1.0 + x * x).sqrt() * (y / (1.0 + x * x).sqrt()).atan()
        + y / (1.0 + y * y).sqrt() * (x / (1.0 + y * y).sqrt()).atan())
        / (2.0 * std::f64::consts::PI);
    4.0 * corner
}

/// A cloud of one point at the origin (normal +z, no light) under a
/// square of points `h` above it facing down, `half` on each side, every
/// one sending the exitance `m` (ssM of the physical model), and the mesh
/// the light travels between: a small quad under the point and the square
/// (facing down, or up when `away`).
fn under_a_glowing_square(half: f64, h: f64, m: [f64; 3], away: bool) -> (Cloud, TriMesh) {
    let k = (2.0 * half / 0.1).round() as usize;
    let mut p = vec![[0.0; 3]];
    let mut n = vec![[0.0, 0.0, 1.0]];
    let mut ssm = vec![[0.0f32; 3]];
    for i in 0..=k {
        for j in 0..=k {
            let x = i as f64 / k as f64 * 2.0 * half - half;
            let y = j as f64 / k as f64 * 2.0 * half - half;
            p.push([x, y, h]);
            n.push([0.0, 0.0, -1.0]);
            ssm.push(m.map(|v| v as f32));
        }
    }
    let mut c = Cloud::with_points(p.len());
    let pts = c.points_mut();
    pts.set_vec3("P", Role::Point, &p).unwrap();
    pts.set_vec3("N", Role::Normal, &n).unwrap();
    pts.set_vec3("ssM", Role::Color, &ssm).unwrap();
    c.set_detail(
        "ssmulti_radiance",
        pcsss::cloud::DetailValue::Str(pcsss::stages::ssmulti::RADIANCE.into()),
    );
    let square = plane(4, 2.0 * half, DVec3::new(0.0, 0.0, h));
    let square = if away { square } else { flipped(&square) };
    let scene = join(&plane(2, 0.5, DVec3::ZERO), &square);
    (c, TriMesh::from_cloud(&scene).unwrap())
}

/// The medium of the indirect-light tests.
fn medium() -> pcsss::medium::Medium {
    pcsss::medium::Medium::new([0.95, 0.8, 0.5], [0.1; 3], 1.0, 0.0).unwrap()
}

/// `illum --indirect`: the light the rest of the surface sends. Under a
/// square whose points all send the exitance `M`, a point gets `M` times
/// the view factor of the square (closed form), and its `illum_cos` is
/// the mean cosine of that light (`int cos^2 / int cos` over the square,
/// by quadrature); a square seen from behind sends nothing; the bits do
/// not depend on the thread count.
#[test]
fn indirect_light_is_the_exitance_seen_times_its_view_factor() {
    let (half, h, m) = (2.0, 1.0, [1.0, 0.5, 0.25]);
    let f = view_factor(half, half, h);
    assert!((f - 0.83103).abs() < 1e-4, "{f}");
    // int cos dw = int dA / r^4.
    let mut c1 = 0.0;
    let q = 800;
    for i in 0..q {
        for j in 0..q {
            let x = ((i as f64 + 0.5) / q as f64 * 2.0 - 1.0) * half;
            let y = ((j as f64 + 0.5) / q as f64 * 2.0 - 1.0) * half;
            let r2: f64 = x * x + y * y + h * h;
            c1 += r2.powi(-2);
        }
    }
    assert!((c1 * (2.0 * half / q as f64).powi(2) / std::f64::consts::PI - f).abs() < 1e-5);
    let run = |away: bool, threads: usize| {
        let (mut c, mesh) = under_a_glowing_square(half, h, m, away);
        let occ = Occluder::new(&mesh);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let sh = illum::Shadows::new(&mesh, &occ, None);
            illum::illum(&mut c, &[], Some(&sh), 0, &Progress::hidden()).unwrap();
            illum::indirect(&mut c, &occ, &mesh, &medium(), 1024, 3, &Progress::hidden()).unwrap()
        });
        c
    };
    let c = run(false, 2);
    let e = c.points().vec3_f64("illum").unwrap()[0];
    let ind = c.points().vec3_f64("illum_indirect").unwrap()[0];
    assert_eq!(e, ind);
    for ch in 0..3 {
        assert!(close(e[ch], m[ch] * f, 3e-3), "{e:?} against {f} x {m:?}");
    }
    // The light between surfaces arrives spread over the hemisphere: it
    // is all illum_diffuse, and illum_cos stays the direct light's (none
    // here: 1).
    let cos = c.points().scalar_f64("illum_cos").unwrap()[0];
    assert_eq!(cos, 1.0);
    let spread = c.points().vec3_f64("illum_diffuse").unwrap()[0];
    assert_eq!(spread, ind);
    assert!(c.detail("illum_indirect_rays").is_some());
    // illum again: the light between surfaces is gone, attribute and record.
    let mut again = c.clone();
    let tris = under_a_glowing_square(half, h, m, false).1;
    let occ = Occluder::new(&tris);
    let sh = illum::Shadows::new(&tris, &occ, None);
    illum::illum(&mut again, &[], Some(&sh), 0, &Progress::hidden()).unwrap();
    assert!(!again.points().has("illum_indirect") && again.detail("illum_indirect_rays").is_none());
    // Seen from behind: nothing.
    let back = run(true, 2);
    assert_eq!(back.points().vec3_f64("illum").unwrap()[0], [0.0; 3]);
    // One thread: the same bits.
    assert_same_values(&c, &run(false, 1));
}

/// `illum --indirect` on a cloud ssmulti passed through (light between
/// surfaces' second run) takes the direct light the cloud holds: the
/// same bits as casting its shadow rays again. A cloud whose points,
/// lights, seed or shadows differ from its record, or that holds light
/// between surfaces already, is lit again.
#[test]
fn indirect_light_takes_the_direct_light_the_cloud_holds() {
    let (mut c, mesh) = under_a_glowing_square(2.0, 1.0, [1.0, 0.5, 0.25], false);
    let occ = Occluder::new(&mesh);
    let sh = illum::Shadows::new(&mesh, &occ, None);
    let sun = parse(
        r#"{"lights": [{"name": "sun", "type": "distant", "intensity": 2, "direction": [0.6, 0.2, -1]}]}"#,
    );
    let hidden = Progress::hidden();
    illum::illum(&mut c, &sun, Some(&sh), 0, &hidden).unwrap();
    assert!(illum::holds_direct(&c, &sun, Some(&sh), 0).unwrap());
    let mut full = c.clone();
    illum::illum(&mut full, &sun, Some(&sh), 0, &hidden).unwrap();
    illum::indirect(&mut full, &occ, &mesh, &medium(), 16, 0, &hidden).unwrap();
    let mut taken = c.clone();
    illum::indirect(&mut taken, &occ, &mesh, &medium(), 16, 0, &hidden).unwrap();
    assert!(full.points().vec3_f64("illum").unwrap()[0][0] > 0.0);
    assert_same_values(&full, &taken);
    // Not the cloud's light: another seed, other lights, no shadows,
    // a point moved, light between surfaces in it already.
    assert!(!illum::holds_direct(&c, &sun, Some(&sh), 1).unwrap());
    let other =
        parse(r#"{"lights": [{"name": "sun", "type": "distant", "direction": [0, 0, -1]}]}"#);
    assert!(!illum::holds_direct(&c, &other, Some(&sh), 0).unwrap());
    assert!(!illum::holds_direct(&c, &sun, None, 0).unwrap());
    let mut moved = c.clone();
    let mut p = moved.points().vec3_f64("P").unwrap();
    p[0][2] += 1e-6;
    let p32: Vec<[f32; 3]> = p.iter().map(|v| v.map(|x| x as f32)).collect();
    moved.points_mut().set_vec3("P", Role::Point, &p32).unwrap();
    assert!(!illum::holds_direct(&moved, &sun, Some(&sh), 0).unwrap());
    assert!(!illum::holds_direct(&taken, &sun, Some(&sh), 0).unwrap());
}

/// `illum --indirect --exitance CLOUD`: the exitance from another
/// cloud's points. The cloud itself as that other gives the same bits as
/// its own; one without `ssM`, or lit by other lights, is refused; the
/// cloud that takes the light then needs no `ssM` of its own.
#[test]
fn indirect_light_from_another_clouds_exitance() {
    let (mut c, mesh) = under_a_glowing_square(2.0, 1.0, [1.0, 0.5, 0.25], false);
    let occ = Occluder::new(&mesh);
    let sh = illum::Shadows::new(&mesh, &occ, None);
    let hidden = Progress::hidden();
    illum::illum(&mut c, &[], Some(&sh), 0, &hidden).unwrap();
    let mut own = c.clone();
    illum::indirect(&mut own, &occ, &mesh, &medium(), 64, 0, &hidden).unwrap();
    let mut bare = c.clone();
    bare.points_mut().remove("ssM");
    illum::indirect_from(
        &mut bare,
        Some(&c),
        false,
        &occ,
        &mesh,
        &medium(),
        64,
        0,
        &hidden,
    )
    .unwrap();
    assert_eq!(
        own.points().vec3_f64("illum_indirect").unwrap(),
        bare.points().vec3_f64("illum_indirect").unwrap()
    );
    assert!(own.points().vec3_f64("illum_indirect").unwrap()[0][0] > 0.0);
    let refused = |into: &Cloud, from: &Cloud| {
        illum::indirect_from(
            &mut into.clone(),
            Some(from),
            false,
            &occ,
            &mesh,
            &medium(),
            8,
            0,
            &hidden,
        )
        .unwrap_err()
    };
    let err = refused(&c, &bare);
    assert!(err.to_string().contains("ssM"), "{err}");
    let mut other = c.clone();
    let sun = parse(r#"{"lights": [{"name": "sun", "type": "distant", "direction": [0, 0, -1]}]}"#);
    illum::illum(&mut other, &sun, Some(&sh), 0, &hidden).unwrap();
    let err = refused(&bare, &other);
    assert!(err.to_string().contains("illum_lights_digest"), "{err}");
}

/// `illum --indirect --exitance CLOUD --gather-at-exitance`: the rays
/// cast at the exitance cloud's points, their light carried to the
/// cloud's. With the cloud as its own exitance cloud, the one point facing
/// up (no other faces its way) keeps its own rays' light to the bit; each
/// point of the square takes a weighted mean of its neighbours' (within
/// the least and most of its 8 nearest); a point facing a way no
/// exitance point faces gets nothing; only the exitance cloud's rays are
/// cast; the bits do not depend on the thread count.
#[test]
fn indirect_light_gathered_at_the_exitance_clouds_points_is_carried() {
    let (mut c, mesh) = under_a_glowing_square(2.0, 1.0, [1.0, 0.5, 0.25], false);
    let occ = Occluder::new(&mesh);
    let sh = illum::Shadows::new(&mesh, &occ, None);
    let hidden = Progress::hidden();
    let up = parse(r#"{"lights": [{"name": "below", "type": "distant", "direction": [0, 0, 1]}]}"#);
    illum::illum(&mut c, &up, Some(&sh), 0, &hidden).unwrap();
    let mut own = c.clone();
    illum::indirect(&mut own, &occ, &mesh, &medium(), 32, 0, &hidden).unwrap();
    let mine = own.points().vec3_f64("illum_indirect").unwrap();
    // A point facing sideways, beside the one facing up.
    let mut target = c.clone();
    let mut p = target.points().vec3_f64("P").unwrap();
    let mut n = target.points().vec3_f64("N").unwrap();
    p.push([0.01, 0.0, 0.0]);
    n.push([1.0, 0.0, 0.0]);
    let mut t2 = Cloud::with_points(p.len());
    t2.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    t2.points_mut().set_vec3("N", Role::Normal, &n).unwrap();
    illum::illum(&mut t2, &up, Some(&sh), 0, &hidden).unwrap();
    target = t2;
    let run = |t: &Cloud| {
        let mut t = t.clone();
        let rep = illum::indirect_from(
            &mut t,
            Some(&c),
            true,
            &occ,
            &mesh,
            &medium(),
            32,
            0,
            &hidden,
        )
        .unwrap();
        (t, rep)
    };
    let (got, rep) = run(&target);
    assert_eq!(rep.rays, c.len() as u64 * 32);
    let carried = got.points().vec3_f64("illum_indirect").unwrap();
    assert_eq!(carried[0], mine[0]);
    assert!(mine[0][0] > 0.0);
    let pos = c.points().vec3_f64("P").unwrap();
    for i in 1..c.len() {
        let mut d: Vec<(f64, usize)> = (1..c.len())
            .map(|j| {
                (
                    DVec3::from_array(pos[i]).distance_squared(DVec3::from_array(pos[j])),
                    j,
                )
            })
            .collect();
        d.sort_by(|a, b| a.0.total_cmp(&b.0));
        for ch in 0..3 {
            let near = d[..8].iter().map(|&(_, j)| mine[j][ch]);
            let (lo, hi) = near.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                (l.min(v), h.max(v))
            });
            let v = carried[i][ch];
            assert!(
                v >= lo * (1.0 - 1e-9) && v <= hi * (1.0 + 1e-9),
                "point {i}: {v} not in {lo}..{hi}"
            );
        }
    }
    assert_eq!(carried[c.len()], [0.0; 3]);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let (again, _) = one.install(|| run(&target));
    assert_eq!(again.points().vec3_f64("illum_indirect").unwrap(), carried);
    let said = match got.detail("illum_indirect_rays") {
        Some(pcsss::cloud::DetailValue::Str(s)) => s.clone(),
        other => panic!("{other:?}"),
    };
    assert!(
        said.contains("at each point") && said.contains("nearest 8"),
        "{said}"
    );
}

/// What a point sends to others is its multiple scattering and the
/// single scattering of its direct light: under a square lit from
/// below (irradiance 1 along its normal) whose points have `ssM` `M`, a
/// point gets the view factor times `M + rs(1)`. A medium other than the
/// one the cloud's ssM was made with is refused, naming both.
#[test]
fn indirect_light_carries_the_single_scattering_of_the_light_it_got() {
    let (half, h, m) = (2.0, 1.0, [0.2, 0.1, 0.05]);
    let f = view_factor(half, half, h);
    let (mut c, mesh) = under_a_glowing_square(half, h, m, false);
    let up = parse(r#"{"lights": [{"name": "below", "type": "distant", "direction": [0, 0, 1]}]}"#);
    illum::illum(&mut c, &up, None, 0, &Progress::hidden()).unwrap();
    let occ = Occluder::new(&mesh);
    let med = medium();
    illum::indirect(&mut c, &occ, &mesh, &med, 1024, 3, &Progress::hidden()).unwrap();
    let e = c.points().vec3_f64("illum_indirect").unwrap()[0];
    let rs = med.rs_at(1.0);
    for ch in 0..3 {
        let want = f * (m[ch] + rs[ch]);
        assert!(
            close(e[ch], want, 3e-3),
            "{e:?}: channel {ch} against {want}"
        );
    }
    // ssmulti's record of another medium (albedo 0.9 in red).
    use pcsss::cloud::DetailValue as D;
    let mut other = c.clone();
    other.set_detail("ssmulti_model", D::Str("physical".into()));
    other.set_detail("ssmulti_albedo", D::V3D([0.9, 0.8, 0.5]));
    other.set_detail("ssmulti_mfp", D::V3D(med.mfp));
    other.set_detail("ssmulti_eta", D::F64(med.eta));
    other.set_detail("ssmulti_g", D::F64(med.g));
    let mut same = other.clone();
    same.set_detail("ssmulti_albedo", D::V3D(med.albedo));
    illum::indirect(&mut same, &occ, &mesh, &med, 16, 0, &Progress::hidden()).unwrap();
    let err = illum::indirect(&mut other, &occ, &mesh, &med, 16, 0, &Progress::hidden())
        .unwrap_err()
        .to_string();
    assert!(err.contains("albedo [0.9") && err.contains("0.95"), "{err}");
}

/// `--indirect` needs the physical model's ssM (an exitance): a cloud
/// without ssM names ssmulti, the seed model's ssM is a parameter error,
/// and the option needs --mesh.
#[test]
fn indirect_light_needs_the_physical_models_ssm() {
    let (c, mesh) = under_a_glowing_square(1.0, 1.0, [1.0; 3], false);
    let occ = Occluder::new(&mesh);
    let mut seed = c.clone();
    seed.set_detail(
        "ssmulti_radiance",
        pcsss::cloud::DetailValue::Str("ssM".into()),
    );
    let mut none = c.clone();
    none.points_mut().remove("ssM");
    for (mut bad, says) in [(seed, "physical"), (none, "ssmulti")] {
        let err = illum::indirect(&mut bad, &occ, &mesh, &medium(), 16, 0, &Progress::hidden())
            .unwrap_err();
        assert!(err.to_string().contains(says), "{err}");
    }
    let d = tempdir();
    let cloud = d.path().join("c.ply");
    std::fs::write(&cloud, to_bytes(&c, pcsss::formats::Format::DEFAULT)).unwrap();
    let lights = fixtures().join("lights/bunny.json");
    let mesh = d.path().join("m.ply");
    std::fs::write(
        &mesh,
        to_bytes(&plane(2, 1.0, DVec3::ZERO), pcsss::formats::Format::DEFAULT),
    )
    .unwrap();
    let (cloud, lights, mesh) = (
        cloud.to_str().unwrap(),
        lights.to_str().unwrap(),
        mesh.to_str().unwrap(),
    );
    // No mesh; a mesh but no medium; no rays.
    for (extra, says) in [
        (&["--no-shadows", "--indirect", "16"][..], "--indirect"),
        (&["--mesh", mesh, "--indirect", "16"][..], "medium"),
        (&["--no-shadows", "--indirect", "0"][..], "--indirect"),
    ] {
        let mut args = vec![cloud, "--lights", lights];
        args.extend(extra);
        let o = run("illum", &args, b"");
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(says), "{extra:?}: {}", stderr(&o));
    }
}

/// The bake with light between surfaces, through the binaries: on the
/// torus (whose inner ring sees itself) illum --indirect adds light where
/// the surface sees itself and none where it sees only the sky, and
/// ssmulti run again returns at least what it returned from the direct
/// light alone, at every point (its sum is linear in the light).
#[test]
fn light_between_surfaces_through_the_binaries() {
    let d = tempdir();
    let at = |n: &str| d.path().join(n).display().to_string();
    let torus = fixtures().join("mesh/torus.obj").display().to_string();
    let lights = fixtures().join("lights/torus.json").display().to_string();
    let b = |n: &str| bin(n).display().to_string();
    let medium = "--model physical --albedo 0.95,0.8,0.6 --mfp 0.05 --eta 1 --g 0";
    let cmd = format!(
        "{m} {torus} | {p} --class face --attr area --method sum --as Tarea > mesh.ply && \
         {s} mesh.ply -n 6000 --seed 3 | {f} --mesh mesh.ply | {p} --normalize -o cloud.ply && \
         {i} cloud.ply --lights {lights} --mesh mesh.ply {medium} -o lit.ply && \
         {ss} lit.ply {medium} -o once.ply && \
         {i} once.ply --lights {lights} --mesh mesh.ply {medium} --indirect 512 -o bounce.ply && \
         {ss} bounce.ply {medium} -o twice.ply",
        m = b("measure"),
        p = b("promote"),
        s = b("scatter"),
        f = b("facet"),
        i = b("illum"),
        ss = b("ssmulti"),
    );
    shell(d.path(), &cmd);
    let read = |n: &str| from_bytes(&std::fs::read(at(n)).unwrap());
    let (lit, bounce, once, twice) = (
        read("lit.ply"),
        read("bounce.ply"),
        read("once.ply"),
        read("twice.ply"),
    );
    let ind = bounce.points().vec3_f64("illum_indirect").unwrap();
    let p = bounce.points().vec3_f64("P").unwrap();
    let n = bounce.points().vec3_f64("N").unwrap();
    // The direct light is what illum gave before.
    let direct = lit.points().vec3_f64("illum").unwrap();
    let all = bounce.points().vec3_f64("illum").unwrap();
    for i in 0..p.len() {
        for c in 0..3 {
            assert!(close(all[i][c], direct[i][c] + ind[i][c], 1e-5));
        }
    }
    // The torus lies in a plane through its centre: a point on the
    // inner ring facing the centre sees the ring across; one on the
    // outer rim facing out sees the sky alone.
    let (mut inner, mut outer) = (Vec::new(), Vec::new());
    let axis = (0..3)
        .min_by(|&a, &b| {
            let ext = |k: usize| {
                let (lo, hi) = p
                    .iter()
                    .fold((f64::MAX, f64::MIN), |(l, h), q| (l.min(q[k]), h.max(q[k])));
                hi - lo
            };
            ext(a).partial_cmp(&ext(b)).unwrap()
        })
        .unwrap();
    let centre = p.iter().fold(DVec3::ZERO, |s, q| s + DVec3::from_array(*q)) / p.len() as f64;
    for i in 0..p.len() {
        let mut r = DVec3::from_array(p[i]) - centre;
        r[axis] = 0.0;
        let facing = DVec3::from_array(n[i]).dot(r.normalize());
        if facing < -0.95 {
            inner.push(ind[i][0]);
        } else if facing > 0.95 {
            outer.push(ind[i][0]);
        }
    }
    assert!(
        inner.len() > 20 && outer.len() > 20,
        "{} {}",
        inner.len(),
        outer.len()
    );
    // (The ring across is narrow: a point's rays meet it a few times.)
    let seen = inner.iter().filter(|&&e| e > 0.0).count();
    assert!(seen * 10 >= inner.len() * 9, "{seen} of {}", inner.len());
    assert!(outer.iter().all(|&e| e == 0.0), "{outer:?}");
    let (m1, m2) = (
        once.points().vec3_f64("ssM").unwrap(),
        twice.points().vec3_f64("ssM").unwrap(),
    );
    let mut more = 0;
    for i in 0..m1.len() {
        for c in 0..3 {
            assert!(
                m2[i][c] >= m1[i][c] * (1.0 - 1e-5),
                "point {i}: {:?} then {:?}",
                m1[i],
                m2[i]
            );
        }
        more += (m2[i][0] > m1[i][0] * 1.001) as usize;
    }
    assert!(more > 100, "{more}");
    assert!(
        twice.detail("ssmulti_indirect").is_some() && twice.detail("illum_indirect_rays").is_some()
    );
}
