//! A bad-input table for every binary: each row a bad file or parameter,
//! run under a 2 GiB address-space limit in a directory of its own
//! inputs. Each must exit 2 (usage, parameter) or 1 (input), print one
//! line on standard error that names the file or parameter at fault, not
//! panic, and leave no output or temp file behind.

use std::path::Path;
use std::process::{Command, Output, Stdio};

use crate::util::*;
use pcsss::formats::{self, Format};
use pcsss::stages::facet;
use pcsss::{Cloud, Role};

/// A lit cloud of 200 points on the cube with every attribute a stage
/// reads (P, N, ptarea, sourceprim, sourceuv, illum, ssM, ssS).
pub(crate) fn lit_cloud() -> Cloud {
    let mesh = cube();
    let mut c = scatter_n(&mesh, 200, 1, pcsss::stages::scatter::PtareaMode::Prim);
    let m = pcsss::geom::mesh::TriMesh::from_cloud(&mesh).unwrap();
    let p = facet::Params {
        mode: facet::Mode::Flat,
        weight: facet::Weight::Angle,
        cusp: 60.0,
        weld: true,
    };
    facet::facet_points(&mut c, &m, &p).unwrap();
    let n = c.len();
    let pts = c.points_mut();
    for name in ["illum", "ssM", "ssS"] {
        pts.set_vec3(name, Role::Color, &vec![[0.5f32, 0.25, 0.125]; n])
            .unwrap();
    }
    c.set_detail("ssmulti_sd", pcsss::DetailValue::F64(0.5));
    c
}

fn bytes(c: &Cloud, f: Format) -> Vec<u8> {
    let mut v = Vec::new();
    formats::write_cloud(&mut v, c, f).unwrap();
    v
}

/// The inputs, good and bad, each named for what is wrong with it.
fn inputs(dir: &Path) {
    let w = |name: &str, data: &[u8]| std::fs::write(dir.join(name), data).unwrap();
    let good = lit_cloud();
    let ply = bytes(&good, LE);
    w("cloud.ply", &ply);
    w("trunc.ply", &ply[..ply.len() - 7]);
    let head_end = ply.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let text = String::from_utf8_lossy(&ply[..head_end]).into_owned();
    let lying = [
        String::from_utf8(ply[..head_end].to_vec())
            .unwrap()
            .replace("element vertex 200", "element vertex 1000000000")
            .into_bytes(),
        ply[head_end..].to_vec(),
    ]
    .concat();
    assert!(text.contains("element vertex 200"));
    w("lying.ply", &lying);
    w(
        "huge.ply",
        b"ply\nformat binary_little_endian 1.0\nelement e 18446744073709551615\nend_header\n",
    );
    let mut nan = good.clone();
    let mut p = nan.points().vec3_f64("P").unwrap();
    p[3][1] = f64::NAN;
    nan.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    w("nan.ply", &bytes(&nan, LE));
    // Without sourceprim, facet finds each point's face by its position.
    nan.points_mut().remove("sourceprim");
    nan.points_mut().remove("sourceuv");
    w("nan_bare.ply", &bytes(&nan, LE));
    // The physical model's ssM, one of it NaN (illum --indirect).
    let mut phys = good.clone();
    phys.set_detail(
        "ssmulti_radiance",
        pcsss::DetailValue::Str(pcsss::stages::ssmulti::RADIANCE.into()),
    );
    let mut m = phys.points().vec3_f64("ssM").unwrap();
    m[7][2] = f64::NAN;
    phys.points_mut().set_vec3("ssM", Role::Color, &m).unwrap();
    w("nanssm.ply", &bytes(&phys, LE));
    let mut zero_n = good.clone();
    let mut n = zero_n.points().vec3_f32("N").unwrap();
    n[5] = [0.0; 3];
    zero_n.points_mut().set_vec3("N", Role::Normal, &n).unwrap();
    w("zeroN.ply", &bytes(&zero_n, LE));
    let mut partial = good.clone();
    let n = partial.points_mut().remove("N").unwrap();
    let pcsss::AttrData::Vec3(_, cols) = n.data else {
        unreachable!()
    };
    for (name, col) in ["nx", "ny"].iter().zip(cols.iter()) {
        partial
            .points_mut()
            .set(pcsss::Attribute {
                name: name.to_string(),
                data: pcsss::AttrData::Scalar(col.clone()),
            })
            .unwrap();
    }
    w("partialN.ply", &bytes(&partial, ASCII));
    w("text.ply", b"hello world\n");
    w("zero.ply", b"");
    let exr = bytes(&good, Format::Exr);
    w("trunc.exr", &exr[..exr.len() / 2]);
    w(
        "cube.obj",
        &std::fs::read(fixtures().join("mesh/cube.obj")).unwrap(),
    );
    w(
        "degenerate.obj",
        b"v 0 0 0\nv 1 1 1\nv 2 2 2\nv 3 3 3\nf 1 2 3\nf 2 3 4\nf 1 1 1\n",
    );
    w("badindex.obj", b"v 0 0 0\nv 1 0 0\nf 1 2 3\n");
    w(
        "lights.json",
        &std::fs::read(fixtures().join("lights/three.json")).unwrap(),
    );
    w("notjson.json", b"{ \"lights\": [");
    w(
        "badlight.json",
        br#"{ "lights": [ { "name": "p", "type": "point", "intensity": 1 } ] }"#,
    );
    w(
        "camera.json",
        br#"{ "position": [3, 2, 4], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 40, "width": 16, "height": 12 }"#,
    );
    w(
        "flatcam.json",
        br#"{ "position": [3, 2, 4], "look_at": [3, 2, 4], "up": [0, 1, 0], "fov": 40, "width": 16, "height": 12 }"#,
    );
    w(
        "hugecam.json",
        br#"{ "position": [3, 2, 4], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 40, "width": 100000, "height": 100000 }"#,
    );
}

