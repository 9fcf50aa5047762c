//! `render`: a pinhole camera over a mesh. Camera rays are cast through
//! pixel centres against the mesh's BVH; every pixel that hits becomes a
//! shade point (P, smooth N, coverage) of an image cloud ([`crate::image`]),
//! which `filter` then gives `ssM`; the beauty adds an optional direct
//! diffuse term ([`render_scene`] does all three), and [`write_png`] makes
//! a tone-mapped preview. The camera file is specified in
//! formats/CAMERA.md.

use glam::DVec3;
use rand_pcg::Pcg32;
use rayon::prelude::*;
use serde::Deserialize;

use crate::cloud::{AttrData, Attribute, Cloud, DetailValue, Role};
use crate::column::Column;
use crate::error::{Error, Result};
use crate::frame::{Frame, UpAxis};
use crate::geom;
use crate::geom::bvh::Occluder;
use crate::geom::mesh::TriMesh;
use crate::image::{self, Window, PIXEL_X, PIXEL_Y};
use crate::lights::shadow::Shadows;
use crate::lights::Light;
use crate::maths::uniform24;
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
    /// Up direction (default: the `up_axis`, else +y).
    #[serde(default)]
    pub up: Option<[f64; 3]>,
    /// Vertical field of view in degrees (default 40).
    #[serde(default = "default_fov")]
    pub fov: f64,
    /// Image size in pixels (default 512 x 512).
    #[serde(default = "default_size")]
    pub width: u32,
    #[serde(default = "default_size")]
    pub height: u32,
    /// The frame the file's coordinates are in (`formats/CAMERA.md`).
    #[serde(default)]
    pub up_axis: Option<UpAxis>,
    #[serde(default)]
    pub meters_per_unit: Option<f64>,
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
            ("up", cam.up().to_array()),
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
        cam.frame()
            .check()
            .map_err(|why| bad("meters_per_unit", why))?;
        if f.normalize().cross(cam.up()).length() < 1e-9 {
            return Err(bad(
                "up",
                "is parallel to the view direction (or zero)".into(),
            ));
        }
        Ok(cam)
    }

    /// The camera with an image `width` and `height` in place of its own
    /// (`render --width/--height`): one given alone keeps the camera's
    /// aspect, the other side rounded (at least 1 pixel); the vertical
    /// field of view stays. A side out of `1..=MAX_SIDE` is an error
    /// naming it.
    pub fn sized(mut self, width: Option<u32>, height: Option<u32>) -> Result<Camera> {
        let aspect = self.width as f64 / self.height as f64;
        for (key, v) in [("width", width), ("height", height)] {
            if let Some(v) = v.filter(|&v| v == 0 || v > MAX_SIDE) {
                return Err(Error::param(
                    key,
                    format!("{v} pixels is not in 1..={MAX_SIDE}"),
                ));
            }
        }
        // The side that follows the camera's aspect (out of range: the
        // given side's fault).
        let side = |v: f64, key: &str, other: &str| {
            let s = (v.round().min(u32::MAX as f64) as u32).max(1);
            if s > MAX_SIDE {
                Err(Error::param(
                    key,
                    format!("gives the camera's aspect a {other} of {s} pixels, past {MAX_SIDE}: give --{other} too"),
                ))
            } else {
                Ok(s)
            }
        };
        let (w, h) = match (width, height) {
            (None, None) => return Ok(self),
            (Some(w), Some(h)) => (w, h),
            (Some(w), None) => (w, side(w as f64 / aspect, "width", "height")?),
            (None, Some(h)) => (side(h as f64 * aspect, "height", "width")?, h),
        };
        (self.width, self.height) = (w, h);
        Ok(self)
    }

    /// The up direction: `up`, else the up axis, else +y.
    pub fn up(&self) -> DVec3 {
        match (self.up, self.up_axis) {
            (Some(u), _) => DVec3::from_array(u),
            (None, Some(a)) => a.vector(),
            (None, None) => DVec3::Y,
        }
    }

    /// The frame the file states.
    pub fn frame(&self) -> Frame {
        Frame {
            up: self.up_axis,
            meters_per_unit: self.meters_per_unit,
        }
    }

    /// The camera moved into the frame `to` (a cloud's): its position,
    /// target and up turned between up axes, positions scaled between
    /// units. The field of view and the picture do not change.
    pub fn in_frame(&self, to: &Frame) -> Camera {
        let c = self.frame().change_to(to);
        let p = |q: [f64; 3]| c.point(DVec3::from_array(q)).to_array();
        Camera {
            position: p(self.position),
            look_at: p(self.look_at),
            up: Some(c.vector(self.up()).to_array()),
            up_axis: to.up.or(self.up_axis),
            meters_per_unit: to.meters_per_unit.or(self.meters_per_unit),
            ..self.clone()
        }
    }

    /// The ray direction (unit) through the centre of pixel (x, y), y down.
    pub fn ray(&self, x: u32, y: u32) -> DVec3 {
        self.ray_at(x as f64 + 0.5, y as f64 + 0.5)
    }

    /// The ray direction (unit) through image position `(px, py)` in
    /// pixels from the top left corner.
    pub fn ray_at(&self, px: f64, py: f64) -> DVec3 {
        let eye = DVec3::from_array(self.position);
        let fwd = (DVec3::from_array(self.look_at) - eye).normalize();
        let right = fwd.cross(self.up()).normalize();
        let up = right.cross(fwd);
        let h = (self.fov.to_radians() * 0.5).tan();
        let aspect = self.width as f64 / self.height as f64;
        let u = (2.0 * px / self.width as f64 - 1.0) * h * aspect;
        let v = (1.0 - 2.0 * py / self.height as f64) * h;
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
    /// Camera rays a pixel and how they are weighed.
    pub pixels: Pixels,
}

