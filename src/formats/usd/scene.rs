//! USD in: UsdLux lights and a UsdGeomCamera, written as the toolkit's
//! own lights and camera files (formats/LIGHTS.md, formats/CAMERA.md) so
//! that one parser checks both, and a scene in USD and in JSON is the
//! same scene by construction. The conversions are the table in
//! formats/LIGHTS.md#light-units.

use std::f64::consts::PI;
use std::path::Path;

use glam::{DMat4, DVec3};
use openusd::{sdf, usd};
use serde_json::{json, Map, Value};

use super::stage::{self, at, value};
use crate::error::{Error, Result};
use crate::frame::Frame;

fn num(stage: &usd::Stage, p: &sdf::Path, names: &[&str], default: f64) -> Result<f64> {
    for n in names {
        if let Some(v) = value(stage, p, n)? {
            let x =
                stage::scalar(&v).ok_or_else(|| at(p.as_str(), format!("{n} is not a number")))?;
            if !x.is_finite() {
                return Err(at(p.as_str(), format!("{n} is {x}")));
            }
            return Ok(x);
        }
    }
    Ok(default)
}

fn flag(stage: &usd::Stage, p: &sdf::Path, names: &[&str]) -> Result<bool> {
    for n in names {
        match value(stage, p, n)? {
            None => continue,
            Some(sdf::Value::Bool(b)) => return Ok(b),
            Some(_) => return Err(at(p.as_str(), format!("{n} is not a bool"))),
        }
    }
    Ok(false)
}

fn authored(stage: &usd::Stage, p: &sdf::Path, names: &[&str]) -> Result<bool> {
    for n in names {
        if value(stage, p, n)?.is_some() {
            return Ok(true);
        }
    }
    Ok(false)
}

fn arr(v: DVec3) -> Value {
    json!([v.x, v.y, v.z])
}

/// The frame as the files' keys.
fn frame_keys(f: &Frame, o: &mut Map<String, Value>) {
    if let Some(up) = f.up {
        o.insert("up_axis".into(), json!(up.name()));
    }
    if let Some(m) = f.meters_per_unit {
        o.insert("meters_per_unit".into(), json!(m));
    }
}

/// A length along the transform's scale (the cube root of its volume
/// change), for a sphere's or disk's radius.
fn scale_of(m: &DMat4) -> f64 {
    glam::DMat3::from_mat4(*m).determinant().abs().cbrt()
}

