//! Property tests (proptest): PLY and OpenEXR round trips of generated
//! clouds (any attributes, any types, any counts, details and comments),
//! and the stages' invariants over generated scenes (thread count,
//! translation, scale, attribute order, point order).
//!
//! The generator's seed is fixed, so `make test` is the same run every
//! time; `PCSSS_PROPTEST_SEED=N` explores another part of the space and
//! `PCSSS_PROPTEST_CASES=N` runs more cases. A failing case is shrunk to a
//! small one and printed.

use glam::DVec3;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

use crate::util::*;
use pcsss::cloud::{AttrData, ListColumn};
use pcsss::formats::exr::{Compression, ExrOptions};
use pcsss::formats::{self, Format, Select};
use pcsss::geom::bvh::Occluder;
use pcsss::geom::mesh::TriMesh;
use pcsss::progress::Progress;
use pcsss::stages::scatter::{self, Amount, PtareaMode};
use pcsss::stages::ssmulti::{self, Falloff, Norm, BURLEY_KAPPA};
use pcsss::stages::{facet, illum, sssingle};
use pcsss::{Attribute, Cloud, Column, DetailValue, Element, Role, ScalarType};

/// `cases` cases (times `PCSSS_PROPTEST_CASES / 100` when set), from the
/// fixed seed or `PCSSS_PROPTEST_SEED`.
fn config(cases: u32) -> Config {
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<u64>().ok());
    let cases =
        env("PCSSS_PROPTEST_CASES").map_or(cases, |c| (cases as u64 * c / 100).max(1) as u32);
    Config {
        cases,
        rng_seed: RngSeed::Fixed(env("PCSSS_PROPTEST_SEED").unwrap_or(0x5eed_c10d)),
        max_shrink_iters: 2000,
        ..Config::default()
    }
}

// ---------------------------------------------------------------------------
// Generated clouds.

fn scalar_type() -> impl Strategy<Value = ScalarType> {
    proptest::sample::select(ScalarType::ALL.to_vec())
}

fn int_type() -> impl Strategy<Value = ScalarType> {
    proptest::sample::select(
        ScalarType::ALL
            .into_iter()
            .filter(|t| !t.is_float())
            .collect::<Vec<_>>(),
    )
}

/// `n` values of type `ty`: every bit pattern, NaNs and infinities included.
fn column(ty: ScalarType, n: usize) -> BoxedStrategy<Column> {
    use proptest::collection::vec;
    match ty {
        ScalarType::I8 => vec(any::<i8>(), n).prop_map(Column::I8).boxed(),
        ScalarType::U8 => vec(any::<u8>(), n).prop_map(Column::U8).boxed(),
        ScalarType::I16 => vec(any::<i16>(), n).prop_map(Column::I16).boxed(),
        ScalarType::U16 => vec(any::<u16>(), n).prop_map(Column::U16).boxed(),
        ScalarType::I32 => vec(any::<i32>(), n).prop_map(Column::I32).boxed(),
        ScalarType::U32 => vec(any::<u32>(), n).prop_map(Column::U32).boxed(),
        ScalarType::F32 => vec(any::<u32>().prop_map(f32::from_bits), n)
            .prop_map(Column::F32)
            .boxed(),
        ScalarType::F64 => vec(any::<u64>().prop_map(f64::from_bits), n)
            .prop_map(Column::F64)
            .boxed(),
    }
}

fn role() -> impl Strategy<Value = Role> {
    prop_oneof![
        Just(Role::Point),
        Just(Role::Vector),
        Just(Role::Normal),
        Just(Role::Color)
    ]
}

/// A list column of `n` rows of 0 to 5 items (fewer than a signed
/// byte count can hold).
fn list(n: usize) -> BoxedStrategy<AttrData> {
    (
        int_type(),
        scalar_type(),
        proptest::collection::vec(0usize..=5, n),
    )
        .prop_flat_map(|(ct, it, lens)| {
            let total = lens.iter().sum();
            (Just(ct), Just(lens), column(it, total))
        })
        .prop_map(|(ct, lens, items)| {
            let mut l = ListColumn::new(ct, items.ty());
            let mut at = 0;
            for k in lens {
                at += k;
                l.offsets.push(at);
            }
            l.items = items;
            AttrData::List(l)
        })
        .boxed()
}