/// The weight of a camera sample in the pixels around it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum PixelFilter {
    /// Its own pixel, weight 1.
    #[default]
    Box,
    /// A Gaussian of standard deviation 0.5 pixel cut at 2 pixels (less
    /// its value there), Mitsuba's default.
    Gaussian,
}

/// How the pixels are sampled: `spp` rays a pixel (1: through its centre;
/// more: jittered in a `floor(sqrt(spp))` square grid of strata, the rest
/// uniform, from the random stream `Pcg32(seed, pixel)`), weighed by
/// `filter`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pixels {
    pub spp: u32,
    pub filter: PixelFilter,
    pub seed: u64,
}

impl Default for Pixels {
    fn default() -> Pixels {
        Pixels {
            spp: 1,
            filter: PixelFilter::Box,
            seed: 0,
        }
    }
}

/// The most samples a pixel.
pub const MAX_SPP: u32 = 4096;

impl Pixels {
    /// Checks `spp`, named as the command line's.
    pub fn validate(&self) -> Result<()> {
        if !(1..=MAX_SPP).contains(&self.spp) {
            return Err(Error::param(
                "spp",
                format!("{} is not in 1..={MAX_SPP}", self.spp),
            ));
        }
        Ok(())
    }

    /// Whether the picture is the plain one: a ray through each pixel's
    /// centre, its own pixel's.
    fn centres(&self) -> bool {
        self.spp == 1 && self.filter == PixelFilter::Box
    }

    /// The sample positions of pixel `(x, y)` within it, in `[0, 1)^2`.
    fn offsets(&self, index: u64) -> Vec<(f64, f64)> {
        if self.spp == 1 {
            return vec![(0.5, 0.5)];
        }
        let mut r = Pcg32::new(self.seed, index);
        let m = (self.spp as f64).sqrt().floor() as u32;
        let mut v = Vec::with_capacity(self.spp as usize);
        for k in 0..self.spp {
            let (u, w) = (uniform24(&mut r), uniform24(&mut r));
            if k < m * m {
                let (i, j) = (k % m, k / m);
                v.push(((i as f64 + u) / m as f64, (j as f64 + w) / m as f64));
            } else {
                v.push((u, w));
            }
        }
        v
    }

    /// The filter's reach in pixels and its weight at offset `(dx, dy)`.
    fn reach(&self) -> i64 {
        match self.filter {
            PixelFilter::Box => 0,
            PixelFilter::Gaussian => 2,
        }
    }