/// One UsdLux light as a light of the lights file, or `None` for a prim
/// that is not a light.
fn light(stage: &usd::Stage, p: &sdf::Path, ty: &str, name: &str) -> Result<Option<Value>> {
    let prim = p.as_str();
    let kinds = [
        "DistantLight",
        "SphereLight",
        "RectLight",
        "DiskLight",
        "DomeLight",
        "CylinderLight",
        "GeometryLight",
        "PortalLight",
        "DomeLight_1",
        "PluginLight",
    ];
    if !kinds.contains(&ty) {
        return Ok(None);
    }
    // UsdLux's inputs, and their names before the `inputs:` namespace.
    let i = |n: &'static str| -> [String; 2] { [format!("inputs:{n}"), n.to_string()] };
    let get = |n: &'static str, d: f64| -> Result<f64> {
        let names = i(n);
        num(stage, p, &[&names[0], &names[1]], d)
    };
    let has = |n: &'static str| -> Result<bool> {
        let names = i(n);
        authored(stage, p, &[&names[0], &names[1]])
    };
    let intensity = get("intensity", 1.0)?;
    let exposure = get("exposure", 0.0)?;
    let color = match value(stage, p, "inputs:color")?.or(value(stage, p, "color")?) {
        None => DVec3::ONE,
        Some(v) => stage::vec3(&v).ok_or_else(|| at(prim, "inputs:color is not a color3f"))?,
    };
    let normalize = flag(stage, p, &["inputs:normalize", "normalize"])?;
    if flag(
        stage,
        p,
        &["inputs:enableColorTemperature", "enableColorTemperature"],
    )? {
        return Err(at(
            prim,
            "enableColorTemperature is not read: give the colour as inputs:color",
        ));
    }
    for n in ["texture:file", "shaping:ies:file"] {
        if has(n)? && !(ty == "DomeLight" && n == "texture:file") {
            return Err(at(prim, format!("inputs:{n} is not read")));
        }
    }
    if has("shaping:focus")? && get("shaping:focus", 0.0)? != 0.0 {
        return Err(at(prim, "inputs:shaping:focus is not read"));
    }
    // Radiance in the light's own units (nits), before its shape.
    let l = intensity * exposure.exp2();
    let m = stage::world(stage, p)?;
    let pos = m.transform_point3(DVec3::ZERO);
    // Lights emit along their -Z.
    let ahead = m.transform_vector3(-DVec3::Z);
    let mut o = Map::new();
    o.insert("name".into(), json!(name));
    o.insert("color".into(), arr(color));
    let (kind, strength) = match ty {
        "DistantLight" => {
            let angle = get("angle", 0.53)?;
            o.insert("direction".into(), arr(ahead));
            let s = if normalize {
                l
            } else {
                l * PI * (angle.to_radians() / 2.0).sin().powi(2)
            };
            ("distant", s)
        }
        "SphereLight" => {
            let r = get("radius", 0.5)? * scale_of(&m);
            // A sphere of radiance L shows pi r^2 L towards any point;
            // normalized, its radiance is divided by its area 4 pi r^2.
            let s = if normalize { l / 4.0 } else { l * PI * r * r };
            o.insert("position".into(), arr(pos));
            let point = flag(stage, p, &["treatAsPoint"])?;
            if has("shaping:cone:angle")? {
                let cone = get("shaping:cone:angle", 90.0)?;
                let soft = get("shaping:cone:softness", 0.0)?.clamp(0.0, 1.0);
                o.insert("direction".into(), arr(ahead));
                o.insert("cone_angle".into(), json!(cone));
                o.insert("cone_delta".into(), json!(soft * cone));
                ("spot", s)
            } else if point {
                ("point", s)
            } else {
                o.insert("radius".into(), json!(r));
                ("sphere", s)
            }
        }
        "RectLight" => {
            let w = get("width", 1.0)?;
            let h = get("height", 1.0)?;
            // It faces its -Z: the edges in the order whose cross
            // product points there.
            let u = m.transform_vector3(DVec3::Y * h);
            let v = m.transform_vector3(DVec3::X * w);
            o.insert("position".into(), arr(pos));
            o.insert("u".into(), arr(u));
            o.insert("v".into(), arr(v));
            let area = u.cross(v).length();
            ("rect", if normalize { l } else { l * area })
        }
        "DiskLight" => {
            let r = get("radius", 0.5)? * scale_of(&m);
            o.insert("position".into(), arr(pos));
            o.insert("normal".into(), arr(ahead));
            o.insert("radius".into(), json!(r));
            ("disk", if normalize { l } else { l * PI * r * r })
        }
        "DomeLight" => {
            if has("texture:file")? {
                return Err(at(
                    prim,
                    "a DomeLight's inputs:texture:file is not read yet: give the map in a lights \
                     JSON file (formats/LIGHTS.md#dome)",
                ));
            }
            ("dome", l)
        }
        other => {
            return Err(at(
                prim,
                format!("a {other}: the toolkit has no such light"),
            ))
        }
    };
    o.insert("type".into(), json!(kind));
    o.insert("intensity".into(), json!(strength));
    Ok(Some(Value::Object(o)))
}

/// The stage's UsdLux lights as a lights file (formats/LIGHTS.md), in the
/// stage's frame. A light is named by its prim's name, or by its path
/// when two share a name; a stage without a light is an error.
pub fn lights_json(path: &Path) -> Result<String> {
    stage::guarded(|| lights_unguarded(path))
}