/// An attribute's values for `n` rows: a scalar, a 3-vector (one type for
/// its three components, as the PLY convention groups them) or, when
/// `lists`, a list.
fn attr_data(n: usize, lists: bool) -> BoxedStrategy<AttrData> {
    let scalar = scalar_type()
        .prop_flat_map(move |t| column(t, n))
        .prop_map(|c| AttrData::Scalar(c.into()));
    let vec3 = (scalar_type(), role())
        .prop_flat_map(move |(t, r)| (Just(r), column(t, n), column(t, n), column(t, n)))
        .prop_map(|(r, a, b, c)| AttrData::Vec3(r, Box::new([a.into(), b.into(), c.into()])));
    if lists {
        prop_oneof![3 => scalar, 2 => vec3, 1 => list(n)].boxed()
    } else {
        prop_oneof![3 => scalar, 2 => vec3].boxed()
    }
}

/// A name no convention reads into something else: a stem and a unique
/// number (never `x`, `nx`, `A_x` or `A_r`); the 3-vectors' own names `P`
/// and `N` are given to the first 3-vectors.
fn name_stem() -> impl Strategy<Value = String> {
    "[a-zA-Z][a-zA-Z0-9]{0,5}"
}

fn element(name: String, n: usize, lists: bool) -> BoxedStrategy<Element> {
    proptest::collection::vec((name_stem(), attr_data(n, lists)), 0..6)
        .prop_map(move |attrs| {
            let mut e = Element::new(&name, n);
            let mut special = vec!["N", "P"];
            for (i, (stem, data)) in attrs.into_iter().enumerate() {
                let name = match (&data, special.last()) {
                    (AttrData::Vec3(..), Some(_)) => special.pop().unwrap().to_string(),
                    _ => format!("{stem}{i}"),
                };
                e.set(Attribute { name, data }).unwrap();
            }
            e
        })
        .boxed()
}

fn detail_value() -> impl Strategy<Value = DetailValue> {
    let f32s = any::<u32>().prop_map(f32::from_bits);
    let f64s = any::<u64>().prop_map(f64::from_bits);
    prop_oneof![
        any::<i32>().prop_map(DetailValue::I32),
        f32s.clone().prop_map(DetailValue::F32),
        f64s.clone().prop_map(DetailValue::F64),
        [f32s.clone(), f32s.clone(), f32s].prop_map(DetailValue::V3F),
        [f64s.clone(), f64s.clone(), f64s].prop_map(DetailValue::V3D),
        any::<String>().prop_map(DetailValue::Str),
    ]
}

/// Details, comments and `obj_info` lines: any text on one line, and
/// lines that look like the toolkit's own `pcsss` comments or have
/// whitespace at their ends.
fn extras(cloud: Cloud) -> BoxedStrategy<Cloud> {
    let line = prop_oneof![
        "[^\r\n]{0,24}",
        "pcsss( (detail|role|vertex|x|i32|f64|str|P|point|1|\"a\")){0,4}",
        "[ \t]{0,2}[a-z ]{0,3}[ \t]{0,2}",
    ];
    (
        proptest::collection::vec(("[a-zA-Z_][a-zA-Z0-9_.:]{0,8}", detail_value()), 0..5),
        proptest::collection::vec(line.clone(), 0..3),
        proptest::collection::vec(line, 0..2),
    )
        .prop_map(move |(details, comments, obj_info)| {
            let mut c = cloud.clone();
            for (name, v) in details {
                c.set_detail(&name, v);
            }
            c.comments = comments;
            c.obj_info = obj_info;
            c
        })
        .boxed()
}

/// Counts around the EXR layout's 1024-wide rows as well as small ones.
fn count() -> impl Strategy<Value = usize> {
    prop_oneof![8 => 0usize..40, 1 => 1020usize..1030]
}

