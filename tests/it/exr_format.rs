//! OpenEXR point clouds and shade-point images: round trips, layout,
//! readers and writers nobody here wrote (Debian's `exrheader`, Python's
//! `OpenEXR`), bad input.

use std::path::Path;
use std::process::Command;

use crate::util::*;
use pcsss::formats::exr::{Compression, ExrOptions};
use pcsss::formats::{self, Format, Select};
use pcsss::{Cloud, Column, DetailValue, Role};
use serde_json::Value;

const EXR: Format = Format::Exr;

fn exr_bytes(c: &Cloud, opt: &ExrOptions) -> Vec<u8> {
    let mut v = Vec::new();
    formats::write_cloud_with(&mut v, c, EXR, opt).expect("write exr");
    v
}

fn read(b: &[u8]) -> pcsss::Result<Cloud> {
    formats::read_cloud(b, &Select::All)
}

/// `every_type_cloud`'s points and details (EXR holds points only).
fn points_only() -> Cloud {
    let mut c = every_type_cloud();
    c.elements.truncate(1);
    c
}

/// A cloud of `n` points with f32 P, N, illum, ptarea and a detail.
fn cloud_of(n: usize) -> Cloud {
    let mut c = Cloud::with_points(n);
    let p: Vec<[f32; 3]> = (0..n)
        .map(|i| {
            let t = i as f32 * 0.37;
            [t.sin() * 1e3, t.cos() * 1e-3, t]
        })
        .collect();
    let pts = c.points_mut();
    pts.set_vec3("P", Role::Point, &p).unwrap();
    pts.set_vec3("N", Role::Normal, &p).unwrap();
    pts.set_vec3("illum", Role::Color, &p).unwrap();
    pts.set_scalar("ptarea", p.iter().map(|v| v[0]).collect())
        .unwrap();
    c.set_detail("ssmulti_sd", DetailValue::F64(0.25));
    c
}

#[test]
fn every_type_and_detail_round_trips_bit_exact() {
    let c = points_only();
    for comp in ["none", "rle", "zips", "zip", "piz"] {
        let opt = ExrOptions {
            compression: comp.parse().unwrap(),
            half: vec![],
        };
        let back = read(&exr_bytes(&c, &opt)).unwrap();
        assert_same_values(&c, &back);
    }
}

#[test]
fn counts_that_do_not_fill_the_last_row_and_zero_round_trip() {
    for n in [0usize, 1, 7, 1023, 1024, 1025, 2500] {
        let c = cloud_of(n);
        let b = exr_bytes(&c, &ExrOptions::default());
        let back = read(&b).unwrap();
        assert_eq!(back.len(), n);
        assert_same_values(&c, &back);
        // PLY -> EXR -> PLY as files through the binary.
        let dir = tempdir();
        let ply = dir.path().join("in.ply");
        std::fs::write(&ply, to_bytes(&c, LE)).unwrap();
        let exr = dir.path().join("c.exr");
        let o = run(
            "pcconvert",
            &[ply.to_str().unwrap(), "-o", exr.to_str().unwrap()],
            b"",
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let o = run("pcconvert", &[exr.to_str().unwrap()], b"");
        assert!(o.status.success(), "{}", stderr(&o));
        assert_same_values(&c, &from_bytes(&o.stdout));
    }
}

#[test]
fn image_shape_is_rows_of_1024() {
    for (n, w, h) in [
        (0usize, 1usize, 1usize),
        (5, 5, 1),
        (1024, 1024, 1),
        (3000, 1024, 3),
    ] {
        let b = exr_bytes(&cloud_of(n), &ExrOptions::default());
        let meta =
            exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(&b), false).unwrap();
        let size = meta.headers[0].layer_size;
        assert_eq!((size.width(), size.height()), (w, h), "{n} points");
    }
}