/// One row: a binary, its arguments (`@OUT` is the output file, checked
/// absent afterwards), a file for standard input, the exit status and
/// what the one line on standard error must contain.
struct Row {
    bin: &'static str,
    args: &'static [&'static str],
    stdin: Option<&'static str>,
    code: i32,
    names: &'static str,
}

const fn row(
    bin: &'static str,
    args: &'static [&'static str],
    code: i32,
    names: &'static str,
) -> Row {
    Row {
        bin,
        args,
        stdin: None,
        code,
        names,
    }
}

const fn piped(
    bin: &'static str,
    args: &'static [&'static str],
    stdin: &'static str,
    code: i32,
    names: &'static str,
) -> Row {
    Row {
        bin,
        args,
        stdin: Some(stdin),
        code,
        names,
    }
}

#[rustfmt::skip]
const TABLE: &[Row] = &[
    // scatter
    row("scatter", &["text.ply", "-n", "10", "-o", "@OUT"], 1, "text.ply"),
    row("scatter", &["zero.ply", "-n", "10", "-o", "@OUT"], 1, "zero.ply"),
    piped("scatter", &["-n", "10", "-o", "@OUT"], "text.ply", 1, "<stdin>"),
    row("scatter", &["cube.obj", "-n", "-5", "-o", "@OUT"], 2, "--count"),
    row("scatter", &["cube.obj", "--density", "nan", "-o", "@OUT"], 2, "--density"),
    row("scatter", &["cube.obj", "-n", "4294967296", "-o", "@OUT"], 2, "--count"),
    row("scatter", &["cube.obj", "-n", "10", "--ptarea", "bogus", "-o", "@OUT"], 2, "--ptarea"),
    row("scatter", &["degenerate.obj", "-n", "10", "-o", "@OUT"], 1, "degenerate.obj"),
    row("scatter", &["badindex.obj", "-n", "10", "-o", "@OUT"], 1, "badindex.obj"),
    row("scatter", &["huge.ply", "-n", "10", "-o", "@OUT"], 1, "huge.ply"),
    row("scatter", &["cloud.ply", "-n", "10", "-o", "@OUT"], 1, "cloud.ply"),
    // follow
    row("follow", &["cloud.ply", "--rest", "cube.obj", "--mesh", "text.ply", "-o", "@OUT"], 1, "text.ply"),
    row("follow", &["cloud.ply", "--rest", "cube.obj", "--mesh", "degenerate.obj", "-o", "@OUT"], 1, "degenerate.obj"),
    row("follow", &["cloud.ply", "--rest", "badindex.obj", "--mesh", "cube.obj", "-o", "@OUT"], 1, "badindex.obj"),
    row("follow", &["trunc.ply", "--rest", "cube.obj", "--mesh", "cube.obj", "-o", "@OUT"], 1, "trunc.ply"),
    row("follow", &["nan_bare.ply", "--rest", "cube.obj", "--mesh", "cube.obj", "-o", "@OUT"], 1, "nan_bare.ply"),
    // texture
    row("texture", &["cloud.ply", "--mesh", "cube.obj", "--image", "text.ply", "--as", "Cd", "-o", "@OUT"], 1, "text.ply"),
    row("texture", &["cloud.ply", "--mesh", "cube.obj", "--image", "missing.png", "--as", "Cd", "-o", "@OUT"], 1, "missing.png"),
    row("texture", &["cloud.ply", "--mesh", "cube.obj", "--image", "trunc.ply", "--as", "Cd", "-o", "@OUT"], 1, "trunc.ply"),
    row("texture", &["cloud.ply", "--mesh", "cube.obj", "--image", "text.ply", "--as", "Cd", "--wrap", "mirror", "-o", "@OUT"], 2, "--wrap"),
    // facet
    row("facet", &["nan_bare.ply", "--mesh", "cube.obj", "-o", "@OUT"], 1, "nan_bare.ply"),
    row("facet", &["cloud.ply", "--mesh", "text.ply", "-o", "@OUT"], 1, "text.ply"),
    row("facet", &["cloud.ply", "--mesh", "badindex.obj", "-o", "@OUT"], 1, "badindex.obj"),
    row("facet", &["cloud.ply", "--mesh", "cube.obj", "--cusp", "-1", "-o", "@OUT"], 2, "--cusp"),
    row("facet", &["trunc.ply", "--mesh", "cube.obj", "-o", "@OUT"], 1, "trunc.ply"),
    row("facet", &["cloud.ply", "-o", "@OUT"], 1, "cloud.ply"),
    // measure
    row("measure", &["text.ply", "-o", "@OUT"], 1, "text.ply"),
    row("measure", &["lying.ply", "-o", "@OUT"], 1, "lying.ply"),
    row("measure", &["huge.ply", "-o", "@OUT"], 1, "huge.ply"),
    row("measure", &["cloud.ply", "-o", "@OUT"], 1, "cloud.ply"),
    row("measure", &["badindex.obj", "-o", "@OUT"], 1, "badindex.obj"),
    piped("measure", &["-o", "@OUT"], "trunc.ply", 1, "<stdin>"),
    // promote
    row("promote", &["cloud.ply", "--class", "point", "--attr", "nosuch", "-o", "@OUT"], 1, "nosuch"),
    row("promote", &["cloud.ply", "--class", "face", "--attr", "area", "-o", "@OUT"], 1, "cloud.ply"),
    row("promote", &["cloud.ply", "--attr", "ptarea", "--method", "bogus", "-o", "@OUT"], 2, "--method"),
    row("promote", &["partialN.ply", "--class", "point", "--attr", "N", "-o", "@OUT"], 1, "nx"),
    // illum
    row("illum", &["cloud.ply", "--lights", "notjson.json", "--no-shadows", "-o", "@OUT"], 1, "notjson.json"),
    row("illum", &["cloud.ply", "--lights", "/dev/zero", "--no-shadows", "-o", "@OUT"], 1, "/dev/zero"),
    row("illum", &["cloud.ply", "--lights", "badlight.json", "--no-shadows", "-o", "@OUT"], 1, "badlight.json"),
    row("illum", &["zeroN.ply", "--lights", "lights.json", "--no-shadows", "-o", "@OUT"], 1, "zeroN.ply"),
    row("illum", &["partialN.ply", "--lights", "lights.json", "--no-shadows", "-o", "@OUT"], 1, "nx"),
    row("illum", &["nan.ply", "--lights", "lights.json", "--mesh", "cube.obj", "-o", "@OUT"], 1, "nan.ply"),
    row("illum", &["cloud.ply", "--lights", "lights.json", "--mesh", "badindex.obj", "-o", "@OUT"], 1, "badindex.obj"),
    row("illum", &["cloud.ply", "--lights", "lights.json", "--mesh", "degenerate.obj", "-o", "@OUT"], 1, "degenerate.obj"),
    row("illum", &["cloud.ply", "--lights", "lights.json", "--no-shadows", "--lmask", "nosuch", "-o", "@OUT"], 2, "--lmask"),
    row("illum", &["cloud.ply", "--lights", "lights.json", "--mesh", "cube.obj", "--model", "physical", "--mfp", "0.1", "--indirect", "8", "-o", "@OUT"], 2, "--indirect"),
    row("illum", &["nanssm.ply", "--lights", "lights.json", "--mesh", "cube.obj", "--model", "physical", "--mfp", "0.1", "--indirect", "8", "-o", "@OUT"], 1, "nanssm.ply"),
    row("illum", &["nanssm.ply", "--lights", "lights.json", "--mesh", "cube.obj", "--indirect", "8", "-o", "@OUT"], 2, "--indirect"),
    row("illum", &["cloud.ply", "--lights", "lights.json", "--mesh", "cube.obj", "--model", "physical", "--mfp", "-1", "-o", "@OUT"], 2, "--mfp"),
    row("illum", &["cloud.ply", "--lights", "lights.json", "--mesh", "cube.obj", "--exitance", "nanssm.ply", "-o", "@OUT"], 2, "--indirect"),
    row("illum", &["cloud.ply", "--lights", "lights.json", "--mesh", "cube.obj", "--model", "physical", "--mfp", "0.1", "--indirect", "8", "--exitance", "nosuch.ply", "-o", "@OUT"], 1, "nosuch.ply"),
    row("illum", &["cloud.ply", "--lights", "lights.json", "--mesh", "cube.obj", "--model", "physical", "--mfp", "0.1", "--indirect", "8", "--exitance", "cloud.ply", "-o", "@OUT"], 1, "cloud.ply"),
    // ssmulti
    row("ssmulti", &["cloud.ply", "--sd", "0", "-o", "@OUT"], 2, "--sd"),
    row("ssmulti", &["cloud.ply", "--sd", "1", "--per-point", "gloss=Cd", "-o", "@OUT"], 2, "--per-point"),
    row("ssmulti", &["cloud.ply", "--sd", "1", "--per-point", "rd=Cd", "--levels", "1", "-o", "@OUT"], 2, "--levels"),
    row("ssmulti", &["cloud.ply", "--sd", "nan", "-o", "@OUT"], 2, "--sd"),
    row("ssmulti", &["cloud.ply", "--sd", "1e-300", "-o", "@OUT"], 2, "--sd"),
    row("ssmulti", &["cloud.ply", "--sd", "1", "--tolerance", "2", "-o", "@OUT"], 2, "--tolerance"),
    row("ssmulti", &["cloud.ply", "--sd", "1", "--rd", "1,2", "-o", "@OUT"], 2, "--rd"),
    row("ssmulti", &["cloud.ply", "--sd", "1", "--bounce", "-1", "-o", "@OUT"], 2, "--bounce"),
    row("ssmulti", &["nan.ply", "--sd", "1", "-o", "@OUT"], 1, "nan.ply"),
    row("ssmulti", &["partialN.ply", "--sd", "1", "-o", "@OUT"], 1, "nx"),
    piped("ssmulti", &["--sd", "1", "-o", "@OUT"], "lying.ply", 1, "<stdin>"),
    row("ssmulti", &["cloud.ply", "--model", "physical", "-o", "@OUT"], 2, "--mfp"),
    row("ssmulti", &["cloud.ply", "--model", "physical", "--mfp", "0.1", "--albedo", "1", "-o", "@OUT"], 2, "--albedo"),
    row("ssmulti", &["cloud.ply", "--model", "physical", "--dmfp", "0.1", "--color", "0.99", "-o", "@OUT"], 2, "--color"),
    row("ssmulti", &["cloud.ply", "--model", "physical", "--mfp", "nan", "-o", "@OUT"], 2, "--mfp"),
    row("ssmulti", &["cloud.ply", "--model", "physical", "--dmfp", "0.1", "--albedo", "1", "-o", "@OUT"], 2, "--albedo"),
    row("ssmulti", &["cloud.ply", "--model", "physical", "--mfp", "0.1", "--eta", "0", "-o", "@OUT"], 2, "--eta"),
    row("ssmulti", &["cloud.ply", "--model", "physical", "--mfp", "0.1", "--g", "2", "-o", "@OUT"], 2, "--g"),
    // filter
    row("filter", &["cloud.ply", "--cloud", "nan.ply", "-o", "@OUT"], 1, "nan.ply"),
    row("filter", &["cloud.ply", "--cloud", "text.ply", "-o", "@OUT"], 1, "text.ply"),
    row("filter", &["nan.ply", "--cloud", "cloud.ply", "-o", "@OUT"], 1, "nan.ply"),
    row("filter", &["cloud.ply", "--cloud", "cloud.ply", "--nfp", "0", "-o", "@OUT"], 2, "--nfp"),
    row("filter", &["cloud.ply", "--cloud", "cloud.ply", "--radius", "-1", "-o", "@OUT"], 2, "--radius"),
    row("filter", &["cloud.ply", "--cloud", "cloud.ply", "--single-mesh", "cube.obj", "-o", "@OUT"], 2, "--single-lights"),
    row("filter", &["cloud.ply", "--cloud", "cloud.ply", "--eye", "0,0,5", "-o", "@OUT"], 2, "--single-lights"),
    row("filter", &["cloud.ply", "--cloud", "cloud.ply", "--attr", "nosuch", "-o", "@OUT"], 1, "nosuch"),
    row("filter", &["zeroN.ply", "--cloud", "cloud.ply", "--facing", "-o", "@OUT"], 1, "zeroN.ply"),
    // sssingle
    row("sssingle", &["cloud.ply", "--mesh", "cube.obj", "--lights", "lights.json", "--sd", "0.5", "--eye", "1,2", "-o", "@OUT"], 2, "--eye"),
    row("sssingle", &["cloud.ply", "--mesh", "cube.obj", "--lights", "lights.json", "--sd", "0.5", "--camera", "flatcam.json", "-o", "@OUT"], 1, "flatcam.json"),
    row("sssingle", &["cloud.ply", "--mesh", "cube.obj", "--lights", "lights.json", "--sd", "0.5", "--camera", "notjson.json", "-o", "@OUT"], 1, "notjson.json"),
    row("sssingle", &["cloud.ply", "--mesh", "degenerate.obj", "--lights", "lights.json", "--sd", "0.5", "--eye", "3,2,4", "-o", "@OUT"], 1, "degenerate.obj"),
    row("sssingle", &["cloud.ply", "--mesh", "cube.obj", "--lights", "lights.json", "--sd", "0.5", "--eye", "3,2,4", "--samples", "0", "-o", "@OUT"], 2, "--samples"),
    row("sssingle", &["cloud.ply", "--mesh", "cube.obj", "--lights", "lights.json", "--sd", "0.5", "--eye", "3,2,4", "--eta", "0", "-o", "@OUT"], 2, "--eta"),
    row("sssingle", &["cloud.ply", "--mesh", "cube.obj", "--lights", "lights.json", "--sd", "0.5", "--eye", "3,2,4", "--model", "physical", "--mfp", "-1,1,1", "-o", "@OUT"], 2, "--mfp"),
    row("sssingle", &["zeroN.ply", "--mesh", "cube.obj", "--lights", "lights.json", "--sd", "0.5", "--eye", "3,2,4", "-o", "@OUT"], 1, "zeroN.ply"),
    // render
    row("render", &["--mesh", "cube.obj", "--camera", "hugecam.json", "--cloud", "cloud.ply", "-o", "@OUT.exr"], 1, "hugecam.json"),
    row("render", &["--mesh", "cube.obj", "--camera", "camera.json", "--cloud", "cloud.ply", "-o", "@OUT.ply"], 2, "--output"),
    row("render", &["--mesh", "cube.obj", "--camera", "camera.json", "--cloud", "cloud.ply", "--width", "0", "-o", "@OUT.exr"], 2, "--width"),
    row("render", &["--mesh", "cube.obj", "--camera", "camera.json", "--cloud", "cloud.ply", "--height", "-3", "-o", "@OUT.exr"], 2, "--height"),
    row("render", &["--mesh", "cube.obj", "--camera", "camera.json", "--cloud", "cloud.ply", "-o", "@OUT.exr", "--png", "@OUT.exr"], 2, "--png"),
    row("render", &["--mesh", "cube.obj", "--camera", "camera.json", "--cloud", "cloud.ply", "-o", "@OUT.exr", "--direct", "lights.json", "--kd", "3e38"], 1, "beyond the range"),
    row("render", &["--mesh", "cube.obj", "--camera", "camera.json", "--cloud", "cloud.ply", "-o", "@OUT.exr", "--png", "nodir/r.png"], 1, "nodir"),
    row("render", &["--mesh", "cube.obj", "--camera", "/dev/zero", "--cloud", "cloud.ply", "-o", "@OUT.exr"], 1, "/dev/zero"),
    row("render", &["--mesh", "cube.obj", "--camera", "flatcam.json", "--cloud", "cloud.ply", "-o", "@OUT.exr"], 1, "flatcam.json"),
    row("render", &["--mesh", "cube.obj", "--camera", "camera.json", "--cloud", "trunc.exr", "-o", "@OUT.exr"], 1, "trunc.exr"),
    row("render", &["--mesh", "degenerate.obj", "--camera", "camera.json", "--cloud", "cloud.ply", "-o", "@OUT.exr"], 1, "degenerate.obj"),
    row("filter", &["cloud.ply", "--cloud", "cloud.ply", "--attr", "ssS,ssX", "-o", "@OUT"], 1, "ssX"),
    // pcconvert
    row("pcconvert", &["trunc.exr", "-o", "@OUT"], 1, "trunc.exr"),
    row("pcconvert", &["cloud.ply", "--format", "bogus", "-o", "@OUT"], 2, "--format"),
    row("pcconvert", &["cloud.ply", "--half", "nosuch", "-o", "@OUT.exr"], 2, "--half"),
    row("pcconvert", &["lying.ply", "-o", "@OUT"], 1, "lying.ply"),
    row("pcconvert", &["cloud.ply", "--compression", "bogus", "-o", "@OUT.exr"], 2, "--compression"),
    piped("pcconvert", &["-o", "@OUT"], "zero.ply", 1, "<stdin>"),
    // pctile (@OUT: split's directory, merge's file)
    row("pctile", &["split", "trunc.ply", "--tiles", "2", "--halo", "0.1", "-o", "@OUT"], 1, "trunc.ply"),
    row("pctile", &["split", "lying.ply", "--tiles", "2", "--halo", "0.1", "-o", "@OUT"], 1, "lying.ply"),
    row("pctile", &["split", "nan.ply", "--tiles", "2", "--halo", "0.1", "-o", "@OUT"], 1, "nan.ply"),
    row("pctile", &["split", "text.ply", "--tiles", "2", "--halo", "0.1", "-o", "@OUT"], 1, "text.ply"),
    row("pctile", &["split", "cube.obj", "--tiles", "2", "--halo", "0.1", "-o", "@OUT"], 1, "cube.obj"),
    row("pctile", &["split", "cloud.ply", "--tiles", "0", "--halo", "0.1", "-o", "@OUT"], 2, "--tiles"),
    row("pctile", &["split", "cloud.ply", "--tiles", "2", "--halo", "-1", "-o", "@OUT"], 2, "--halo"),
    row("pctile", &["split", "cloud.ply", "--tile-memory", "1K", "--halo", "0.1", "-o", "@OUT"], 2, "--tile-memory"),
    row("pctile", &["split", "cloud.ply", "--tiles", "2", "--for", "ssmulti", "--stage-args", "--sd nope", "-o", "@OUT"], 2, "--stage-args"),
    row("pctile", &["split", "cloud.ply", "--tiles", "2", "--for", "ssmulti", "--stage-args", "--sd 0.5", "--halo", "0.1", "-o", "@OUT"], 2, "--halo"),
    row("pctile", &["split", "cloud.ply", "--tiles", "2", "--halo", "-1e-300", "-o", "@OUT"], 2, "--halo: -1e-300"),
    row("pctile", &["split", "cloud.ply", "--tile-memory", "32M", "--halo", "1000", "-o", "@OUT"], 2, "--tile-memory"),
    row("pctile", &["split", "cloud.ply", "--tiles", "2", "--for", "sssingle", "--stage-args", "--bogus 3", "-o", "@OUT"], 2, "sssingle: unexpected argument"),
    row("pctile", &["split", "cloud.ply", "--tiles", "2", "--for", "illum", "--stage-args", "--seed x", "-o", "@OUT"], 2, "illum: invalid value"),
    row("pctile", &["split", "cloud.ply", "--tiles", "2", "--for", "ssmulti", "--stage-args", "--sd 1e308 --rd 1e10", "-o", "@OUT"], 2, "--stage-args: ssmulti's reach"),
    // A stage's parameter is named as its option within --stage-args.
    row("pctile", &["split", "cloud.ply", "--tiles", "2", "--for", "filter", "--stage-args", "--sd 0.5 --radius -1", "-o", "@OUT"], 2, "--stage-args --radius"),
    row("pctile", &["split", "cloud.ply", "--tiles", "2", "--for", "filter", "--stage-args", "--nfp 8", "-o", "@OUT"], 2, "--stage-args --nfp"),
    row("pctile", &["split", "cloud.ply", "--tiles", "2", "--for", "ssmulti", "--stage-args", "--sd 0.5 --tolerance 3", "-o", "@OUT"], 2, "ssmulti: parameter --tolerance"),
    row("pctile", &["split", "cloud.ply", "--tiles", "2", "--for", "nosuch", "-o", "@OUT"], 2, "--for"),
    piped("pctile", &["split", "--tiles", "2", "--halo", "0.1", "-o", "@OUT"], "zero.ply", 1, "<stdin>"),
    row("pctile", &["merge", "nosuch", "-o", "@OUT"], 1, "nosuch/manifest.json"),
    // pcdiff
    row("pcdiff", &["cloud.ply", "cloud.ply", "--only", "nosuch"], 2, "nosuch"),
    row("pcdiff", &["cloud.ply", "cloud.ply", "--tol", "nosuch=1"], 2, "nosuch"),
    // (pcdiff's 1 means "they differ", as diff's: trouble is 2.)
    row("pcdiff", &["cloud.ply", "text.ply"], 2, "text.ply"),
    row("pcdiff", &["trunc.ply", "cloud.ply"], 2, "trunc.ply"),
    // pcinfo
    row("pcinfo", &["huge.ply"], 1, "huge.ply"),
    row("pcinfo", &["text.ply"], 1, "text.ply"),
    row("pcinfo", &["trunc.exr"], 1, "trunc.exr"),
    piped("pcinfo", &[], "zero.ply", 1, "<stdin>"),
];