    fn weight(&self, dx: f64, dy: f64) -> f64 {
        match self.filter {
            PixelFilter::Box => {
                if (-0.5..0.5).contains(&dx) && (-0.5..0.5).contains(&dy) {
                    1.0
                } else {
                    0.0
                }
            }
            PixelFilter::Gaussian => {
                let g = |d: f64| {
                    if d.abs() >= 2.0 {
                        0.0
                    } else {
                        (-2.0 * d * d).exp() - (-8.0f64).exp()
                    }
                };
                g(dx) * g(dy)
            }
        }
    }
}

/// Renders `scene`: the image cloud with `P`, `N`, `ssM`, `beauty` (and
/// `illum` with a direct term), what the camera saw and what the filter
/// did. An error names the input at fault.
pub fn render_scene(scene: &Scene, progress: &Progress) -> Result<(Cloud, Report, filter::Report)> {
    let at_mesh = |e: Error| e.about(scene.mesh_name);
    scene.pixels.validate()?;
    if let Some((_, kd)) = scene.direct {
        check_kd(kd)?;
    }
    let (mut shade, rep, at) = if scene.pixels.centres() {
        let (shade, rep) = render(scene.mesh, scene.camera).map_err(at_mesh)?;
        (shade, rep, None)
    } else {
        let (shade, rep, at) =
            render_samples(scene.mesh, scene.camera, &scene.pixels).map_err(at_mesh)?;
        (shade, rep, Some(at))
    };
    let frep = filter::filter(
        scene.cloud,
        scene.cloud_name,
        &mut shade,
        &scene.filter,
        scene.sources,
        progress,
    )?;
    let tris = match scene.direct {
        Some(_) => Some(TriMesh::from_cloud(scene.mesh).map_err(at_mesh)?),
        None => None,
    };
    let occluder = tris.as_ref().map(Occluder::new);
    let shadows = tris
        .as_ref()
        .zip(occluder.as_ref())
        .map(|(m, o)| Shadows::new(m, o, None));
    let direct = scene
        .direct
        .zip(shadows.as_ref())
        .map(|((lights, kd), sh)| (lights, sh, kd));
    let terms: Vec<(&str, f64)> = scene
        .sources
        .iter()
        .map(|s| (s.name(), filter::radiance_scale(scene.cloud, s)))
        .collect();
    let eye = DVec3::from_array(scene.camera.position);
    // ssM walked towards an eye is the light towards that eye alone.
    if let Some(crate::cloud::DetailValue::V3D(baked)) = scene.cloud.detail("ssmulti_eye") {
        let baked = DVec3::from_array(*baked);
        let uses = scene
            .sources
            .iter()
            .any(|s| matches!(s, filter::Source::Stored("ssM")));
        if uses && (baked - eye).length() > 1e-6 * eye.length().max(baked.length()).max(1.0) {
            return Err(crate::error::Error::param(
                "camera",
                format!(
                    "the cloud's ssM was walked towards the eye {:?} (ssmulti --eye/--camera), \
                     this camera is at {:?}: bake ssM for this camera, or without --eye",
                    baked.to_array(),
                    eye.to_array()
                ),
            ));
        }
    }
    let exit = scene
        .sources
        .iter()
        .find_map(|s| filter::exit_medium(scene.cloud, s).map(|m| (s.name(), Exit::new(&m, eye))));
    let exit_ref = exit.as_ref().map(|(n, e)| (*n, e));
    beauty(&mut shade, &terms, exit_ref, direct, progress)?;
    let sum: Vec<String> = terms
        .iter()
        .map(|(n, k)| {
            if exit_ref.is_some_and(|(e, _)| e == *n) {
                format!("{n} / pi * R_m(mu) / R_md")
            } else if *k == 1.0 {
                n.to_string()
            } else {
                format!("{n} / pi")
            }
        })
        .collect();
    shade.set_detail("render_beauty", DetailValue::Str(sum.join(" + ")));
    let (shade, rep) = match at {
        None => (shade, rep),
        Some(at) => resolve(&shade, &at, scene.camera, &scene.pixels, rep)?,
    };
    Ok((shade, rep, frep))
}

/// A mesh ready for camera rays: its BVH and smooth vertex normals.
struct Caster {
    m: TriMesh,
    vn: Vec<DVec3>,
    face_n: Vec<DVec3>,
    tri_face: Vec<u32>,
    bvh: Occluder,
    eye: DVec3,
}

