//! What the fuzz targets (`fuzz/`, `cargo fuzz`, nightly) run on each
//! input, kept here so that `make test` replays the corpus and every input
//! that once crashed (`fixtures/fuzz/`) on stable with the very same code.
//! Each function may return early on an error; it must never panic, hang
//! or allocate beyond what its input holds.

use glam::DVec3;

use crate::formats::{self, Format, Select};
use crate::geom::mesh::TriMesh;

/// A PLY file (any encoding): read whole and with one attribute decoded;
/// what reads is written in two encodings and read back, and its faces
/// triangulated and measured.
pub fn ply(data: &[u8]) {
    let _ = formats::read_cloud(data, &Select::only(&["P"]));
    let Ok(cloud) = formats::read_cloud(data, &Select::All) else {
        return;
    };
    round_trip(&cloud, Format::DEFAULT);
    round_trip(&cloud, Format::Ply(formats::Encoding::Ascii));
    round_trip_usd(&cloud);
    mesh(&cloud);
}

/// An OpenEXR file: read; what reads is written and read back.
pub fn exr(data: &[u8]) {
    let Ok(cloud) = formats::read_cloud(data, &Select::All) else {
        return;
    };
    round_trip(&cloud, Format::Exr);
}

/// An OBJ file: read, triangulated, measured.
pub fn obj(data: &[u8]) {
    if let Ok(cloud) = formats::obj::read_obj(data) {
        round_trip(&cloud, Format::DEFAULT);
        mesh(&cloud);
    }
}

/// A lights file (parsed, masked, its light at a point) or a camera file
/// (parsed, a ray made).
pub fn json(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = crate::medium::material::parse(text, "fuzz");
    if let Ok(file) = crate::lights::parse_file(text, "fuzz") {
        for up in [crate::frame::UpAxis::Y, crate::frame::UpAxis::Z] {
            let _ = file.in_frame(&crate::frame::Frame {
                up: Some(up),
                meters_per_unit: Some(0.01),
            });
        }
    }
    if let Ok(lights) = crate::lights::parse(text, "fuzz") {
        for mask in ["*", "{a,b}", "^x", "\"a b\",c"] {
            let _ = crate::lights::mask(&lights, mask);
        }
        let mut out = Vec::new();
        for l in &lights {
            l.arrivals(DVec3::ZERO, DVec3::Z, 0.5, 0.5, &mut out);
            l.emissions(DVec3::new(0.1, 0.2, 0.3), 0.5, 0.5, &mut out);
        }
    }
    if let Ok(cam) = crate::stages::render::Camera::parse(text, "fuzz") {
        let moved = cam.in_frame(&crate::frame::Frame {
            up: Some(crate::frame::UpAxis::Z),
            meters_per_unit: Some(1e-3),
        });
        let _ = moved.ray(0, 0);
        let _ = cam.ray(0, 0);
        let _ = cam.ray(cam.width - 1, cam.height - 1);
    }
}

/// A texture image (PNG or OpenEXR): read both ways, sampled in and past
/// its edges.
pub fn texture(data: &[u8]) {
    use crate::formats::texture::{read_bytes, Decode};
    for decode in [Decode::Auto, Decode::Linear] {
        if let Ok(t) = read_bytes(data, decode) {
            for (u, v) in [(0.0, 0.0), (0.5, 0.5), (1.0, 1.0), (-3.2, 7.9), (1e9, -1e9)] {
                let _ = t.sample(u, v, true);
                let _ = t.sample(u, v, false);
            }
        }
    }
}

/// A USD stage (text, crate or package, by its first bytes): its meshes,
/// lights and camera read; what reads as a mesh is written as USD text
/// and read back.
pub fn usd(data: &[u8]) {
    let ext = if data.starts_with(b"#usda") {
        "usda"
    } else if data.starts_with(b"PK") {
        "usdz"
    } else {
        "usdc"
    };
    let Ok(dir) = tempfile::tempdir() else { return };
    let path = dir.path().join(format!("stage.{ext}"));
    if std::fs::write(&path, data).is_err() {
        return;
    }
    if let Ok(m) = formats::usd::read_mesh(&path, None) {
        mesh(&m.cloud);
        round_trip_usd(&m.cloud);
    }
    let _ = formats::usd::lights_json(&path);
    let _ = formats::usd::camera_json(&path, 64);
}

/// Writes `cloud` as USD text; what writes must read back (but a layer
/// of overs of a stage's meshes, which composes over that stage alone).
fn round_trip_usd(cloud: &crate::Cloud) {
    if cloud.detail(crate::names::D_USD_PRIMS).is_some() {
        let _ = formats::write_cloud(&mut Vec::new(), cloud, Format::Usda);
        return;
    }
    let mut bytes = Vec::new();
    if formats::write_cloud(&mut bytes, cloud, Format::Usda).is_err() {
        return;
    }
    let Ok(dir) = tempfile::tempdir() else { return };
    let path = dir.path().join("back.usda");
    if std::fs::write(&path, &bytes).is_ok() {
        if let Err(e) = formats::read_cloud_file(&path, &Select::All) {
            panic!("a cloud written as USD text does not read back: {e}");
        }
    }
}

/// Writes `cloud` as `format`; what writes must read back.
fn round_trip(cloud: &crate::Cloud, format: Format) {
    let mut bytes = Vec::new();
    if formats::write_cloud(&mut bytes, cloud, format).is_ok() {
        if let Err(e) = formats::read_cloud(&bytes[..], &Select::All) {
            panic!("a cloud written as {format:?} does not read back: {e}");
        }
    }
}

/// Triangulates and measures a cloud with faces.
fn mesh(cloud: &crate::Cloud) {
    if cloud.faces().is_none_or(|f| f.is_empty()) {
        return;
    }
    if let Ok(m) = TriMesh::from_cloud(cloud) {
        let _ = m.tri_areas();
        let _ = m.face_normals();
        let mut c = cloud.clone();
        let _ = crate::stages::measure::measure(&mut c);
    }
}

/// A tile manifest (`pctile merge` reads it): parsed and checked; what
/// passes has its checksum recomputed and its tiles' plan rebuilt from
/// their boxes' corners.
pub fn manifest(data: &[u8]) {
    let Ok(m) = crate::tiles::Manifest::parse(data) else {
        return;
    };
    let _ = m.checksum();
    let mut corners: Vec<DVec3> = m.tiles.iter().map(|t| DVec3::from_array(t.lo)).collect();
    let plan = crate::tiles::Plan::new(
        &mut corners,
        DVec3::from_array(m.lo),
        DVec3::from_array(m.hi),
        m.tiles.len(),
    );
    for t in &m.tiles {
        let p = DVec3::from_array(t.lo);
        if p.is_finite() {
            let owner = plan.owner(p);
            plan.halo_of(p, owner, m.halo, |_| {});
        }
    }
}
