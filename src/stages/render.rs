//! `render`: a pinhole camera over a mesh. Camera rays are cast through
//! pixel centres against the mesh's BVH; every pixel that hits becomes a
//! shade point (P, smooth N, coverage) of an image cloud ([`crate::image`]),
//! which `filter` then gives `ssM`; the beauty adds an optional direct
//! diffuse term ([`render_scene`] does all three), and [`write_png`] makes
//! a tone-mapped preview. The camera file is specified in
//! formats/CAMERA.md.

use glam::DVec3;
use rayon::prelude::*;
use serde::Deserialize;

use crate::cloud::{Attribute, Cloud, Role};
use crate::column::Column;
use crate::error::{Error, Result};
use crate::geom;
use crate::geom::bvh::Occluder;
use crate::geom::mesh::TriMesh;
use crate::image::{self, Window, PIXEL_X, PIXEL_Y};
use crate::lights::Light;
use crate::progress::Progress;
use crate::stages::facet::{self, Weight};
use crate::stages::filter;

/// A camera file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    /// Eye position.
    pub position: [f64; 3],
    /// The point the camera looks at (the image centre).
    pub look_at: [f64; 3],
    /// Up direction (default +y).
    #[serde(default = "default_up")]
    pub up: [f64; 3],
    /// Vertical field of view in degrees (default 40).
    #[serde(default = "default_fov")]
    pub fov: f64,
    /// Image size in pixels (default 512 x 512).
    #[serde(default = "default_size")]
    pub width: u32,
    #[serde(default = "default_size")]
    pub height: u32,
}

fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f64 {
    40.0
}
fn default_size() -> u32 {
    512
}

/// The largest image side.
pub const MAX_SIDE: u32 = 16384;

impl Camera {
    /// Reads and checks a camera file's text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<Camera> {
        let cam: Camera = crate::error::from_json(text, file)?;
        let bad = |key: &str, why: String| Error::invalid(format!("{file} at {key}: {why}"));
        for (key, v) in [
            ("position", cam.position),
            ("look_at", cam.look_at),
            ("up", cam.up),
        ] {
            if !v.iter().all(|x| x.is_finite()) {
                return Err(bad(key, format!("{v:?} is not finite")));
            }
        }
        if !(cam.fov > 0.0 && cam.fov < 180.0) {
            return Err(bad(
                "fov",
                format!("{} is not in (0, 180) degrees", cam.fov),
            ));
        }
        for (key, v) in [("width", cam.width), ("height", cam.height)] {
            if v == 0 || v > MAX_SIDE {
                return Err(bad(key, format!("{v} is not in 1..={MAX_SIDE}")));
            }
        }
        let f = DVec3::from_array(cam.look_at) - DVec3::from_array(cam.position);
        if f.length() == 0.0 {
            return Err(bad("look_at", "equals position".into()));
        }
        if f.normalize().cross(DVec3::from_array(cam.up)).length() < 1e-9 {
            return Err(bad(
                "up",
                "is parallel to the view direction (or zero)".into(),
            ));
        }
        Ok(cam)
    }

    /// The ray direction (unit) through the centre of pixel (x, y), y down.
    pub fn ray(&self, x: u32, y: u32) -> DVec3 {
        let eye = DVec3::from_array(self.position);
        let fwd = (DVec3::from_array(self.look_at) - eye).normalize();
        let right = fwd.cross(DVec3::from_array(self.up)).normalize();
        let up = right.cross(fwd);
        let h = (self.fov.to_radians() * 0.5).tan();
        let aspect = self.width as f64 / self.height as f64;
        let u = (2.0 * (x as f64 + 0.5) / self.width as f64 - 1.0) * h * aspect;
        let v = (1.0 - 2.0 * (y as f64 + 0.5) / self.height as f64) * h;
        (fwd + right * u + up * v).normalize()
    }
}

/// What `render` did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    pub pixels: usize,
    pub covered: usize,
}

/// A whole picture: the mesh seen by the camera, the cloud filtered at
/// the covered pixels, and a direct term.
pub struct Scene<'a> {
    pub mesh: &'a Cloud,
    /// The mesh's name in messages.
    pub mesh_name: &'a str,
    pub camera: &'a Camera,
    /// The cloud with `ssM` (or what lazy evaluation needs).
    pub cloud: &'a Cloud,
    pub cloud_name: &'a str,
    pub filter: filter::Params,
    /// What the beauty sums: `ssM`, `ssS` (stored or computed lazily).
    pub sources: &'a [filter::Source<'a>],
    /// A direct diffuse term: the lights and the diffuse reflectance
    /// `kd` (`beauty = ssM + kd * illum`, shadows from the mesh).
    pub direct: Option<(&'a [Light], [f64; 3])>,
}