impl Caster {
    fn new(mesh: &Cloud, cam: &Camera, rays: u64) -> Result<Caster> {
        // About 300 bytes a ray at the peak (hits, shade points, the
        // filtered attributes, the image written): asked for first.
        crate::memory::check_available(
            300 * rays,
            "camera",
            &format!("{rays} camera rays ({} x {})", cam.width, cam.height),
        )?;
        let m = TriMesh::from_cloud(mesh)?;
        m.require_area()?;
        // Vertex normals (angle-weighted), as facet gives a mesh's vertices.
        let mut with_n = mesh.clone();
        facet::facet_mesh(&mut with_n, Weight::Angle, true)?;
        let vn: Vec<DVec3> = with_n
            .points()
            .vec3_f64("N")?
            .iter()
            .map(|v| DVec3::from_array(*v))
            .collect();
        let face_n = m.face_normals();
        let tri_face = m.tri_faces();
        let bvh = Occluder::new(&m);
        Ok(Caster {
            m,
            vn,
            face_n,
            tri_face,
            bvh,
            eye: DVec3::from_array(cam.position),
        })
    }

    /// The first hit along `d` from the eye: its position and smooth
    /// normal.
    fn cast(&self, d: DVec3) -> Option<(DVec3, DVec3)> {
        let (t, dist) = self.bvh.closest(self.eye, d)?;
        let m = &self.m;
        let [a, b, c] = m.tri(t);
        let bary = geom::closest_on_triangle(self.eye + d * dist, a, b, c);
        let p = geom::blend(bary, a, b, c);
        let k = m.tris[t];
        let n = bary[0] * self.vn[m.vertex(k[0])]
            + bary[1] * self.vn[m.vertex(k[1])]
            + bary[2] * self.vn[m.vertex(k[2])];
        let n = if n.length() > 0.0 {
            n.normalize()
        } else {
            self.face_n[self.tri_face[t] as usize]
        };
        Some((p, n))
    }
}

/// Shade points at `hits` (P, N): f32 positions unless the mesh's own are
/// f64.
fn shade_points(mesh: &Cloud, p: &[DVec3], n: &[DVec3]) -> Result<Cloud> {
    let mut shade = Cloud::with_points(p.len());
    let pts = shade.points_mut();
    let p_is_f64 = mesh
        .points()
        .vec3_columns("P")
        .is_ok_and(|c| c[0].ty() == crate::column::ScalarType::F64);
    if p_is_f64 {
        let p: Vec<[f64; 3]> = p.iter().map(|v| v.to_array()).collect();
        pts.set_vec3("P", Role::Point, &p)?;
    } else {
        let p32: Vec<[f32; 3]> = p.iter().map(|v| v.as_vec3().to_array()).collect();
        pts.set_vec3("P", Role::Point, &p32)?;
    }
    let n: Vec<[f32; 3]> = n.iter().map(|v| v.as_vec3().to_array()).collect();
    pts.set_vec3("N", Role::Normal, &n)?;
    Ok(shade)
}

/// Ray-casts `mesh` (a cloud with faces) from `cam`, a ray through each
/// pixel's centre: the covered pixels as shade points with `P`, `N` (the
/// vertices' smooth normals interpolated), `pixel_x`, `pixel_y` and the
/// image windows.
pub fn render(mesh: &Cloud, cam: &Camera) -> Result<(Cloud, Report)> {
    let pixels = cam.width as u64 * cam.height as u64;
    let caster = Caster::new(mesh, cam, pixels)?;
    let (w, h) = (cam.width, cam.height);
    let rows: Vec<Vec<(u32, u32, DVec3, DVec3)>> = (0..h)
        .into_par_iter()
        .map(|y| {
            (0..w)
                .filter_map(|x| caster.cast(cam.ray(x, y)).map(|(p, n)| (x, y, p, n)))
                .collect()
        })
        .collect();
    let hits: Vec<(u32, u32, DVec3, DVec3)> = rows.into_iter().flatten().collect();
    let p: Vec<DVec3> = hits.iter().map(|h| h.2).collect();
    let n: Vec<DVec3> = hits.iter().map(|h| h.3).collect();
    let mut shade = shade_points(mesh, &p, &n)?;
    let pts = shade.points_mut();
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

/// Ray-casts `mesh` with `px.spp` rays a pixel ([`Pixels`]): the hits as
/// shade points (`P`, `N`; not yet an image) and each one's image
/// position.
fn render_samples(
    mesh: &Cloud,
    cam: &Camera,
    px: &Pixels,
) -> Result<(Cloud, Report, Vec<[f64; 2]>)> {
    let pixels = cam.width as u64 * cam.height as u64;
    let caster = Caster::new(mesh, cam, pixels * px.spp as u64)?;
    let (w, h) = (cam.width, cam.height);
    let rows: Vec<Vec<([f64; 2], DVec3, DVec3)>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut row = Vec::new();
            for x in 0..w {
                for (u, v) in px.offsets(y as u64 * w as u64 + x as u64) {
                    let at = [x as f64 + u, y as f64 + v];
                    if let Some((p, n)) = caster.cast(cam.ray_at(at[0], at[1])) {
                        row.push((at, p, n));
                    }
                }
            }
            row
        })
        .collect();
    let hits: Vec<([f64; 2], DVec3, DVec3)> = rows.into_iter().flatten().collect();
    let p: Vec<DVec3> = hits.iter().map(|h| h.1).collect();
    let n: Vec<DVec3> = hits.iter().map(|h| h.2).collect();
    let shade = shade_points(mesh, &p, &n)?;
    let report = Report {
        pixels: pixels as usize,
        covered: 0,
    };
    Ok((shade, report, hits.iter().map(|h| h.0).collect()))
}