/// A PLY cloud: `vertex` and up to two other elements (lists allowed),
/// in any order.
fn ply_cloud() -> BoxedStrategy<Cloud> {
    (proptest::collection::vec(count(), 1..=3), 0usize..3)
        .prop_flat_map(|(counts, at)| {
            let k = counts.len();
            let elems: Vec<_> = counts
                .into_iter()
                .enumerate()
                .map(|(i, n)| {
                    let name = if i == at % k {
                        "vertex".to_string()
                    } else {
                        format!("elem{i}")
                    };
                    element(name, n, true)
                })
                .collect();
            elems
        })
        .prop_flat_map(|elements| {
            extras(Cloud {
                elements,
                ..Cloud::default()
            })
        })
        .boxed()
}

/// An EXR cloud: points only, no lists.
fn exr_cloud() -> BoxedStrategy<Cloud> {
    count()
        .prop_flat_map(|n| element("vertex".into(), n, false))
        .prop_flat_map(|e| {
            extras(Cloud {
                elements: vec![e],
                ..Cloud::default()
            })
        })
        .boxed()
}

/// Detail values equal bit for bit, but any NaN equals any NaN (text
/// keeps a NaN, not its payload).
fn same_detail(a: &Cloud, b: &Cloud) -> Result<(), TestCaseError> {
    prop_assert_eq!(a.detail.len(), b.detail.len());
    let f32_same = |x: f32, y: f32| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan());
    let f64_same = |x: f64, y: f64| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan());
    for (x, y) in a.detail.iter().zip(&b.detail) {
        prop_assert_eq!(&x.name, &y.name);
        let same = match (&x.value, &y.value) {
            (DetailValue::F32(p), DetailValue::F32(q)) => f32_same(*p, *q),
            (DetailValue::F64(p), DetailValue::F64(q)) => f64_same(*p, *q),
            (DetailValue::V3F(p), DetailValue::V3F(q)) => (0..3).all(|k| f32_same(p[k], q[k])),
            (DetailValue::V3D(p), DetailValue::V3D(q)) => (0..3).all(|k| f64_same(p[k], q[k])),
            (p, q) => p == q,
        };
        prop_assert!(same, "detail {}: {:?} vs {:?}", x.name, x.value, y.value);
    }
    Ok(())
}

/// Everything but the details as `assert_same_values`, the details as
/// `same_detail`.
fn same_cloud(a: &Cloud, b: &Cloud) -> Result<(), TestCaseError> {
    same_detail(a, b)?;
    let strip = |c: &Cloud| Cloud {
        detail: vec![],
        ..c.clone()
    };
    let (a, b) = (strip(a), strip(b));
    let r = std::panic::catch_unwind(|| assert_same_values(&a, &b));
    prop_assert!(r.is_ok(), "values differ (see the panic above)");
    Ok(())
}

proptest! {
    #![proptest_config(config(96))]

    #[test]
    fn ply_round_trips_any_cloud_in_every_encoding(c in ply_cloud()) {
        for f in [LE, BE, ASCII] {
            let mut bytes = Vec::new();
            formats::write_cloud(&mut bytes, &c, f).unwrap();
            let back = formats::read_cloud(&bytes[..], &Select::All)
                .map_err(|e| TestCaseError::fail(format!("{f:?} does not read back: {e}")))?;
            same_cloud(&c, &back)?;
            // What was read writes the same bytes again.
            let mut again = Vec::new();
            formats::write_cloud(&mut again, &back, f).unwrap();
            prop_assert!(bytes == again, "{:?}: second write differs", f);
        }
    }

    #[test]
    fn exr_round_trips_any_points(
        c in exr_cloud(),
        comp in proptest::sample::select(vec!["none", "rle", "zips", "zip", "piz"]),
    ) {
        let opt = ExrOptions { compression: comp.parse::<Compression>().unwrap(), half: vec![] };
        let mut bytes = Vec::new();
        let wrote = formats::write_cloud_with(&mut bytes, &c, Format::Exr, &opt);
        if c.points().attrs().is_empty() {
            // OpenEXR needs a channel: refused, with the reason.
            let e = wrote.unwrap_err().to_string();
            prop_assert!(e.contains("no attributes"), "{}", e);
            return Ok(());
        }
        wrote.unwrap();
        let back = formats::read_cloud(&bytes[..], &Select::All)
            .map_err(|e| TestCaseError::fail(format!("{comp}: does not read back: {e}")))?;
        same_cloud(&c, &back)?;
    }
}