fn lights_unguarded(path: &Path) -> Result<String> {
    let (file, root) = stage::split_prim(path);
    let stage = stage::open(file)?;
    let frame = stage::frame(&stage, true)?;
    let prims = stage::prims_under(&stage, root)?;
    let mut found = Vec::new();
    for p in &prims {
        let ty = stage::type_name(&stage, p)?;
        found.push((p, ty));
    }
    let short = |p: &sdf::Path| p.name().unwrap_or(p.as_str()).to_string();
    let mut lights = Vec::new();
    for (p, ty) in &found {
        let twice = found
            .iter()
            .filter(|(q, t)| t.ends_with("Light") && short(q) == short(p))
            .count()
            > 1;
        let name = if twice {
            p.as_str().to_string()
        } else {
            short(p)
        };
        if let Some(l) = light(&stage, p, ty, &name)? {
            lights.push(l);
        }
    }
    if lights.is_empty() {
        return Err(Error::invalid("no UsdLux light on the stage"));
    }
    let mut o = Map::new();
    o.insert("lights".into(), Value::Array(lights));
    frame_keys(&frame, &mut o);
    stage::finish(&stage)?;
    Ok(Value::Object(o).to_string())
}

/// A stage's UsdGeomCamera (the one at the path after `:`, else the
/// stage's only one) as a camera file (formats/CAMERA.md): the eye at
/// its origin, looking down its -Z with its +Y up, the vertical field of
/// view from `verticalAperture` and `focalLength`, and a picture whose
/// width over height is the apertures' (`height` pixels high).
pub fn camera_json(path: &Path, height: u32) -> Result<String> {
    stage::guarded(|| camera_unguarded(path, height))
}

fn camera_unguarded(path: &Path, height: u32) -> Result<String> {
    let (file, root) = stage::split_prim(path);
    let stage = stage::open(file)?;
    let frame = stage::frame(&stage, true)?;
    let mut cams = Vec::new();
    for p in stage::prims_under(&stage, root)? {
        if stage::type_name(&stage, &p)? == "Camera" {
            cams.push(p);
        }
    }
    let p = match cams.as_slice() {
        [p] => p,
        [] => return Err(Error::invalid("no UsdGeomCamera on the stage")),
        many => {
            let names: Vec<_> = many.iter().map(|p| p.as_str()).collect();
            return Err(Error::invalid(format!(
                "{} cameras ({}): name one as FILE:/path/to/camera",
                many.len(),
                names.join(", ")
            )));
        }
    };
    let prim = p.as_str();
    let token = |n: &str| -> Result<Option<String>> {
        Ok(value(&stage, p, n)?.as_ref().and_then(stage::token))
    };
    if token("projection")?.is_some_and(|t| t != "perspective") {
        return Err(at(
            prim,
            "an orthographic camera: the toolkit's camera is a pinhole",
        ));
    }
    for n in ["horizontalApertureOffset", "verticalApertureOffset"] {
        if num(&stage, p, &[n], 0.0)? != 0.0 {
            return Err(at(prim, format!("{n} is not read")));
        }
    }
    let focal = num(&stage, p, &["focalLength"], 50.0)?;
    let h_ap = num(&stage, p, &["horizontalAperture"], 20.955)?;
    let v_ap = num(&stage, p, &["verticalAperture"], 15.2908)?;
    if !(focal > 0.0 && h_ap > 0.0 && v_ap > 0.0) {
        return Err(at(prim, "focalLength and the apertures must be > 0"));
    }
    let m = stage::world(&stage, p)?;
    let eye = m.transform_point3(DVec3::ZERO);
    let ahead = m.transform_vector3(-DVec3::Z).normalize();
    let up = m.transform_vector3(DVec3::Y);
    let (width, height, v_ap) = match render_settings(&stage, p)? {
        Some(s) => (s.width, s.height, s.conform(h_ap, v_ap)),
        None => (
            ((height as f64) * h_ap / v_ap).round().clamp(1.0, 16384.0) as u32,
            height,
            v_ap,
        ),
    };
    let fov = 2.0 * (v_ap / (2.0 * focal)).atan().to_degrees();
    let mut o = Map::new();
    o.insert("position".into(), arr(eye));
    o.insert("look_at".into(), arr(eye + ahead));
    o.insert("up".into(), arr(up));
    o.insert("fov".into(), json!(fov));
    o.insert("width".into(), json!(width));
    o.insert("height".into(), json!(height));
    frame_keys(&frame, &mut o);
    stage::finish(&stage)?;
    Ok(Value::Object(o).to_string())
}