#[test]
fn half_on_request_rounds_to_half() {
    let c = cloud_of(100);
    let opt = ExrOptions {
        compression: Compression::Zip,
        half: vec!["illum".into()],
    };
    let back = read(&exr_bytes(&c, &opt)).unwrap();
    let a = c.points().vec3_f32("illum").unwrap();
    let b = back.points().vec3_f32("illum").unwrap();
    for (x, y) in a.iter().zip(&b) {
        for k in 0..3 {
            let h = exr::prelude::f16::from_f32(x[k]).to_f32();
            assert_eq!(h.to_bits(), y[k].to_bits());
        }
    }
    // The other attributes stay f32, exact.
    assert_eq!(
        c.points().vec3_f32("P").unwrap(),
        back.points().vec3_f32("P").unwrap()
    );
    // Only float attributes can be half.
    let mut c2 = c.clone();
    c2.points_mut()
        .set(pcsss::Attribute::scalar("id", Column::I32(vec![1; 100])))
        .unwrap();
    let mut v = Vec::new();
    let e = formats::write_cloud_with(
        &mut v,
        &c2,
        EXR,
        &ExrOptions {
            half: vec!["id".into()],
            ..Default::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("parameter half") && e.contains("id"), "{e}");
}

#[test]
fn faces_and_lists_are_refused_not_dropped() {
    let e = formats::write_cloud(&mut Vec::new(), &every_type_cloud(), EXR)
        .unwrap_err()
        .to_string();
    assert!(e.contains("face") && e.contains("PLY"), "{e}");
}

#[test]
fn stdin_to_stdout_and_format_flag() {
    let c = cloud_of(3000);
    let o = run("pcconvert", &["--format", "exr"], &to_bytes(&c, LE));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(o.stdout.starts_with(&formats::EXR_MAGIC));
    let o2 = run("pcconvert", &[], &o.stdout);
    assert!(o2.status.success(), "{}", stderr(&o2));
    assert_same_values(&c, &from_bytes(&o2.stdout));
    // The output file's extension chooses EXR.
    let dir = tempdir();
    let out = dir.path().join("m.exr");
    let o = run(
        "pcconvert",
        &["-o", out.to_str().unwrap()],
        &to_bytes(&c, LE),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read(&out)
        .unwrap()
        .starts_with(&formats::EXR_MAGIC));
}

/// A shade-point cloud as an image: same window, same points back.
#[test]
fn shade_points_write_back_as_the_same_image() {
    let mut c = Cloud::with_points(3);
    let pts = c.points_mut();
    pts.set_vec3(
        "P",
        Role::Point,
        &[[1f32, 2., 3.], [4., 5., 6.], [7., 8., 9.]],
    )
    .unwrap();
    pts.set(pcsss::Attribute::scalar(
        "pixel_x",
        Column::I32(vec![-2, 0, 5]),
    ))
    .unwrap();
    pts.set(pcsss::Attribute::scalar(
        "pixel_y",
        Column::I32(vec![3, 3, 4]),
    ))
    .unwrap();
    c.set_detail("exr_data_window", DetailValue::Str("-2 3 5 4".into()));
    c.set_detail("exr_display_window", DetailValue::Str("0 0 9 9".into()));
    let b = exr_bytes(&c, &ExrOptions::default());
    let back = read(&b).unwrap();
    assert_eq!(back.len(), 3);
    assert_eq!(
        back.points().vec3_f32("P").unwrap(),
        c.points().vec3_f32("P").unwrap()
    );
    assert_eq!(
        back.points().scalar_f64("pixel_x").unwrap(),
        [-2.0, 0.0, 5.0]
    );
    assert_eq!(
        back.points().scalar_f64("pixel_y").unwrap(),
        [3.0, 3.0, 4.0]
    );
    assert_eq!(back.detail("exr_data_window"), c.detail("exr_data_window"));
    assert_eq!(
        back.detail("exr_display_window"),
        c.detail("exr_display_window")
    );
    // A pixel outside the window is an error naming the point.
    let mut bad = c.clone();
    bad.points_mut()
        .set(pcsss::Attribute::scalar(
            "pixel_x",
            Column::I32(vec![-2, 0, 6]),
        ))
        .unwrap();
    let e = formats::write_cloud(&mut Vec::new(), &bad, EXR)
        .unwrap_err()
        .to_string();
    assert!(e.contains("point 2") && e.contains("outside"), "{e}");
}

// ---------------------------------------------------------------------
// Bad input.

fn find(b: &[u8], pat: &[u8]) -> usize {
    b.windows(pat.len())
        .position(|w| w == pat)
        .expect("pattern")
}

#[test]
fn truncated_files_are_one_line_errors() {
    let b = exr_bytes(&cloud_of(5000), &ExrOptions::default());
    for cut in [3, 4, 20, 300, b.len() / 2, b.len() - 1] {
        let e = read(&b[..cut]).unwrap_err().to_string();
        assert!(!e.contains('\n'), "{e}");
        assert!(!e.is_empty());
    }
    // Through the binary: exit 1, one line naming the file.
    let dir = tempdir();
    let f = dir.path().join("cut.exr");
    std::fs::write(&f, &b[..b.len() / 2]).unwrap();
    let o = run("pcinfo", &[f.to_str().unwrap()], b"");
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("cut.exr"), "{err}");
}