// ---------------------------------------------------------------------------
// Stage invariants.

/// `f` on a pool of `threads` threads.
fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

/// `c` with each element's attributes in the order `key` sorts them to,
/// and one more attribute (`extra`, u16) that no stage reads.
fn reordered(c: &Cloud, key: u64) -> Cloud {
    let mut out = c.clone();
    for e in &mut out.elements {
        let mut attrs = e.attrs().to_vec();
        attrs.sort_by_key(|a| {
            let h = a
                .name
                .bytes()
                .fold(key, |h, b| h.wrapping_mul(31).wrapping_add(b as u64));
            h.wrapping_mul(0x9e37_79b9_7f4a_7c15)
        });
        let mut fresh = Element::new(&e.name, e.len());
        let extra = (0..e.len())
            .map(|i| (i as u16).wrapping_mul(7919))
            .collect();
        attrs.insert(
            (key % (attrs.len() as u64 + 1)) as usize,
            Attribute::scalar("extra", Column::U16(extra)),
        );
        for a in attrs {
            fresh.set(a).unwrap();
        }
        *e = fresh;
    }
    out
}

/// `c`'s points in the order of `perm` (`perm[i]` is the old index of new
/// point `i`).
fn permuted(c: &Cloud, perm: &[usize]) -> Cloud {
    let mut out = c.clone();
    out.set_points(c.points().gather(perm));
    out
}

fn permutation(n: usize, key: u64) -> Vec<usize> {
    let mut p: Vec<usize> = (0..n).collect();
    p.sort_by_key(|&i| (i as u64 ^ key).wrapping_mul(0x9e37_79b9_7f4a_7c15));
    p
}

/// Largest |a - b| over the largest |a| (0 when both are all 0).
fn rel_diff(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let top = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let d = a
        .iter()
        .flatten()
        .zip(b.iter().flatten())
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    if top == 0.0 {
        d
    } else {
        d / top
    }
}

fn bits(v: &[[f64; 3]]) -> Vec<[u64; 3]> {
    v.iter().map(|x| x.map(f64::to_bits)).collect()
}

fn ssm(c: &Cloud) -> Vec<[f64; 3]> {
    c.points().vec3_f64("ssM").unwrap()
}

fn ssmulti_params() -> impl Strategy<Value = ssmulti::Params> {
    (
        prop_oneof![
            Just(Falloff::Smooth),
            (0.5f64..50.0).prop_map(|sigma| Falloff::Exp { sigma }),
            Just(Falloff::Burley {
                kappa: BURLEY_KAPPA
            }),
        ],
        prop_oneof![Just(Norm::Seed), Just(Norm::Channel), Just(Norm::Local)],
        any::<bool>(),
        0.0f64..1.0,
        prop_oneof![2 => Just(0.0), 1 => 0.05f64..0.5],
        [0.05f64..1.0, 0.05f64..1.0, 0.05f64..1.0],
        0.05f64..0.8,
    )
        .prop_map(
            |(falloff, norm, rgb, bounce, tolerance, rd, sd)| ssmulti::Params {
                rd,
                sd,
                bounce,
                rgb,
                falloff,
                norm,
                tolerance,
                ..ssmulti::Params::default()
            },
        )
}

/// `n` points on the mesh cube's surface (seed `seed`) with the faces'
/// normals.
fn scattered(n: usize, seed: u64, mode: PtareaMode) -> Cloud {
    let mesh = cube();
    let mut c = scatter_n(&mesh, n, seed, mode);
    let m = TriMesh::from_cloud(&mesh).unwrap();
    let p = facet::Params {
        mode: facet::Mode::Flat,
        weight: facet::Weight::Angle,
        cusp: 60.0,
        weld: true,
    };
    facet::facet_points(&mut c, &m, &p).unwrap();
    c
}

