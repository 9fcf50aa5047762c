//! Shadow rays (`lights::shadow`, shared by illum and sssingle) against
//! what geometry says. On a convex mesh nothing is in the way of light a
//! point's surface faces, however grazing, for flat and smooth normals,
//! from 80 to 80k faces, near the origin and far from it. What a real
//! blocker hides stays hidden: a second body, a ray that crosses the
//! solid under a tilted normal; through a medium, by `exp(-sigma_t d)`
//! over the chord, per channel.

use glam::DVec3;

use crate::util::*;
use pcsss::cloud::Role;
use pcsss::geom::bvh::Occluder;
use pcsss::geom::mesh::TriMesh;
use pcsss::lights::shadow::{Passage, Point, Shadows};
use pcsss::lights::{self, Light};
use pcsss::progress::Progress;
use pcsss::stages::facet::{self, Mode, Weight};
use pcsss::stages::illum;
use pcsss::stages::scatter::PtareaMode;
use pcsss::stages::sssingle::{self, Model, Params};
use pcsss::Cloud;

/// An icosphere of radius `r` about `c`: the icosahedron's faces split
/// `level` times in four, corners pushed onto the sphere (20 * 4^level
/// faces, wound outwards).
fn icosphere(level: u32, r: f64, c: DVec3) -> Cloud {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<DVec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| DVec3::from_array(*p).normalize())
    .collect();
    let mut f: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let mut m = |i: usize, j: usize| {
                *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                    v.push(((v[i] + v[j]) * 0.5).normalize());
                    v.len() - 1
                })
            };
            let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    let p: Vec<[f64; 3]> = v.iter().map(|q| (c + *q * r).to_array()).collect();
    let faces: Vec<Vec<i32>> = f.iter().map(|t| t.map(|i| i as i32).to_vec()).collect();
    mesh_from(&p, &faces)
}

/// `n` points scattered on `mesh` with its flat or smooth normals.
fn points_on(mesh: &Cloud, n: usize, mode: Mode) -> Cloud {
    let mut c = scatter_n(mesh, n, 3, PtareaMode::Centroid);
    let params = facet::Params {
        mode,
        weight: Weight::Angle,
        cusp: 60.0,
        weld: false,
    };
    facet::facet_points(&mut c, &TriMesh::from_cloud(mesh).unwrap(), &params).unwrap();
    c
}

/// Unit directions `n cos + t sin` about unit `n`, for the grazing cosines
/// and four azimuths.
fn grazing(n: DVec3) -> Vec<DVec3> {
    let (u, v) = n.any_orthonormal_pair();
    let mut out = Vec::new();
    for cos in [1e-4, 1e-3, 1e-2, 0.05, 0.3] {
        let sin = (1.0f64 - cos * cos).sqrt();
        for k in 0..4 {
            let a = std::f64::consts::FRAC_PI_2 * k as f64 + 0.3;
            let t = u * a.cos() + v * a.sin();
            out.push((n * cos + t * sin).normalize());
        }
    }
    out
}

#[test]
fn grazing_light_is_never_shadowed_on_a_convex_mesh() {
    for level in 1..=6u32 {
        for centre in [DVec3::ZERO, DVec3::new(1e3, -500.0, 250.0)] {
            let mesh = icosphere(level, 1.0, centre);
            let tris = TriMesh::from_cloud(&mesh).unwrap();
            let occ = Occluder::new(&tris);
            let shadows = Shadows::new(&tris, &occ, None);
            for mode in [Mode::Flat, Mode::Smooth] {
                let pts = points_on(&mesh, 1000, mode);
                let (pos, nrm) = (positions(&pts), pts.points().vec3_f64("N").unwrap());
                let prim = pts.points().scalar_f64("sourceprim").unwrap();
                let mut blocked = 0;
                let mut rays = 0;
                for (i, (p, n)) in pos.iter().zip(&nrm).enumerate() {
                    let n = DVec3::from_array(*n).normalize();
                    // The triangle found from the mesh alone, from the
                    // face the point was scattered on, and from a face
                    // it is not on (passed over).
                    let face = prim[i] as usize;
                    let wrong = (face + 7) % tris.face_count();
                    let mut at = [
                        Point::new(*p, n),
                        Point::new(*p, n).on_face(face),
                        Point::new(*p, n).on_face(wrong),
                    ];
                    for dir in grazing(n) {
                        // A distant light, and a point light 10 away.
                        for dist in [f64::INFINITY, 10.0] {
                            for a in at.iter_mut() {
                                rays += 1;
                                blocked += shadows.from_point(None, a, dir, dist).blocked as usize;
                            }
                        }
                    }
                }
                assert_eq!(
                    blocked,
                    0,
                    "{} faces about {centre}, {mode:?} normals: {blocked} of {rays} rays blocked",
                    tris.tris.len()
                );
            }
        }
    }
}