/// A `UsdRenderSettings` prim's picture for a camera: its `resolution`
/// and how the camera's aperture is made to fit it.
struct Settings {
    width: u32,
    height: u32,
    /// `expandAperture` (USD's fallback): the aperture grows on one side
    /// to the picture's aspect; `cropAperture`: it shrinks.
    expand: bool,
}

impl Settings {
    /// The vertical aperture the picture sees, from the camera's apertures
    /// `h_ap` by `v_ap`.
    fn conform(&self, h_ap: f64, v_ap: f64) -> f64 {
        let image = self.width as f64 / self.height as f64;
        let taller = image < h_ap / v_ap;
        // Expanded, a taller picture gets more vertical aperture; cropped,
        // a wider one gets less.
        if taller == self.expand {
            h_ap / image
        } else {
            v_ap
        }
    }
}

/// The render settings that name camera `cam`: the stage's own
/// (`renderSettingsPrimPath`) when it names the camera, else the one
/// `RenderSettings` prim that does (two or more: an error naming them);
/// `None` when none does (the picture then follows the apertures).
fn render_settings(stage: &usd::Stage, cam: &sdf::Path) -> Result<Option<Settings>> {
    let mut naming = Vec::new();
    for p in stage::prims(stage)? {
        if stage::type_name(stage, &p)? != "RenderSettings" {
            continue;
        }
        let targets = stage
            .prim(p.clone())
            .relationship("camera")
            .targets()
            .map_err(stage::usd_err)?;
        if targets.iter().any(|t| t == cam) {
            naming.push(p);
        }
    }
    let chosen = match stage
        .stage_metadata("renderSettingsPrimPath")
        .map_err(stage::usd_err)?
    {
        Some(v) => stage::token(&v).and_then(|s| naming.iter().find(|p| p.as_str() == s).cloned()),
        None => None,
    };
    let p = match (chosen, naming.as_slice()) {
        (Some(p), _) => p,
        (None, []) => return Ok(None),
        (None, [p]) => p.clone(),
        (None, many) => {
            let names: Vec<_> = many.iter().map(|p| p.as_str()).collect();
            return Err(Error::invalid(format!(
                "{} render settings name camera {} ({}): say which with the stage's renderSettingsPrimPath",
                many.len(),
                cam.as_str(),
                names.join(", ")
            )));
        }
    };
    let prim = p.as_str();
    // USD's fallback resolution.
    let (w, h) = match value(stage, &p, "resolution")? {
        None => (2048, 1080),
        Some(sdf::Value::Vec2i(r)) => (r.x, r.y),
        Some(_) => return Err(at(prim, "resolution is not an int2")),
    };
    if !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
        return Err(at(
            prim,
            format!("resolution ({w}, {h}): each side 1 to 16384"),
        ));
    }
    let aspect = num(stage, &p, &["pixelAspectRatio"], 1.0)?;
    if aspect != 1.0 {
        return Err(at(
            prim,
            format!("pixelAspectRatio {aspect}: the toolkit's pixels are square"),
        ));
    }
    let policy = value(stage, &p, "aspectRatioConformPolicy")?
        .as_ref()
        .and_then(stage::token)
        .unwrap_or_else(|| "expandAperture".into());
    let expand = match policy.as_str() {
        "expandAperture" => true,
        "cropAperture" => false,
        other => {
            return Err(at(
                prim,
                format!(
                    "aspectRatioConformPolicy {other}: expandAperture and cropAperture are read"
                ),
            ))
        }
    };
    Ok(Some(Settings {
        width: w as u32,
        height: h as u32,
        expand,
    }))
}