/// Renders `scene`: the image cloud with `P`, `N`, `ssM`, `beauty` (and
/// `illum` with a direct term), what the camera saw and what the filter
/// did. An error names the input at fault.
pub fn render_scene(scene: &Scene, progress: &Progress) -> Result<(Cloud, Report, filter::Report)> {
    let at_mesh = |e: Error| e.about(scene.mesh_name);
    let (mut shade, rep) = render(scene.mesh, scene.camera).map_err(at_mesh)?;
    let frep = filter::filter(
        scene.cloud,
        scene.cloud_name,
        &mut shade,
        &scene.filter,
        scene.sources,
        progress,
    )?;
    let occluder = match scene.direct {
        Some(_) => Some(Occluder::new(
            &TriMesh::from_cloud(scene.mesh).map_err(at_mesh)?,
        )),
        None => None,
    };
    let direct = scene
        .direct
        .zip(occluder.as_ref())
        .map(|((lights, kd), occ)| (lights, occ, kd));
    let names: Vec<&str> = scene.sources.iter().map(|s| s.name()).collect();
    beauty(&mut shade, &names, direct, progress)?;
    Ok((shade, rep, frep))
}

/// Ray-casts `mesh` (a cloud with faces) from `cam`: the covered pixels as
/// shade points with `P`, `N` (the vertices' smooth normals interpolated),
/// `pixel_x`, `pixel_y` and the image windows.
pub fn render(mesh: &Cloud, cam: &Camera) -> Result<(Cloud, Report)> {
    // About 300 bytes a covered pixel at the peak (hits, shade points,
    // the filtered attributes, the image written): asked for first.
    let pixels = cam.width as u64 * cam.height as u64;
    crate::memory::check_available(
        300 * pixels,
        "camera",
        &format!("a {} x {} image", cam.width, cam.height),
    )?;
    let m = TriMesh::from_cloud(mesh)?;
    m.require_area()?;
    // Vertex normals (angle-weighted), as facet gives a mesh's vertices.
    let mut with_n = mesh.clone();
    facet::facet_mesh(&mut with_n, Weight::Angle)?;
    let vn: Vec<DVec3> = with_n
        .points()
        .vec3_f64("N")?
        .iter()
        .map(|v| DVec3::from_array(*v))
        .collect();
    let face_n = m.face_normals();
    let tri_face = m.tri_faces();
    let bvh = Occluder::new(&m);
    let eye = DVec3::from_array(cam.position);
    let (w, h) = (cam.width, cam.height);
    let rows: Vec<Vec<(u32, u32, DVec3, DVec3)>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut row = Vec::new();
            for x in 0..w {
                let d = cam.ray(x, y);
                let Some((t, dist)) = bvh.closest(eye, d) else {
                    continue;
                };
                let [a, b, c] = m.tri(t);
                let bary = geom::closest_on_triangle(eye + d * dist, a, b, c);
                let p = geom::blend(bary, a, b, c);
                let k = m.tris[t];
                let n = bary[0] * vn[m.vertex(k[0])]
                    + bary[1] * vn[m.vertex(k[1])]
                    + bary[2] * vn[m.vertex(k[2])];
                let n = if n.length() > 0.0 {
                    n.normalize()
                } else {
                    face_n[tri_face[t] as usize]
                };
                row.push((x, y, p, n));
            }
            row
        })
        .collect();
    let hits: Vec<(u32, u32, DVec3, DVec3)> = rows.into_iter().flatten().collect();
    let mut shade = Cloud::with_points(hits.len());
    let pts = shade.points_mut();
    let p: Vec<[f64; 3]> = hits.iter().map(|h| h.2.to_array()).collect();
    let n: Vec<[f32; 3]> = hits.iter().map(|h| h.3.as_vec3().to_array()).collect();
    // f32 positions unless the mesh's own are f64.
    let p_is_f64 = mesh
        .points()
        .vec3_columns("P")
        .is_ok_and(|c| c[0].ty() == crate::column::ScalarType::F64);
    if p_is_f64 {
        pts.set_vec3("P", Role::Point, &p)?;
    } else {
        let p32: Vec<[f32; 3]> = p.iter().map(|v| v.map(|x| x as f32)).collect();
        pts.set_vec3("P", Role::Point, &p32)?;
    }
    pts.set_vec3("N", Role::Normal, &n)?;
    pts.set(Attribute::scalar(
        PIXEL_X,
        Column::I32(hits.iter().map(|h| h.0 as i32).collect()),
    ))?;
    pts.set(Attribute::scalar(
        PIXEL_Y,
        Column::I32(hits.iter().map(|h| h.1 as i32).collect()),
    ))?;
    let win = Window::of_size(w, h);
    image::set_windows(&mut shade, win, win);
    let report = Report {
        pixels: w as usize * h as usize,
        covered: hits.len(),
    };
    Ok((shade, report))
}