/// Eight distant lights about the sphere.
fn lights_around() -> Vec<Light> {
    let dirs = [
        [1.0, 0.2, 0.1],
        [-0.3, 1.0, 0.2],
        [0.1, -0.4, 1.0],
        [-1.0, -1.0, 0.3],
        [0.5, 0.5, -1.0],
        [-0.2, 0.9, -0.6],
        [0.7, -0.8, -0.1],
        [0.05, 0.02, -1.0],
    ];
    let list: Vec<String> = dirs
        .iter()
        .enumerate()
        .map(|(i, d)| {
            format!(
                r#"{{"type": "distant", "name": "l{i}", "direction": [{}, {}, {}]}}"#,
                d[0], d[1], d[2]
            )
        })
        .collect();
    lights::parse(&format!(r#"{{"lights": [{}]}}"#, list.join(",")), "test").unwrap()
}

#[test]
fn illum_and_sssingle_find_no_shadow_on_a_convex_mesh() {
    let lights = lights_around();
    for level in [1u32, 3, 6] {
        let mesh = icosphere(level, 1.0, DVec3::ZERO);
        let tris = TriMesh::from_cloud(&mesh).unwrap();
        let occ = Occluder::new(&tris);
        let shadows = Shadows::new(&tris, &occ, None);
        for mode in [Mode::Flat, Mode::Smooth] {
            let mut c = points_on(&mesh, 4000, mode);
            let r = illum::illum(&mut c, &lights, Some(&shadows), 0, &Progress::hidden()).unwrap();
            assert!(r.rays > 10_000);
            assert_eq!(r.blocked, 0, "illum, level {level}, {mode:?}: {r:?}");
            // sssingle's rays leave the mesh where light enters it, at
            // every angle; its flat and smooth normals there.
            for cusp in [0.0, 60.0] {
                let p = Params {
                    model: Model::Physical,
                    mfp: [0.3; 3],
                    eta: 1.0,
                    g: 0.4,
                    samples: 4,
                    cusp,
                    eye: DVec3::new(0.3, -4.0, 1.0),
                    ..Params::default()
                };
                let mut s = points_on(&mesh, 1000, mode);
                let r =
                    sssingle::sssingle(&mut s, &tris, &lights, &p, &Progress::hidden()).unwrap();
                assert!(r.shadow_rays > 5_000, "{r:?}");
                assert_eq!(
                    r.shadowed, 0,
                    "sssingle, level {level}, {mode:?}, cusp {cusp}: {r:?}"
                );
            }
        }
    }
}

/// The chord a line through `p` along unit `d` cuts from the sphere of
/// radius `r` about `c` (0 when it misses), from `p` on.
fn chord(p: DVec3, d: DVec3, c: DVec3, r: f64) -> f64 {
    let o = p - c;
    let b = o.dot(d);
    let disc = b * b - (o.length_squared() - r * r);
    if disc <= 0.0 {
        return 0.0;
    }
    let (t0, t1) = (-b - disc.sqrt(), -b + disc.sqrt());
    (t1.max(0.0) - t0.max(0.0)).max(0.0)
}

#[test]
fn a_ball_in_the_way_shadows_what_it_hides_and_its_medium_lets_light_through() {
    // A sphere and, between it and a distant light, a ball: a point is
    // behind the ball when its ray to the light passes through it
    // (within a band of the faceted ball's outline, where either answer
    // is right).
    let body = icosphere(4, 1.0, DVec3::ZERO);
    let (bc, br) = (DVec3::new(0.0, 0.0, 2.0), 0.4);
    let ball = icosphere(4, br, bc);
    let both = join_meshes(&body, &ball);
    let tris = TriMesh::from_cloud(&both).unwrap();
    let occ = Occluder::new(&tris);
    let sigma = DVec3::new(10.0, 5.0, 2.5);
    let opaque = Shadows::new(&tris, &occ, None);
    let medium = Shadows::new(
        &tris,
        &occ,
        Some(Passage {
            sigma_t: sigma,
            eta: 1.0,
        }),
    );
    let dir = DVec3::new(0.1, 0.05, 1.0).normalize();
    // The faceted ball lies between radii br cos(a) and br: a band of
    // 2% of its radius holds both outlines.
    let band = 0.02 * br;
    for mode in [Mode::Flat, Mode::Smooth] {
        let pts = points_on(&body, 4000, mode);
        let (pos, nrm) = (positions(&pts), pts.points().vec3_f64("N").unwrap());
        let (mut hidden, mut seen) = (0, 0);
        for (p, n) in pos.iter().zip(&nrm) {
            let n = DVec3::from_array(*n).normalize();
            if n.dot(dir) <= 0.0 {
                continue;
            }
            let miss = (*p - bc).cross(dir).length(); // distance of the line from the centre
            let reach = opaque.from_point(None, &mut Point::new(*p, n), dir, f64::INFINITY);
            if miss < br - band && (bc - *p).dot(dir) > 0.0 {
                hidden += 1;
                assert!(
                    reach.blocked && reach.through == DVec3::ZERO,
                    "{p}: {reach:?}"
                );
                // Through the medium: exp(-sigma d) over the chord, the
                // faceted chord within 3% of the sphere's.
                let d = chord(*p, dir, bc, br);
                let got = medium
                    .from_point(None, &mut Point::new(*p, n), dir, f64::INFINITY)
                    .through;
                for c in 0..3 {
                    let (lo, hi) = (
                        (-sigma[c] * d * 1.03).exp(),
                        (-sigma[c] * (d * 0.97 - 0.02 * br)).exp(),
                    );
                    assert!(
                        got[c] >= lo * 0.999 && got[c] <= hi * 1.001,
                        "{p} channel {c}: {} not in [{lo}, {hi}] (chord {d})",
                        got[c]
                    );
                }
            } else if miss > br + band {
                seen += 1;
                assert!(!reach.blocked, "{p}: {reach:?}");
                assert_eq!(
                    medium
                        .from_point(None, &mut Point::new(*p, n), dir, f64::INFINITY)
                        .through,
                    DVec3::ONE
                );
            }
        }
        assert!(
            hidden > 100 && seen > 1000,
            "{mode:?}: {hidden} hidden, {seen} seen"
        );
    }
}

#[test]
fn a_ray_that_crosses_the_solid_under_a_tilted_normal_is_blocked() {
    // A point on the sphere whose normal is tilted far from its facet
    // (as a coarse mesh's smooth normals are): a light it faces, but its
    // facet does not, sends the ray into the solid. Near the point the
    // ray leaves beside its own triangle (the terminator: lit); deeper,
    // it crosses the sphere and leaves far away (blocked, and through a
    // medium by the chord).
    let mesh = icosphere(5, 1.0, DVec3::ZERO);
    let tris = TriMesh::from_cloud(&mesh).unwrap();
    let occ = Occluder::new(&tris);
    let opaque = Shadows::new(&tris, &occ, None);
    let sigma = DVec3::new(1.0, 0.5, 0.25);
    let medium = Shadows::new(
        &tris,
        &occ,
        Some(Passage {
            sigma_t: sigma,
            eta: 1.0,
        }),
    );
    // A point beside the north pole, on a facet (these are about 2
    // degrees apart at this level).
    let (p, facet) = icosphere_point_near(&tris, DVec3::Z);
    let x = (DVec3::X - facet * facet.x).normalize();
    let n = (facet + x * 3.0).normalize();
    for dive_deg in [0.2f64, 10.0, 40.0] {
        let a = dive_deg.to_radians();
        let dir = (x * a.cos() - facet * a.sin()).normalize();
        assert!(n.dot(dir) > 0.0);
        let r = opaque.from_point(None, &mut Point::new(p, n), dir, f64::INFINITY);
        // The chord of the unit sphere from the point on.
        let d = chord(p, dir, DVec3::ZERO, 1.0);
        if dive_deg < 1.0 {
            // Out again through a facet beside its own.
            assert!(!r.blocked, "dive {dive_deg}: {r:?}");
        } else {
            assert!(
                r.blocked && r.through == DVec3::ZERO,
                "dive {dive_deg}: {r:?}"
            );
            let got = medium
                .from_point(None, &mut Point::new(p, n), dir, f64::INFINITY)
                .through;
            for c in 0..3 {
                let want = (-sigma[c] * d).exp();
                assert!(
                    (got[c] / want - 1.0).abs() < 0.02,
                    "dive {dive_deg} channel {c}: {} against {want}",
                    got[c]
                );
            }
        }
    }
}

/// A point of `tris`'s surface a little off the vertex nearest `dir` (on
/// a triangle, not an edge), and its triangle's unit normal.
fn icosphere_point_near(tris: &TriMesh, dir: DVec3) -> (DVec3, DVec3) {
    let t = (0..tris.tris.len())
        .max_by(|&a, &b| {
            let c = |t: usize| tris.tri(t).iter().copied().sum::<DVec3>().dot(dir);
            c(a).total_cmp(&c(b))
        })
        .unwrap();
    let [a, b, c] = tris.tri(t);
    (
        a * 0.8 + b * 0.12 + c * 0.08,
        (b - a).cross(c - a).normalize(),
    )
}

/// Two meshes as one.
pub(crate) fn join_meshes(a: &Cloud, b: &Cloud) -> Cloud {
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

#[test]
fn sssingle_under_a_ball_of_its_medium_keeps_each_channel_s_share() {
    // A slab lit straight from above and seen straight from above (eta
    // 1): every depth sample of a point takes its light through the same
    // place of the top face, so a ball of the medium over the slab
    // multiplies the point's ssS by exp(-sigma_t d) of its chord, per
    // channel; outside its shadow nothing changes.
    let slab = crate::sssingle::slab_mesh(5.0, 2.0, DVec3::ZERO);
    let (bc, br) = (DVec3::new(0.0, 0.0, 1.5), 0.5);
    let with_ball = join_meshes(&slab, &icosphere(4, br, bc));
    let p: Vec<[f64; 3]> = (0..41)
        .map(|i| [-1.0 + 0.05 * i as f64, 0.013, 0.0])
        .collect();
    let mut pts = Cloud::with_points(p.len());
    pts.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    pts.points_mut()
        .set_vec3("N", Role::Normal, &vec![[0.0f32, 0.0, 1.0]; p.len()])
        .unwrap();
    let mfp = [0.1, 0.2, 0.4];
    let params = Params {
        model: Model::Physical,
        mfp,
        albedo: [0.9; 3],
        eta: 1.0,
        g: 0.3,
        samples: 16,
        eye: DVec3::new(0.0, 0.0, 1e7),
        ..Params::default()
    };
    let lights = crate::sssingle::distant(0.0, [1.0; 3]);
    let bare = crate::sssingle::run(&pts, &slab, &lights, &params);
    let shaded = crate::sssingle::run(&pts, &with_ball, &lights, &params);
    let mut inside = 0;
    for (i, q) in p.iter().enumerate() {
        let rho = (q[0] * q[0] + q[1] * q[1]).sqrt();
        let d = chord(DVec3::from_array(*q), DVec3::Z, bc, br);
        for c in 0..3 {
            let ratio = shaded[i][c] / bare[i][c];
            if rho < br * 0.97 {
                let (lo, hi) = (
                    (-d * 1.02 / mfp[c]).exp(),
                    (-(d * 0.98 - 0.03 * br) / mfp[c]).exp(),
                );
                assert!(
                    ratio >= lo * 0.999 && ratio <= hi * 1.001,
                    "x {}: channel {c} {ratio} not in [{lo}, {hi}]",
                    q[0]
                );
            } else if rho > br * 1.01 {
                assert_eq!(ratio, 1.0, "x {}: channel {c}", q[0]);
            }
        }
        inside += (rho < br * 0.97) as usize;
    }
    assert!(inside > 10);
}