#[test]
fn a_header_count_larger_than_the_pixels_is_refused() {
    let mut b = exr_bytes(&cloud_of(10), &ExrOptions::default());
    // pcsss:points\0 int\0 <size 4> <value>
    let at = find(&b, b"pcsss:points\0int\0") + b"pcsss:points\0int\0".len() + 4;
    b[at..at + 4].copy_from_slice(&2_000_000_000i32.to_le_bytes());
    let e = read(&b).unwrap_err().to_string();
    assert!(
        e.contains("2000000000 points") && e.contains("10 pixels"),
        "{e}"
    );
}

#[test]
fn subsampled_channels_are_refused() {
    let mut b = exr_bytes(&cloud_of(10), &ExrOptions::default());
    // Channel list entry: name\0, pixel type i32, pLinear u8, 3 reserved,
    // xSampling i32, ySampling i32.
    let at = find(&b, b"ptarea\0") + b"ptarea\0".len() + 8;
    b[at..at + 4].copy_from_slice(&2i32.to_le_bytes());
    let e = read(&b).unwrap_err().to_string();
    assert!(e.contains("ptarea") && e.contains("subsampled"), "{e}");
}

#[test]
fn deep_files_are_refused_clearly() {
    let b = exr_bytes(&cloud_of(10), &ExrOptions::default());
    // The `type` attribute: "scanlineimage" -> "deepscanline" (one byte
    // shorter: the size field changes too).
    let at = find(&b, b"type\0string\0");
    let size_at = at + b"type\0string\0".len();
    let mut d = b[..size_at].to_vec();
    d.extend_from_slice(&12i32.to_le_bytes());
    d.extend_from_slice(b"deepscanline");
    d.extend_from_slice(&b[size_at + 4 + 13..]);
    let e = read(&d).unwrap_err().to_string();
    assert!(e.to_lowercase().contains("deep"), "{e}");
}

#[test]
fn an_image_without_p_is_refused_naming_p() {
    // An EXR without pcsss:points is shade points, and needs P.
    let mut c = Cloud::with_points(2);
    c.points_mut()
        .set_vec3("Cd", Role::Color, &[[1f32, 0., 0.], [0., 1., 0.]])
        .unwrap();
    c.points_mut()
        .set(pcsss::Attribute::scalar("pixel_x", Column::I32(vec![0, 1])))
        .unwrap();
    c.points_mut()
        .set(pcsss::Attribute::scalar("pixel_y", Column::I32(vec![0, 0])))
        .unwrap();
    c.set_detail("exr_data_window", DetailValue::Str("0 0 1 0".into()));
    let b = exr_bytes(&c, &ExrOptions::default());
    let e = read(&b).unwrap_err().to_string();
    assert!(e.contains("P pass"), "{e}");
}

#[test]
fn empty_and_garbage_after_the_magic() {
    let mut b = formats::EXR_MAGIC.to_vec();
    b.extend_from_slice(&[2, 0, 0, 0]);
    b.extend(std::iter::repeat_n(0xffu8, 64));
    let e = read(&b).unwrap_err().to_string();
    assert!(!e.is_empty() && !e.contains('\n'), "{e}");
}

// ---------------------------------------------------------------------
// Readers and writers nobody here wrote.

/// Python with the OpenEXR package.
fn python() -> String {
    python_with(&["OpenEXR", "numpy"])
}

/// What Debian's exrheader prints of `f`.
fn exrheader(f: &Path) -> String {
    match Command::new("exrheader").arg(f).output() {
        Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stdout).into_owned(),
        r => interop_missing(&format!(
            "exrheader failed or is missing ({r:?}); `make test` installs Debian's openexr"
        )),
    }
}

fn script() -> String {
    format!("{}/tests/py/exr_interop.py", env!("CARGO_MANIFEST_DIR"))
}

