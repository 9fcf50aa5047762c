//! `texture`: an image sampled at each point through the mesh's texture
//! coordinates. A linear gradient comes back exactly (bilinear filtering
//! of a linear function is exact), per-corner coordinates on a seam are
//! each face's own, 8-bit PNG is decoded from sRGB, and a texture drives
//! a per-point material.

use crate::util::*;

/// A 16-bit grey PNG of `w x h` whose column x holds `(x + 0.5) / w`.
fn gradient_png(path: &std::path::Path, w: u32, h: u32) {
    let f = std::fs::File::create(path).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(f), w, h);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Sixteen);
    let mut wr = enc.write_header().unwrap();
    let mut data = Vec::new();
    for _ in 0..h {
        for x in 0..w {
            let v = (((x as f64 + 0.5) / w as f64) * 65535.0).round() as u16;
            data.extend(v.to_be_bytes());
        }
    }
    wr.write_image_data(&data).unwrap();
}

/// Two unit quads side by side, [0, 1] and [1, 2] in x: the left's u is
/// x / 2, the right's (x - 1) / 2, so the shared edge is a seam (u 0.5 on
/// the left, 0 on the right); v is y.
const SEAM_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nv 1 1 0\nv 2 1 0\n\
vt 0 0\nvt 0.5 0\nvt 0 1\nvt 0.5 1\nvt 0 0\nvt 0.5 0\nvt 0 1\nvt 0.5 1\n\
f 1/1 2/2 5/4 4/3\nf 2/5 3/6 6/8 5/7\n";

#[test]
fn a_gradient_comes_back_and_each_face_keeps_its_coordinates() {
    let d = tempdir();
    std::fs::write(d.path().join("seam.obj"), SEAM_OBJ).unwrap();
    gradient_png(&d.path().join("grad.png"), 256, 4);
    let b = |n: &str| bin(n).display().to_string();
    shell(
        d.path(),
        &format!(
            "{s} seam.obj -n 4000 --seed 2 | {t} --mesh seam.obj --image grad.png --as Cd --wrap clamp -o tex.ply",
            s = b("scatter"),
            t = b("texture"),
        ),
    );
    let c = from_bytes(&std::fs::read(d.path().join("tex.ply")).unwrap());
    let p = c.points().vec3_f64("P").unwrap();
    let cd = c.points().vec3_f64("Cd").unwrap();
    let mut worst = 0.0f64;
    for (q, v) in p.iter().zip(&cd) {
        let u = if q[0] < 1.0 {
            q[0] / 2.0
        } else {
            (q[0] - 1.0) / 2.0
        };
        // Within half a texel of the image's edge the edge texel extends.
        let want = u.clamp(0.5 / 256.0, 1.0 - 0.5 / 256.0);
        worst = worst.max((v[0] - want).abs());
        assert_eq!(v[0], v[1]);
    }
    assert!(worst < 1e-4, "{worst}");
    assert!(c.detail("texture_Cd_size").is_some());
}

#[test]
fn eight_bit_png_is_decoded_from_srgb_unless_told_linear() {
    let d = tempdir();
    std::fs::write(d.path().join("seam.obj"), SEAM_OBJ).unwrap();
    let f = std::fs::File::create(d.path().join("one.png")).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(f), 1, 1);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header()
        .unwrap()
        .write_image_data(&[128, 64, 255])
        .unwrap();
    let b = |n: &str| bin(n).display().to_string();
    shell(
        d.path(),
        &format!(
            "{s} seam.obj -n 300 --seed 1 | {t} --mesh seam.obj --image one.png --as colour -o tex.ply && \
             {t} tex.ply --mesh seam.obj --image one.png --as raw --decode linear -o both.ply",
            s = b("scatter"),
            t = b("texture"),
        ),
    );
    let c = from_bytes(&std::fs::read(d.path().join("both.ply")).unwrap());
    let srgb = |c: f64| ((c / 255.0 + 0.055) / 1.055).powf(2.4);
    for v in c.points().vec3_f64("colour").unwrap() {
        for (k, byte) in [128.0, 64.0, 255.0].iter().enumerate() {
            assert!((v[k] - srgb(*byte)).abs() < 1e-6, "{v:?}");
        }
    }
    for v in c.points().vec3_f64("raw").unwrap() {
        assert!((v[0] - 128.0 / 255.0).abs() < 1e-6, "{v:?}");
    }
    // Both textures' records are kept.
    assert!(c.detail("texture_colour_wrap").is_some() && c.detail("texture_raw_wrap").is_some());
}