/// An f64 copy of `c`'s positions moved by `offset` and scaled by `s`
/// about the origin (areas by s^2).
fn moved(c: &Cloud, offset: DVec3, s: f64) -> Cloud {
    let mut out = c.clone();
    let p: Vec<[f64; 3]> = c
        .points()
        .vec3_f64("P")
        .unwrap()
        .iter()
        .map(|v| (DVec3::from_array(*v) * s + offset).to_array())
        .collect();
    let pts = out.points_mut();
    pts.set_vec3("P", Role::Point, &p).unwrap();
    if pts.has("ptarea") {
        let a: Vec<f64> = pts
            .scalar_f64("ptarea")
            .unwrap()
            .iter()
            .map(|a| a * s * s)
            .collect();
        pts.set_scalar("ptarea", a).unwrap();
    }
    out
}

/// `illum` from a fixed light: the toolkit's own, independent of the
/// cloud's frame.
fn lit(c: &Cloud) -> Cloud {
    let mut c = c.clone();
    let p = c.points().vec3_f64("P").unwrap();
    c.points_mut()
        .set_vec3(
            "illum",
            Role::Color,
            &p.iter()
                .enumerate()
                .map(|(i, _)| [(i % 7) as f32 * 0.3, 1.0, (i % 3) as f32])
                .collect::<Vec<_>>(),
        )
        .unwrap();
    c
}