#[test]
#[ignore = "interop: needs Debian's exrheader; `make test` runs it"]
fn exrheader_lists_our_channels_and_attributes() {
    let dir = tempdir();
    let f = dir.path().join("c.exr");
    let mut c = cloud_of(1500);
    c.set_detail("origin", DetailValue::V3D([1e6, -1e6, 0.5]));
    std::fs::write(&f, exr_bytes(&c, &ExrOptions::default())).unwrap();
    let h = exrheader(&f);
    for ch in [
        "P.x", "P.y", "P.z", "N.x", "illum.R", "illum.G", "illum.B", "ptarea",
    ] {
        assert!(
            h.lines().any(|l| l.trim().starts_with(&format!("{ch},"))),
            "{ch} missing from:\n{h}"
        );
    }
    assert!(h.contains("pcsss:points (type int): 1500"), "{h}");
    assert!(
        h.contains("pcsss:detail:ssmulti_sd (type double): 0.25"),
        "{h}"
    );
    assert!(h.contains("pcsss:detail:origin (type v3d)"), "{h}");
    assert!(
        h.contains("dataWindow (type box2i): (0 0) - (1023 1)"),
        "{h}"
    );
    assert!(h.contains("compression (type compression): zip"), "{h}");
}

#[test]
#[ignore = "interop: needs Python's OpenEXR; `make test` runs it"]
fn python_openexr_reads_our_channels_bit_exact() {
    let py = python();
    let dir = tempdir();
    let f = dir.path().join("c.exr");
    let c = cloud_of(1500);
    std::fs::write(&f, exr_bytes(&c, &ExrOptions::default())).unwrap();
    let o = Command::new(&py)
        .arg(script())
        .arg("dump")
        .arg(&f)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    let p = c.points().vec3_f32("P").unwrap();
    let e = c.points().vec3_f32("illum").unwrap();
    for (name, vals) in [
        ("P.x", p.iter().map(|v| v[0]).collect::<Vec<f32>>()),
        ("P.z", p.iter().map(|v| v[2]).collect()),
        ("illum.G", e.iter().map(|v| v[1]).collect()),
        ("ptarea", c.points().scalar_f32("ptarea").unwrap()),
    ] {
        let ch = &v["channels"][name];
        assert_eq!(ch["type"], "float", "{name}");
        assert_eq!(ch["shape"], serde_json::json!([2, 1024]), "{name}");
        let bits = ch["bits"].as_array().unwrap();
        for (i, x) in vals.iter().enumerate() {
            assert_eq!(bits[i].as_u64().unwrap() as u32, x.to_bits(), "{name}[{i}]");
        }
        // Padding pixels are zero.
        assert!(bits[1500..].iter().all(|b| b.as_u64() == Some(0)));
    }
    assert!(
        v["header"]["pcsss:points"]
            .as_str()
            .unwrap()
            .contains("1500"),
        "{}",
        v["header"]
    );
}