#[test]
fn a_texture_drives_a_per_point_material_through_the_binaries() {
    let d = tempdir();
    std::fs::write(d.path().join("seam.obj"), SEAM_OBJ).unwrap();
    gradient_png(&d.path().join("grad.png"), 64, 4);
    std::fs::write(
        d.path().join("sun.json"),
        r#"{"lights": [{"name": "sun", "type": "distant", "direction": [0, 0, -1]}]}"#,
    )
    .unwrap();
    std::fs::write(
        d.path().join("mat.json"),
        r#"{"color": 0.5, "dmfp": 0.05, "per_point": {"color": "Cd"}, "levels": 4}"#,
    )
    .unwrap();
    let b = |n: &str| bin(n).display().to_string();
    shell(
        d.path(),
        &format!(
            "{s} seam.obj -n 3000 --seed 2 | {f} --mesh seam.obj | {t} --mesh seam.obj --image grad.png --as Cd \
             | {i} --lights sun.json --no-shadows | {m} --material mat.json -o sss.ply",
            s = b("scatter"),
            f = b("facet"),
            t = b("texture"),
            i = b("illum"),
            m = b("ssmulti"),
        ),
    );
    let c = from_bytes(&std::fs::read(d.path().join("sss.ply")).unwrap());
    assert!(matches!(
        c.detail("ssmulti_per_point"),
        Some(pcsss::cloud::DetailValue::Str(s)) if s == "color from Cd; 4 levels"
    ));
    // Brighter where the texture is: the rightmost of each half against
    // the leftmost (away from the seam and the ends).
    let p = c.points().vec3_f64("P").unwrap();
    let ssm = c.points().vec3_f64("ssM").unwrap();
    let mean = |lo: f64, hi: f64| {
        let v: Vec<f64> = p
            .iter()
            .zip(&ssm)
            .filter(|(q, _)| q[0] > lo && q[0] < hi && q[1] > 0.2 && q[1] < 0.8)
            .map(|(_, s)| s[0])
            .collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    assert!(
        mean(0.7, 0.9) > 1.5 * mean(0.1, 0.3),
        "{} {}",
        mean(0.7, 0.9),
        mean(0.1, 0.3)
    );
}

#[test]
fn a_texture_over_another_stage_s_attribute_or_at_no_coordinate_is_refused() {
    let d = tempdir();
    std::fs::write(d.path().join("seam.obj"), SEAM_OBJ).unwrap();
    // The same quads with one texture coordinate that is not a number.
    std::fs::write(
        d.path().join("nan.obj"),
        SEAM_OBJ.replacen("vt 0.5 0\n", "vt nan 0\n", 1),
    )
    .unwrap();
    gradient_png(&d.path().join("grad.png"), 8, 4);
    let b = |n: &str| bin(n).display().to_string();
    shell(
        d.path(),
        &format!("{s} seam.obj -n 200 --seed 3 -o pts.ply", s = b("scatter")),
    );
    // texture on `input` through `mesh`, written as attribute `name`.
    let tex = |input: &str, mesh: &str, name: &str| {
        std::process::Command::new(bin("texture"))
            .current_dir(d.path())
            .args([
                input, "--mesh", mesh, "--image", "grad.png", "--as", name, "-o", "x.ply",
            ])
            .output()
            .unwrap()
    };
    // Refused with exit status `code`: its message.
    let refused = |o: &std::process::Output, code: i32| {
        let e = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(code), "{e}");
        e
    };
    // Positions written as a colour would pass on as positions.
    let o = tex("pts.ply", "seam.obj", "P");
    let e = refused(&o, 2);
    assert!(e.contains("'P'") && e.contains("scatter"), "{e}");
    assert!(!d.path().join("x.ply").exists());
    // A coordinate that is not a number has no colour: not black, refused.
    let o = tex("pts.ply", "nan.obj", "Cd");
    let e = refused(&o, 1);
    assert!(e.contains("not finite") && e.contains("vertex"), "{e}");
    // A point whose sourceuv is not a number, the same.
    let mut c = from_bytes(&std::fs::read(d.path().join("pts.ply")).unwrap());
    let mut uv = c.points().vec3_f64("sourceuv").unwrap();
    uv[7][0] = f64::NAN;
    c.points_mut()
        .set_vec3("sourceuv", pcsss::Role::Vector, &uv)
        .unwrap();
    std::fs::write(
        d.path().join("nanuv.ply"),
        to_bytes(&c, pcsss::formats::Format::DEFAULT),
    )
    .unwrap();
    let o = tex("nanuv.ply", "seam.obj", "Cd");
    let e = refused(&o, 1);
    assert!(e.contains("point 7") && e.contains("sourceuv"), "{e}");
    // The same quads moved: as many faces, but the points lie off them.
    std::fs::write(
        d.path().join("moved.obj"),
        SEAM_OBJ
            .replace("v 0 ", "v 7 ")
            .replace("v 1 ", "v 8 ")
            .replace("v 2 ", "v 9 "),
    )
    .unwrap();
    let o = tex("pts.ply", "moved.obj", "Cd");
    let e = refused(&o, 1);
    assert!(
        e.contains("is the mesh the one it was scattered on?"),
        "{e}"
    );
    // The valid run beside them still works.
    let o = tex("pts.ply", "seam.obj", "Cd");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}