proptest! {
    #![proptest_config(config(24))]

    #[test]
    fn ssmulti_is_the_same_on_any_threads_attribute_order_point_order_frame(
        n in 30usize..400,
        seed in any::<u64>(),
        p in ssmulti_params(),
        key in any::<u64>(),
        offset in prop_oneof![Just(DVec3::ZERO), (-1e6f64..1e6, -1e6f64..1e6, -1e6f64..1e6).prop_map(|(x, y, z)| DVec3::new(x, y, z))],
        k in -30i32..30,
        s in 1e-4f64..1e4,
    ) {
        let base = moved(&lit(&scattered(n, seed, PtareaMode::Voronoi)), DVec3::ZERO, 1.0);
        let run = |c: &Cloud, p: &ssmulti::Params| {
            let mut c = c.clone();
            ssmulti::ssmulti(&mut c, p, &Progress::hidden()).unwrap();
            c
        };
        let want_cloud = on_threads(1, || run(&base, &p));
        let want = ssm(&want_cloud);
        // Thread count: bit for bit.
        let two = on_threads(2, || run(&base, &p));
        prop_assert_eq!(bits(&ssm(&two)), bits(&want));
        // Attribute order and an attribute no stage reads: bit for bit, and
        // the extra attribute comes out unchanged.
        let r = reordered(&base, key);
        let got = run(&r, &p);
        prop_assert_eq!(bits(&ssm(&got)), bits(&want));
        prop_assert_eq!(got.points().attr("extra"), r.points().attr("extra"));
        // Point order: the same values, permuted (sums in another order).
        let perm = permutation(n, key);
        let got = ssm(&run(&permuted(&base, &perm), &p));
        let back: Vec<[f64; 3]> = perm.iter().map(|&i| want[i]).collect();
        prop_assert!(rel_diff(&back, &got) < 1e-5, "point order: {}", rel_diff(&back, &got));
        // A power-of-two scale: bit for bit.
        let s2 = 2f64.powi(k);
        let got = ssm(&run(&moved(&base, DVec3::ZERO, s2), &ssmulti::Params { sd: p.sd * s2, ..p }));
        prop_assert_eq!(bits(&got), bits(&want), "scale 2^{}", k);
        // Any translation and scale: to f32's accuracy of the result.
        let got = ssm(&run(&moved(&base, offset * s, s), &ssmulti::Params { sd: p.sd * s, ..p }));
        let tol = if p.tolerance > 0.0 { 2e-3 } else { 2e-5 };
        prop_assert!(rel_diff(&want, &got) < tol, "offset {} scale {}: {}", offset * s, s, rel_diff(&want, &got));
    }

    #[test]
    fn scatter_is_the_same_on_any_threads_and_moves_with_its_mesh(
        n in 1usize..600,
        seed in any::<u64>(),
        mode in prop_oneof![Just(PtareaMode::Prim), Just(PtareaMode::Knn), Just(PtareaMode::Voronoi), Just(PtareaMode::Centroid)],
        relax in 0u32..3,
        offset in (-1e6f64..1e6, -1e6f64..1e6, -1e6f64..1e6).prop_map(|(x, y, z)| DVec3::new(x, y, z)),
        k in -20i32..20,
    ) {
        let mesh = moved(&cube(), DVec3::ZERO, 1.0);
        let p = scatter::Params { amount: Amount::Count(n), seed, ptarea: mode, relax, ..scatter::Params::new(Amount::Count(n)) };
        let one = on_threads(1, || scatter::scatter(&mesh, &p).unwrap());
        let two = on_threads(2, || scatter::scatter(&mesh, &p).unwrap());
        prop_assert!(one == two, "thread count changes the points");
        prop_assert_eq!(one.len(), n);
        // A power-of-two scale of the mesh: the same points, scaled, bit
        // for bit, and areas times 4^k.
        let s = 2f64.powi(k);
        let big = scatter::scatter(&moved(&mesh, DVec3::ZERO, s), &p).unwrap();
        let a = one.points().vec3_f64("P").unwrap();
        let b = big.points().vec3_f64("P").unwrap();
        for (x, y) in a.iter().zip(&b) {
            prop_assert_eq!(x.map(|v| v * s), *y);
        }
        let aa = one.points().scalar_f64("ptarea").unwrap();
        let ab = big.points().scalar_f64("ptarea").unwrap();
        for (x, y) in aa.iter().zip(&ab) {
            prop_assert!((x * s * s - y).abs() <= 1e-5 * x * s * s, "ptarea {} vs {}", x * s * s, y);
        }
        // A translated mesh: the same points, translated (f64 positions).
        // Relaxation is chaotic on a crease: a point pushed onto an edge
        // of the cube is equally near both faces, rounding picks one, and
        // its next steps follow that face's plane. So with relaxation only
        // most points must agree (measured: 39 of 269 points differ, by
        // up to 4% of the spacing, after 5 iterations 7e5 away).
        let far = scatter::scatter(&moved(&mesh, offset, 1.0), &p).unwrap();
        let b = far.points().vec3_f64("P").unwrap();
        let off = a
            .iter()
            .zip(&b)
            .filter(|(x, y)| {
                (DVec3::from_array(**x) + offset - DVec3::from_array(**y)).length()
                    > 1e-9 * (1.0 + offset.length())
            })
            .count();
        let allowed = if relax == 0 { 0 } else { n / 4 };
        prop_assert!(off <= allowed, "moved by {}: {} of {} points differ", offset, off, n);
    }

    #[test]
    fn illum_is_the_same_on_any_threads_attribute_order_and_frame(
        n in 1usize..400,
        seed in any::<u64>(),
        key in any::<u64>(),
        offset in (-1e6f64..1e6, -1e6f64..1e6, -1e6f64..1e6).prop_map(|(x, y, z)| DVec3::new(x, y, z)),
    ) {
        let mesh = moved(&cube(), DVec3::ZERO, 1.0);
        let cloud = scattered(n, seed, PtareaMode::Prim);
        let lights = |o: DVec3| {
            let at = |v: [f64; 3]| (DVec3::from_array(v) + o).to_array();
            pcsss::lights::parse(&format!(r#"{{ "lights": [
                {{ "name": "sun", "type": "distant", "direction": [-0.4, -1.0, -0.6], "intensity": 2 }},
                {{ "name": "bulb", "type": "point", "position": {:?}, "intensity": 5 }},
                {{ "name": "rim", "type": "spot", "position": {:?}, "direction": [0.0, -0.8, 0.8],
                   "intensity": 8, "cone_angle": 40, "cone_delta": 10 }},
                {{ "name": "panel", "type": "rect", "position": {:?}, "u": [0, 0, 1], "v": [0, 1, 0],
                   "intensity": 6, "samples": 4 }}
            ] }}"#, at([2.0, 1.5, 1.0]), at([0.5, 3.0, -2.5]), at([3.0, 1.0, 2.0])), "lights.json").unwrap()
        };
        let run = |c: &Cloud, m: &Cloud, o: DVec3| {
            let mut c = c.clone();
            let tm = TriMesh::from_cloud(m).unwrap();
            let occ = Occluder::new(&tm);
            let sh = illum::Shadows::new(&tm, &occ, None);
            illum::illum(&mut c, &lights(o), Some(&sh), 7, &Progress::hidden()).unwrap();
            c
        };
        let want = on_threads(1, || run(&cloud, &mesh, DVec3::ZERO));
        let e = |c: &Cloud| c.points().vec3_f64("illum").unwrap();
        let two = on_threads(2, || run(&cloud, &mesh, DVec3::ZERO));
        prop_assert_eq!(bits(&e(&two)), bits(&e(&want)));
        let r = reordered(&cloud, key);
        let got = run(&r, &mesh, DVec3::ZERO);
        prop_assert_eq!(bits(&e(&got)), bits(&e(&want)));
        prop_assert_eq!(got.points().attr("extra"), r.points().attr("extra"));
        // Cloud, mesh and lights moved together: the same light. Points on
        // the cube's edges may change sides of a shadow ray's epsilon, so
        // compare all but a few.
        let far = run(&moved(&cloud, offset, 1.0), &moved(&mesh, offset, 1.0), offset);
        let (a, b) = (e(&want), e(&far));
        let top = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let off = a.iter().zip(&b).filter(|(x, y)| (0..3).any(|k| (x[k] - y[k]).abs() > 1e-5 * top)).count();
        prop_assert!(off <= n / 100, "offset {}: {} of {} points differ", offset, off, n);
    }

    #[test]
    fn sssingle_is_the_same_on_any_threads_attribute_order_and_frame(
        n in 1usize..200,
        seed in any::<u64>(),
        key in any::<u64>(),
        offset in (-1e5f64..1e5, -1e5f64..1e5, -1e5f64..1e5).prop_map(|(x, y, z)| DVec3::new(x, y, z)),
        physical in any::<bool>(),
    ) {
        let mesh = moved(&cube(), DVec3::ZERO, 1.0);
        let cloud = scattered(n, seed, PtareaMode::Prim);
        let lights = |o: DVec3| {
            let p = (DVec3::new(2.0, 3.0, 1.5) + o).to_array();
            pcsss::lights::parse(&format!(r#"{{ "lights": [
                {{ "name": "sun", "type": "distant", "direction": [-0.4, -1.0, -0.6], "intensity": 2 }},
                {{ "name": "bulb", "type": "point", "position": {p:?}, "intensity": 5 }}
            ] }}"#), "lights.json").unwrap()
        };
        let params = |o: DVec3| sssingle::Params {
            eye: DVec3::new(3.0, 2.0, 4.0) + o,
            model: if physical { sssingle::Model::Physical } else { sssingle::Model::Seed },
            samples: 8,
            seed: 3,
            ..sssingle::Params::default()
        };
        let run = |c: &Cloud, m: &Cloud, o: DVec3| {
            let mut c = c.clone();
            let tm = TriMesh::from_cloud(m).unwrap();
            sssingle::sssingle(&mut c, &tm, &lights(o), &params(o), &Progress::hidden()).unwrap();
            c
        };
        let s = |c: &Cloud| c.points().vec3_f64("ssS").unwrap();
        let want = on_threads(1, || run(&cloud, &mesh, DVec3::ZERO));
        let two = on_threads(2, || run(&cloud, &mesh, DVec3::ZERO));
        prop_assert_eq!(bits(&s(&two)), bits(&s(&want)));
        let r = reordered(&cloud, key);
        let got = run(&r, &mesh, DVec3::ZERO);
        prop_assert_eq!(bits(&s(&got)), bits(&s(&want)));
        prop_assert_eq!(got.points().attr("extra"), r.points().attr("extra"));
        let far = run(&moved(&cloud, offset, 1.0), &moved(&mesh, offset, 1.0), offset);
        let (a, b) = (s(&want), s(&far));
        let top = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let off = a.iter().zip(&b).filter(|(x, y)| (0..3).any(|k| (x[k] - y[k]).abs() > 1e-4 * top)).count();
        prop_assert!(off <= n / 50, "offset {}: {} of {} points differ", offset, off, n);
    }
}