/// The beauty at the shade points: the sum of the colour attributes
/// `names` (`ssM`, `ssS`) plus `kd * illum`, with `illum` the direct
/// diffuse light from `lights` (`illum`'s code: `Cl max(0, N.L)` with
/// shadow rays against `occluder`, kept as the attribute `illum`).
pub fn beauty(
    shade: &mut Cloud,
    names: &[&str],
    direct: Option<(&[Light], &Occluder, [f64; 3])>,
    progress: &Progress,
) -> Result<()> {
    let mut sum = vec![[0.0f64; 3]; shade.len()];
    for name in names {
        for (acc, v) in sum.iter_mut().zip(shade.points().vec3_f64(name)?) {
            for c in 0..3 {
                acc[c] += v[c];
            }
        }
    }
    let out: Vec<[f32; 3]> = match direct {
        None => sum.iter().map(|v| v.map(|x| x as f32)).collect(),
        Some((lights, occ, kd)) => {
            crate::stages::illum::illum(shade, lights, Some(occ), 0, progress)?;
            let e = shade.points().vec3_f64("illum")?;
            sum.iter()
                .zip(&e)
                .map(|(m, e)| [0, 1, 2].map(|c| (m[c] + kd[c] * e[c]) as f32))
                .collect()
        }
    };
    // A sum of values each within a float can leave it: refused, with
    // the pixel, never written as infinity.
    let px = shade.points().scalar_f64(PIXEL_X).ok();
    let py = shade.points().scalar_f64(PIXEL_Y).ok();
    if let Some(i) = out.iter().position(|v| v.iter().any(|x| !x.is_finite())) {
        let at = match (&px, &py) {
            (Some(x), Some(y)) => format!("pixel ({}, {})", x[i], y[i]),
            _ => format!("shade point {i}"),
        };
        return Err(Error::invalid(format!(
            "{at}: the beauty would be beyond the range of a float attribute ({} summed{})",
            names.join(" + "),
            if direct.is_some() {
                ", + kd * illum"
            } else {
                ""
            }
        )));
    }
    shade.points_mut().set_vec3("beauty", Role::Color, &out)?;
    Ok(())
}

/// An 8-bit sRGB picture of colour attribute `attr` of an image cloud:
/// `1 - exp(-exposure * x)` per channel (a soft shoulder instead of a
/// clip), sRGB-encoded; pixels without a point get `background`. Returns
/// (width, height, RGB bytes).
pub fn picture(
    shade: &Cloud,
    attr: &str,
    exposure: f64,
    background: [f64; 3],
) -> Result<(u32, u32, Vec<u8>)> {
    let Some(win) = image::data_window(shade)? else {
        return Err(Error::missing("detail", image::DATA_WINDOW));
    };
    let (x0, y0) = (win.x0 as i64, win.y0 as i64);
    let (w, h) = (win.width() as u32, win.height() as u32);
    let enc = |x: f64| (crate::stages::filter::srgb(x) * 255.0 + 0.5) as u8;
    let mut img: Vec<u8> = (0..w as usize * h as usize)
        .flat_map(|_| background.map(enc))
        .collect();
    let c = shade.points().vec3_f64(attr)?;
    let px = shade.points().scalar_f64(PIXEL_X)?;
    let py = shade.points().scalar_f64(PIXEL_Y)?;
    for i in 0..c.len() {
        let (x, y) = (px[i] as i64 - x0, py[i] as i64 - y0);
        if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
            continue;
        }
        let at = 3 * (y as usize * w as usize + x as usize);
        for k in 0..3 {
            let t = 1.0 - (-exposure * c[i][k].max(0.0)).exp();
            img[at + k] = enc(t);
        }
    }
    Ok((w, h, img))
}

/// Writes [`picture`] of `attr` as an 8-bit sRGB PNG.
pub fn write_png(
    w: &mut dyn std::io::Write,
    shade: &Cloud,
    attr: &str,
    exposure: f64,
    background: [f64; 3],
) -> Result<()> {
    let (width, height, rgb) = picture(shade, attr, exposure, background)?;
    let png_error = |e: png::EncodingError| match e {
        png::EncodingError::IoError(e) => Error::Io(e),
        e => Error::invalid(format!("PNG: {e}")),
    };
    let mut enc = png::Encoder::new(w, width, height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut wr = enc.write_header().map_err(png_error)?;
    wr.write_image_data(&rgb).map_err(png_error)?;
    wr.finish().map_err(png_error)
}