/// The image of samples `shade` taken at image positions `at`: each pixel
/// the filter-weighted mean over every sample around it (those that
/// missed the mesh count as 0), the colours premultiplied by coverage
/// `A` (the weight of the samples that hit), `P` and `N` the mean over
/// the hits alone (`N` renormalised). Pixels with `A = 0` are no points.
fn resolve(
    shade: &Cloud,
    at: &[[f64; 2]],
    cam: &Camera,
    px: &Pixels,
    mut rep: Report,
) -> Result<(Cloud, Report)> {
    let (w, h) = (cam.width as i64, cam.height as i64);
    let npix = (w * h) as usize;
    let r = px.reach();
    // Every sample's weight in each pixel it reaches: the total weight.
    let mut total = vec![0.0f64; npix];
    for y in 0..h {
        for x in 0..w {
            for (u, v) in px.offsets((y * w + x) as u64) {
                let (sx, sy) = (x as f64 + u, y as f64 + v);
                splat(sx, sy, r, w, h, px, |i, wt| total[i] += wt);
            }
        }
    }
    let mut cover = vec![0.0f64; npix];
    for &[sx, sy] in at {
        splat(sx, sy, r, w, h, px, |i, wt| cover[i] += wt);
    }
    let pts = shade.points();
    let mut out_cols: Vec<(String, Role, bool, Vec<[f64; 3]>)> = Vec::new();
    for a in pts.attrs() {
        if let AttrData::Vec3(role, _) = &a.data {
            let vals = pts.vec3_f64(&a.name)?;
            let data = a.name == "P" || a.name == "N";
            let mut acc = vec![[0.0f64; 3]; npix];
            for (k, &[sx, sy]) in at.iter().enumerate() {
                splat(sx, sy, r, w, h, px, |i, wt| {
                    for c in 0..3 {
                        acc[i][c] += wt * vals[k][c];
                    }
                });
            }
            out_cols.push((a.name.clone(), *role, data, acc));
        }
    }
    let covered: Vec<usize> = (0..npix).filter(|&i| cover[i] > 0.0).collect();
    let mut img = Cloud::with_points(covered.len());
    let p_is_f64 = pts
        .vec3_columns("P")
        .is_ok_and(|c| c[0].ty() == crate::column::ScalarType::F64);
    for (name, role, data, acc) in &out_cols {
        let v: Vec<[f64; 3]> = covered
            .iter()
            .map(|&i| {
                let d = if *data { cover[i] } else { total[i] };
                let m = acc[i].map(|x| x / d);
                if name == "N" {
                    let n = DVec3::from_array(m);
                    if n.length() > 0.0 {
                        return n.normalize().to_array();
                    }
                }
                m
            })
            .collect();
        let dst = img.points_mut();
        if name == "P" && p_is_f64 {
            dst.set_vec3(name, *role, &v)?;
        } else {
            let v32: Vec<[f32; 3]> = v.iter().map(|x| x.map(|y| y as f32)).collect();
            dst.set_vec3(name, *role, &v32)?;
        }
    }
    let dst = img.points_mut();
    dst.set(Attribute::scalar(
        "A",
        Column::F32(
            covered
                .iter()
                .map(|&i| (cover[i] / total[i]) as f32)
                .collect(),
        ),
    ))?;
    dst.set(Attribute::scalar(
        PIXEL_X,
        Column::I32(covered.iter().map(|&i| (i as i64 % w) as i32).collect()),
    ))?;
    dst.set(Attribute::scalar(
        PIXEL_Y,
        Column::I32(covered.iter().map(|&i| (i as i64 / w) as i32).collect()),
    ))?;
    img.detail = shade.detail.clone();
    let win = Window::of_size(cam.width, cam.height);
    image::set_windows(&mut img, win, win);
    img.set_detail("render_spp", DetailValue::I32(px.spp as i32));
    // The filter's name as the command line spells it.
    let filter = clap::ValueEnum::to_possible_value(&px.filter).map(|v| v.get_name().to_string());
    img.set_detail(
        "render_pixel_filter",
        DetailValue::Str(filter.unwrap_or_default()),
    );
    rep.covered = covered.len();
    Ok((img, rep))
}

