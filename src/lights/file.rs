//! The lights file's text: its keys as serde reads them (every key
//! checked, unknown ones refused), each light validated into a [`Light`],
//! a dome's map read beside the file.

use std::path::Path;
use std::sync::Arc;

use glam::DVec3;
use serde::Deserialize;

use super::dome::{Dome, LatLong};
use super::{Falloff, Light, LightsFile, Shape, MAX_SAMPLES};
use crate::error::{Error, Result};
use crate::frame::{Frame, UpAxis};
fn white() -> [f64; 3] {
    [1.0; 3]
}
fn one() -> f64 {
    1.0
}
fn default_samples() -> u32 {
    16
}
fn default_cone() -> f64 {
    30.0
}
fn default_delta() -> f64 {
    5.0
}
fn default_dome_samples() -> u32 {
    64
}

/// A light as the file writes it. Every variant repeats `name`, `color`
/// and `intensity`: serde cannot `flatten` a shared struct into an
/// internally tagged enum and still refuse unknown keys.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
enum Spec {
    Distant {
        name: String,
        #[serde(default = "white")]
        color: [f64; 3],
        #[serde(default = "one")]
        intensity: f64,
        /// The direction light travels in.
        direction: [f64; 3],
    },
    Point {
        name: String,
        #[serde(default = "white")]
        color: [f64; 3],
        #[serde(default = "one")]
        intensity: f64,
        position: [f64; 3],
        #[serde(default)]
        falloff: Falloff,
    },
    Spot {
        name: String,
        #[serde(default = "white")]
        color: [f64; 3],
        #[serde(default = "one")]
        intensity: f64,
        position: [f64; 3],
        /// The cone's axis (where the spot points).
        direction: [f64; 3],
        #[serde(default)]
        falloff: Falloff,
        /// Half-angle of the cone, degrees.
        #[serde(default = "default_cone")]
        cone_angle: f64,
        /// Width of the soft edge inside the cone, degrees.
        #[serde(default = "default_delta")]
        cone_delta: f64,
        /// Exponent of `cos(angle to axis)` inside the cone.
        #[serde(default)]
        beam_distribution: f64,
    },
    Rect {
        name: String,
        #[serde(default = "white")]
        color: [f64; 3],
        #[serde(default = "one")]
        intensity: f64,
        /// Centre.
        position: [f64; 3],
        /// Edge vectors: the rectangle is `position + s u + t v`,
        /// `s, t` in [-1/2, 1/2]; it emits along `u x v`.
        u: [f64; 3],
        v: [f64; 3],
        #[serde(default)]
        falloff: Falloff,
        #[serde(default = "default_samples")]
        samples: u32,
        #[serde(default)]
        two_sided: bool,
    },
    Disk {
        name: String,
        #[serde(default = "white")]
        color: [f64; 3],
        #[serde(default = "one")]
        intensity: f64,
        position: [f64; 3],
        /// The side it emits towards.
        normal: [f64; 3],
        radius: f64,
        #[serde(default)]
        falloff: Falloff,
        #[serde(default = "default_samples")]
        samples: u32,
        #[serde(default)]
        two_sided: bool,
    },
    Sphere {
        name: String,
        #[serde(default = "white")]
        color: [f64; 3],
        #[serde(default = "one")]
        intensity: f64,
        position: [f64; 3],
        radius: f64,
        #[serde(default)]
        falloff: Falloff,
        #[serde(default = "default_samples")]
        samples: u32,
    },
    Dome {
        name: String,
        #[serde(default = "white")]
        color: [f64; 3],
        #[serde(default = "one")]
        intensity: f64,
        /// A lat-long OpenEXR map, relative to the lights file.
        #[serde(default)]
        map: Option<String>,
        /// Degrees about the up axis.
        #[serde(default)]
        rotation: f64,
        #[serde(default = "default_dome_samples")]
        samples: u32,
    },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSpec {
    lights: Vec<Spec>,
    #[serde(default)]
    up_axis: Option<UpAxis>,
    #[serde(default)]
    meters_per_unit: Option<f64>,
}

/// Reads and validates a lights file's text; `file` names it in errors.
pub fn parse(text: &str, file: &str) -> Result<Vec<Light>> {
    Ok(parse_file(text, file)?.lights)
}

/// Reads and validates a lights file's text with the frame it states. A
/// dome's map is not read: a file with one is refused (see
/// [`parse_file_in`]).
pub fn parse_file(text: &str, file: &str) -> Result<LightsFile> {
    parse_file_in(text, file, None)
}

/// Reads and validates a lights file's text, reading a dome's map from
/// the file's folder `dir`.
pub fn parse_file_in(text: &str, file: &str, dir: Option<&Path>) -> Result<LightsFile> {
    let spec: FileSpec = crate::error::from_json(text, file)?;
    let frame = Frame {
        up: spec.up_axis,
        meters_per_unit: spec.meters_per_unit,
    };
    frame
        .check()
        .map_err(|why| Error::invalid(format!("{file} at meters_per_unit: {why}")))?;
    let mut out = Vec::with_capacity(spec.lights.len());
    for (i, s) in spec.lights.into_iter().enumerate() {
        let mut light = validate(s, dir).map_err(|(key, why)| match key {
            OUTPUT => Error::param("output", why),
            _ => Error::invalid(format!("{file} at lights[{i}].{key}: {why}")),
        })?;
        light.id = i as u32;
        if let Some(j) = out.iter().position(|l: &Light| l.name == light.name) {
            return Err(Error::invalid(format!(
                "{file} at lights[{i}].name: '{}' is already the name of lights[{j}]",
                light.name
            )));
        }
        // A dome's map has its top at the file's up axis.
        if let (Shape::Dome(d), Some(UpAxis::Z)) = (&mut light.shape, frame.up) {
            let c = Frame {
                up: Some(UpAxis::Y),
                meters_per_unit: None,
            }
            .change_to(&frame);
            (d.up, d.zero, d.right) = (c.vector(d.up), c.vector(d.zero), c.vector(d.right));
        }
        out.push(light);
    }
    Ok(LightsFile { lights: out, frame })
}

type Check<T> = std::result::Result<T, (&'static str, String)>;

/// The key of a [`Check`] error that is the output's fault, not the
/// file's: a file the lights file names is one of the run's outputs.
const OUTPUT: &str = "\0output";

fn finite3(key: &'static str, v: [f64; 3]) -> Check<DVec3> {
    let d = DVec3::from_array(v);
    if d.is_finite() {
        Ok(d)
    } else {
        Err((key, format!("{v:?} is not finite")))
    }
}

/// `d` made unit length, scaled by its largest component first: a vector
/// like [1e300, 1e300, 0] or [1e-300, 0, 0] has a length f64 cannot
/// square. Zero for the zero vector.
fn direction(d: DVec3) -> DVec3 {
    let m = d.abs().max_element();
    if m > 0.0 && m.is_finite() {
        (d / m).normalize_or_zero()
    } else {
        DVec3::ZERO
    }
}

fn unit3(key: &'static str, v: [f64; 3]) -> Check<DVec3> {
    let n = direction(finite3(key, v)?);
    if n == DVec3::ZERO {
        Err((key, format!("{v:?} has no direction")))
    } else {
        Ok(n)
    }
}

fn positive(key: &'static str, x: f64) -> Check<f64> {
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err((key, format!("{x} is not a finite number > 0")))
    }
}

fn samples_ok(n: u32) -> Check<u32> {
    if (1..=MAX_SAMPLES).contains(&n) {
        Ok(n)
    } else {
        Err(("samples", format!("{n} is not in 1..={MAX_SAMPLES}")))
    }
}

/// The name, checked, and `Cl = color * intensity`.
fn common(name: String, color: [f64; 3], intensity: f64) -> Check<(String, DVec3)> {
    if name.is_empty() {
        return Err(("name", "is empty".into()));
    }
    let col = DVec3::from_array(color);
    if !(col.is_finite() && col.min_element() >= 0.0) {
        return Err(("color", format!("{color:?} is not finite and >= 0")));
    }
    if !(intensity.is_finite() && intensity >= 0.0) {
        return Err(("intensity", format!("{intensity} is not finite and >= 0")));
    }
    Ok((name, col * intensity))
}

/// A dome's map, read from `dir` (none: the text came from no file).
fn read_map(map: &str, dir: Option<&Path>) -> Check<Arc<LatLong>> {
    let Some(dir) = dir else {
        return Err((
            "map",
            format!("'{map}': a map is read beside a lights file on disk"),
        ));
    };
    let path = dir.join(map);
    let bytes = crate::files::read_input_of(
        &path,
        crate::formats::texture::MAX_FILE,
        "a dome map (an OpenEXR image)",
        &[crate::formats::texture::EXR],
    )
    .map_err(|e| match e {
        // The map is one of the run's outputs: the output's fault.
        Error::Param { what, .. } => (OUTPUT, what),
        e => ("map", e.about(&path.display().to_string()).to_string()),
    })?;
    let (w, h, texels) = crate::formats::exr::read::read_rgb_image(&bytes)
        .map_err(|e| ("map", format!("{}: {e}", path.display())))?;
    LatLong::new(w, h, texels, map)
        .map(Arc::new)
        .map_err(|why| ("map", format!("{}: {why}", path.display())))
}

fn validate(s: Spec, dir: Option<&Path>) -> Check<Light> {
    Ok(match s {
        Spec::Distant {
            name,
            color,
            intensity,
            direction,
        } => {
            let (name, cl) = common(name, color, intensity)?;
            Light {
                name,
                id: 0,
                cl,
                shape: Shape::Distant {
                    to_light: -unit3("direction", direction)?,
                },
                falloff: Falloff::None,
                samples: 1,
            }
        }
        Spec::Point {
            name,
            color,
            intensity,
            position,
            falloff,
        } => {
            let (name, cl) = common(name, color, intensity)?;
            Light {
                name,
                id: 0,
                cl,
                shape: Shape::Point {
                    position: finite3("position", position)?,
                },
                falloff,
                samples: 1,
            }
        }
        Spec::Spot {
            name,
            color,
            intensity,
            position,
            direction,
            falloff,
            cone_angle,
            cone_delta,
            beam_distribution,
        } => {
            let (name, cl) = common(name, color, intensity)?;
            if !(cone_angle.is_finite() && cone_angle > 0.0 && cone_angle <= 180.0) {
                return Err(("cone_angle", format!("{cone_angle} is not in (0, 180]")));
            }
            if !(cone_delta.is_finite() && cone_delta >= 0.0 && cone_delta <= cone_angle) {
                return Err((
                    "cone_delta",
                    format!("{cone_delta} is not in [0, cone_angle = {cone_angle}]"),
                ));
            }
            if !(beam_distribution.is_finite() && beam_distribution >= 0.0) {
                return Err((
                    "beam_distribution",
                    format!("{beam_distribution} is not finite and >= 0"),
                ));
            }
            Light {
                name,
                id: 0,
                cl,
                shape: Shape::Spot {
                    position: finite3("position", position)?,
                    axis: unit3("direction", direction)?,
                    cos_outside: cone_angle.to_radians().cos(),
                    cos_inside: (cone_angle - cone_delta).to_radians().cos(),
                    beam: beam_distribution,
                },
                falloff,
                samples: 1,
            }
        }
        Spec::Rect {
            name,
            color,
            intensity,
            position,
            u,
            v,
            falloff,
            samples,
            two_sided,
        } => {
            let (name, cl) = common(name, color, intensity)?;
            let (du, dv) = (finite3("u", u)?, finite3("v", v)?);
            let normal = direction(direction(du).cross(direction(dv)));
            if normal == DVec3::ZERO {
                return Err(("v", format!("u = {u:?} and v = {v:?} span no area")));
            }
            Light {
                name,
                id: 0,
                cl,
                shape: Shape::Rect {
                    centre: finite3("position", position)?,
                    u: du,
                    v: dv,
                    normal,
                    two_sided,
                },
                falloff,
                samples: samples_ok(samples)?,
            }
        }
        Spec::Disk {
            name,
            color,
            intensity,
            position,
            normal,
            radius,
            falloff,
            samples,
            two_sided,
        } => {
            let (name, cl) = common(name, color, intensity)?;
            Light {
                name,
                id: 0,
                cl,
                shape: Shape::Disk {
                    centre: finite3("position", position)?,
                    normal: unit3("normal", normal)?,
                    radius: positive("radius", radius)?,
                    two_sided,
                },
                falloff,
                samples: samples_ok(samples)?,
            }
        }
        Spec::Sphere {
            name,
            color,
            intensity,
            position,
            radius,
            falloff,
            samples,
        } => {
            let (name, cl) = common(name, color, intensity)?;
            Light {
                name,
                id: 0,
                cl,
                shape: Shape::Sphere {
                    centre: finite3("position", position)?,
                    radius: positive("radius", radius)?,
                },
                falloff,
                samples: samples_ok(samples)?,
            }
        }
        Spec::Dome {
            name,
            color,
            intensity,
            map,
            rotation,
            samples,
        } => {
            let (name, cl) = common(name, color, intensity)?;
            if !rotation.is_finite() {
                return Err(("rotation", format!("{rotation} is not finite")));
            }
            let samples = samples_ok(samples)?;
            let map = match map {
                Some(m) => Some(read_map(&m, dir)?),
                None => None,
            };
            Light {
                name,
                id: 0,
                cl,
                shape: Shape::Dome(Dome::new(map, rotation)),
                falloff: Falloff::None,
                samples,
            }
        }
    })
}