/// Runs a row under `ulimit -v` (2 GiB) and a generous `timeout` (a hang
/// guard, not a speed check), in `dir`.
fn run_row(dir: &Path, r: &Row) -> Output {
    let args: Vec<String> = r
        .args
        .iter()
        .map(|a| format!("'{}'", a.replace("@OUT", "out")))
        .collect();
    let stdin = r
        .stdin
        .map_or(String::from("< /dev/null"), |f| format!("< '{f}'"));
    Command::new("bash")
        .args([
            "-c",
            &format!(
                "ulimit -v 2097152; exec timeout 120 {} {} {stdin}",
                bin(r.bin).display(),
                args.join(" ")
            ),
        ])
        .current_dir(dir)
        .stdin(Stdio::null())
        .output()
        .unwrap()
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn every_binary_refuses_bad_input_with_one_line_and_leaves_nothing() {
    let dir = tempdir();
    inputs(dir.path());
    let before = listing(dir.path());
    let mut failures = Vec::new();
    let mut per_bin = std::collections::BTreeMap::new();
    for r in TABLE {
        *per_bin.entry(r.bin).or_insert(0) += 1;
        let o = run_row(dir.path(), r);
        let err = stderr(&o);
        let what = format!("{} {}", r.bin, r.args.join(" "));
        let mut wrong = Vec::new();
        if o.status.code() != Some(r.code) {
            wrong.push(format!("exit {:?}, not {}", o.status.code(), r.code));
        }
        if err.lines().count() != 1 {
            wrong.push(format!("{} lines on stderr", err.lines().count()));
        }
        if err.contains("panicked") || err.contains("memory allocation") {
            wrong.push("panic or abort".into());
        }
        if !err.contains(r.names) {
            wrong.push(format!("does not name '{}'", r.names));
        }
        if !o.stdout.is_empty() && r.args.contains(&"-o") {
            wrong.push("wrote to standard output".into());
        }
        let after = listing(dir.path());
        if after != before {
            wrong.push(format!(
                "left {:?}",
                after
                    .iter()
                    .filter(|f| !before.contains(f))
                    .collect::<Vec<_>>()
            ));
            for f in after.iter().filter(|f| !before.contains(f)) {
                let _ = std::fs::remove_file(dir.path().join(f));
            }
        }
        if !wrong.is_empty() {
            failures.push(format!(
                "{what}:\n    {}\n    stderr: {}",
                wrong.join("; "),
                err.trim_end()
            ));
        }
    }
    // Every binary has its rows.
    for b in [
        "scatter",
        "facet",
        "follow",
        "texture",
        "measure",
        "promote",
        "illum",
        "ssmulti",
        "filter",
        "sssingle",
        "render",
        "pcconvert",
        "pcdiff",
        "pcinfo",
        "pctile",
    ] {
        assert!(
            per_bin.get(b).copied().unwrap_or(0) >= 4,
            "{b} has too few rows"
        );
    }
    assert!(
        failures.is_empty(),
        "{} of {} rows failed:\n{}",
        failures.len(),
        TABLE.len(),
        failures.join("\n")
    );
}

/// A negative number or a vector that starts with one is an option's
/// value, not an unknown option.
#[test]
fn negative_values_are_values() {
    let dir = tempdir();
    inputs(dir.path());
    let o = run_in(
        Some(dir.path()),
        "sssingle",
        &[
            "cloud.ply",
            "--mesh",
            "cube.obj",
            "--lights",
            "lights.json",
            "--sd",
            "0.5",
            "--eye",
            "-3,-2,-4",
            "--samples",
            "2",
        ],
        b"",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let c = from_bytes(&o.stdout);
    assert_eq!(
        c.detail("sssingle_eye"),
        Some(&pcsss::DetailValue::V3D([-3.0, -2.0, -4.0]))
    );
    let o = run_in(
        Some(dir.path()),
        "facet",
        &["cloud.ply", "--mesh", "cube.obj", "--cusp", "-0.5"],
        b"",
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--cusp") && stderr(&o).contains("-0.5"));
}