#[test]
#[ignore = "interop: needs Python's OpenEXR; `make test` runs it"]
fn python_openexr_p_n_passes_read_as_shade_points() {
    let py = python();
    let dir = tempdir();
    for args in [
        &[][..],
        &["--spelling", "X"][..],
        &["--spelling", "R"][..],
        &["--spelling", "red", "--no-alpha"][..],
        &["--tiled"][..],
    ] {
        let f = dir.path().join("shade.exr");
        let o = Command::new(&py)
            .arg(script())
            .arg("shade")
            .arg(&f)
            .args(args)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let c = formats::read_cloud_file(&f, &Select::All).unwrap();
        // The sphere's hit pixels: centres inside the unit disk.
        let (w, h) = (64, 48);
        let mut hits = 0;
        for y in 0..h {
            for x in 0..w {
                let u = (x as f64 + 0.5) / w as f64 * 2.0 - 1.0;
                let v = (y as f64 + 0.5) / h as f64 * 2.0 - 1.0;
                hits += (u * u + v * v < 1.0) as usize;
            }
        }
        assert_eq!(c.len(), hits, "{args:?}");
        let pts = c.points();
        assert_eq!(pts.attr("P").unwrap().role(), Some(Role::Point), "{args:?}");
        assert_eq!(
            pts.attr("N").unwrap().role(),
            Some(Role::Normal),
            "{args:?}"
        );
        let p = pts.vec3_f64("P").unwrap();
        let px = pts.scalar_f64("pixel_x").unwrap();
        let py_ = pts.scalar_f64("pixel_y").unwrap();
        for i in 0..c.len() {
            // Each point's pixel gives back its P (data window at 10, 20).
            let u = (px[i] - 10.0 + 0.5) / w as f64 * 2.0 - 1.0;
            let v = (py_[i] - 20.0 + 0.5) / h as f64 * 2.0 - 1.0;
            assert!((p[i][0] - u).abs() < 1e-6 && (p[i][1] - v).abs() < 1e-6);
        }
        assert_eq!(
            c.detail("exr_data_window"),
            Some(&DetailValue::Str("10 20 73 67".into()))
        );
        assert_eq!(
            c.detail("exr_display_window"),
            Some(&DetailValue::Str("0 0 99 79".into()))
        );
        // Written back: an image of the same size and data window that
        // Python reads.
        let out = dir.path().join("back.exr");
        let mut c2 = c.clone();
        let n = c2.len();
        c2.points_mut()
            .set_vec3("ssM", Role::Color, &vec![[0.5f32, 0.25, 0.125]; n])
            .unwrap();
        std::fs::write(&out, exr_bytes(&c2, &ExrOptions::default())).unwrap();
        let o = Command::new(&py)
            .arg(script())
            .arg("dump")
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["channels"]["ssM.R"]["shape"], serde_json::json!([48, 64]));
        assert!(
            v["header"]["dataWindow"].as_str().unwrap().contains("10")
                && v["header"]["dataWindow"].as_str().unwrap().contains("73"),
            "{}",
            v["header"]["dataWindow"]
        );
        let r = v["channels"]["ssM.R"]["bits"].as_array().unwrap();
        let covered = r
            .iter()
            .filter(|b| b.as_u64() == Some(0.5f32.to_bits() as u64))
            .count();
        assert_eq!(covered, hits);
    }
}

#[test]
fn a_data_window_larger_than_the_file_is_refused_without_allocating_it() {
    // 7 x 100,000,000 pixels claimed (and a chunk count to match) in a
    // file of a few hundred bytes: an error, found before any pixel
    // buffer is made (a 2.8 GB one would be made otherwise).
    let mut b = exr_bytes(&cloud_of(7), &ExrOptions::default());
    let at = find(&b, b"dataWindow\0box2i\0") + b"dataWindow\0box2i\0".len() + 4;
    for (k, v) in [0i32, 0, 6, 99_999_999].iter().enumerate() {
        b[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
    }
    let at = find(&b, b"chunkCount\0int\0") + b"chunkCount\0int\0".len() + 4;
    b[at..at + 4].copy_from_slice(&6_250_000i32.to_le_bytes());
    let e = read(&b).unwrap_err().to_string();
    assert!(e.contains("OpenEXR") && !e.contains('\n'), "{e}");
}

#[test]
fn a_shade_cloud_claiming_a_huge_image_is_refused_before_allocating() {
    let mut c = Cloud::with_points(1);
    c.points_mut()
        .set_vec3("P", Role::Point, &[[0f32, 0., 0.]])
        .unwrap();
    c.points_mut()
        .set(pcsss::Attribute::scalar("pixel_x", Column::I32(vec![0])))
        .unwrap();
    c.points_mut()
        .set(pcsss::Attribute::scalar("pixel_y", Column::I32(vec![0])))
        .unwrap();
    for win in ["0 0 2000000000 2000000000", "-2147483648 0 2147483647 0"] {
        c.set_detail("exr_data_window", DetailValue::Str(win.into()));
        let e = formats::write_cloud(&mut Vec::new(), &c, EXR)
            .unwrap_err()
            .to_string();
        assert!(e.contains("exr_data_window") && e.contains("pixels"), "{e}");
    }
}

/// The same cloud makes the same bytes, run after run: the header's
/// attributes (the crate keeps them in a hash map, whose order changes
/// with every map) are written in order of their names, and read back
/// the same.
#[test]
fn the_same_cloud_makes_the_same_bytes() {
    let mut c = points_only();
    for k in 0..12 {
        c.set_detail(&format!("note_{k}"), DetailValue::F64(k as f64));
    }
    let opt = ExrOptions::default();
    let first = exr_bytes(&c, &opt);
    for _ in 0..8 {
        assert!(exr_bytes(&c, &opt) == first, "another header order");
    }
    let back = read(&first).unwrap();
    assert_eq!(back.detail, c.detail);
}