/// Calls `add(pixel, weight)` for each pixel within `r` of the one holding
/// image position `(sx, sy)` that the filter gives a weight.
fn splat(sx: f64, sy: f64, r: i64, w: i64, h: i64, px: &Pixels, mut add: impl FnMut(usize, f64)) {
    let (x0, y0) = (sx.floor() as i64, sy.floor() as i64);
    for y in (y0 - r).max(0)..=(y0 + r).min(h - 1) {
        for x in (x0 - r).max(0)..=(x0 + r).min(w - 1) {
            let wt = px.weight(sx - (x as f64 + 0.5), sy - (y as f64 + 0.5));
            if wt > 0.0 {
                add((y * w + x) as usize, wt);
            }
        }
    }
}

/// How the physical model's multiple scattering leaves towards the eye
/// (`docs/DESIGN.md#the-exit`): `ssM` is an exitance; its radiance
/// towards a view at cosine `mu` with the normal is that of a half-space
/// under light from the whole sky, `ssM / pi * R_m(mu) / R_md` per
/// channel (by reciprocity: the light leaving towards `mu` is the light
/// arriving from `mu` that the medium returns), where a Lambertian exit
/// would take `ssM / pi` whatever the view.
pub struct Exit {
    eye: DVec3,
    inc: crate::medium::Incidence,
    /// `R_m(1) / R_md` per channel.
    k: [f64; 3],
}

impl Exit {
    /// The exit of `medium`'s multiple scattering seen from `eye`.
    pub fn new(medium: &crate::medium::Medium, eye: DVec3) -> Exit {
        let d = medium.rm_diffuse();
        Exit {
            eye,
            inc: medium.incidence(),
            k: [0, 1, 2].map(|c| if d[c] > 0.0 { medium.rm[c] / d[c] } else { 1.0 }),
        }
    }

    /// The factor on `ssM / pi` at the point `p` of normal `n`.
    pub fn factor(&self, p: DVec3, n: DVec3) -> [f64; 3] {
        let mu = n
            .normalize_or_zero()
            .dot((self.eye - p).normalize_or_zero())
            .clamp(0.0, 1.0);
        let f = self.inc.factor(mu);
        [0, 1, 2].map(|c| f[c] * self.k[c])
    }
}

/// The beauty at the shade points: the sum of the colour attributes
/// `terms` (`ssM`, `ssS`), each times its scale ([`filter::radiance_scale`])
/// and, for the term `exit` names, its [`Exit`] factor at the point's `P`
/// and `N`, plus `kd * illum`, with `illum` the direct
/// diffuse light from `lights` (`illum`'s code: `Cl max(0, N.L)` with
/// shadow rays against the mesh of `shadows`, kept as the attribute
/// `illum`).
pub fn beauty(
    shade: &mut Cloud,
    terms: &[(&str, f64)],
    exit: Option<(&str, &Exit)>,
    direct: Option<(&[Light], &Shadows, [f64; 3])>,
    progress: &Progress,
) -> Result<()> {
    let mut sum = vec![[0.0f64; 3]; shade.len()];
    let at = match exit {
        Some(_) => Some((shade.points().vec3_f64("P")?, shade.points().vec3_f64("N")?)),
        None => None,
    };
    for (name, k) in terms {
        let view = exit.filter(|(n, _)| n == name).map(|(_, e)| e);
        for (i, (acc, v)) in sum
            .iter_mut()
            .zip(shade.points().vec3_f64(name)?)
            .enumerate()
        {
            let f = match (view, &at) {
                (Some(e), Some((p, n))) => {
                    e.factor(DVec3::from_array(p[i]), DVec3::from_array(n[i]))
                }
                _ => [1.0; 3],
            };
            for c in 0..3 {
                acc[c] += k * v[c] * f[c];
            }
        }
    }
    let names: Vec<&str> = terms.iter().map(|t| t.0).collect();
    let out: Vec<[f32; 3]> = match direct {
        None => sum.iter().map(|v| v.map(|x| x as f32)).collect(),
        Some((lights, shadows, kd)) => {
            crate::stages::illum::illum(shade, lights, Some(shadows), 0, progress)?;
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

pub use super::filter::check_exposure;

/// Checks the direct term's diffuse reflectance `kd`: finite and >= 0
/// in each channel.
pub fn check_kd(kd: [f64; 3]) -> Result<()> {
    if kd.iter().all(|k| k.is_finite() && *k >= 0.0) {
        Ok(())
    } else {
        Err(Error::param(
            "kd",
            format!("{kd:?}: must be finite and >= 0"),
        ))
    }
}

/// An 8-bit sRGB picture of colour attribute `attr` of an image cloud,
/// with coverage as alpha: `1 - exp(-exposure * x)` per channel (a soft
/// shoulder instead of a clip) of the colour over its coverage (a PNG's
/// alpha is straight, the cloud's colours premultiplied), sRGB-encoded;
/// alpha the point's `A` (1 without it), pixels without a point 0.
/// Returns (width, height, RGBA bytes).
pub fn picture(shade: &Cloud, attr: &str, exposure: f64) -> Result<(u32, u32, Vec<u8>)> {
    check_exposure(exposure)?;
    let Some(win) = image::data_window(shade)? else {
        return Err(Error::missing("detail", image::DATA_WINDOW));
    };
    let (x0, y0) = (win.x0 as i64, win.y0 as i64);
    let (w, h) = (win.width() as u32, win.height() as u32);
    let enc = |x: f64| (crate::stages::filter::srgb(x) * 255.0 + 0.5) as u8;
    let mut img = vec![0u8; 4 * w as usize * h as usize];
    let c = shade.points().vec3_f64(attr)?;
    let px = shade.points().scalar_f64(PIXEL_X)?;
    let py = shade.points().scalar_f64(PIXEL_Y)?;
    let alpha = shade.points().scalar_f64("A").ok();
    for i in 0..c.len() {
        let (x, y) = (px[i] as i64 - x0, py[i] as i64 - y0);
        if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
            continue;
        }
        let a = alpha.as_ref().map_or(1.0, |a| a[i].clamp(0.0, 1.0));
        if a.is_nan() || a <= 0.0 {
            continue;
        }
        let at = 4 * (y as usize * w as usize + x as usize);
        for k in 0..3 {
            let t = 1.0 - (-exposure * (c[i][k] / a).max(0.0)).exp();
            img[at + k] = enc(t);
        }
        img[at + 3] = (a * 255.0 + 0.5) as u8;
    }
    Ok((w, h, img))
}

/// Writes [`picture`] of `attr` as an 8-bit sRGB PNG with alpha.
pub fn write_png(
    w: &mut dyn std::io::Write,
    shade: &Cloud,
    attr: &str,
    exposure: f64,
) -> Result<()> {
    let (width, height, rgba) = picture(shade, attr, exposure)?;
    let png_error = |e: png::EncodingError| match e {
        png::EncodingError::IoError(e) => Error::Io(e),
        e => Error::invalid(format!("PNG: {e}")),
    };
    let mut enc = png::Encoder::new(w, width, height);
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut wr = enc.write_header().map_err(png_error)?;
    wr.write_image_data(&rgba).map_err(png_error)?;
    wr.finish().map_err(png_error)
}
