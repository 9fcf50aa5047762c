//! Lights: the JSON file (`formats/LIGHTS.md`), its validation, the light
//! mask, and the light arriving at a point from each light.
//!
//! Every light delivers `Cl = color * intensity` times its distance falloff
//! (point, spot and area lights: `1 / d^2` or none) and its shape (spot
//! cone, emitter cosine). An area light is a point light spread over its
//! surface: its `samples` points share `Cl` equally, each weighted by the
//! emitter's cosine (rectangle, disk: Lambertian, one- or two-sided;
//! sphere: the hemisphere facing the receiver, Lambertian), so that far
//! away every area light equals the point light at its centre.

pub mod dome;
mod file;
pub mod shadow;

pub use file::{parse, parse_file, parse_file_in};

use std::f64::consts::PI;

use glam::DVec3;
use globset::{Glob, GlobMatcher};
use serde::Deserialize;

use crate::error::{Error, Result};
use crate::frame::{Change, Frame};
use crate::maths::smoothstep;
use dome::Dome;

/// Distance falloff of point, spot and area lights.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Falloff {
    None,
    #[default]
    InverseSquare,
}

/// A lights file: its lights and the frame it states they are in.
#[derive(Clone, Debug, PartialEq)]
pub struct LightsFile {
    pub lights: Vec<Light>,
    pub frame: Frame,
}

impl LightsFile {
    /// The lights moved into the frame `to` (a cloud's): positions
    /// rotated between up axes and scaled between units, directions
    /// rotated, and `Cl` of a light that falls off with distance scaled
    /// by the square of the units' ratio, so that the irradiance at a
    /// point of the scene stays what it was.
    pub fn in_frame(&self, to: &Frame) -> Vec<Light> {
        let c = self.frame.change_to(to);
        self.lights.iter().map(|l| l.in_frame(&c)).collect()
    }
}

/// A light's shape.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// Light travelling along `-to_light`.
    Distant {
        to_light: DVec3,
    },
    Point {
        position: DVec3,
    },
    Spot {
        position: DVec3,
        axis: DVec3,
        cos_outside: f64,
        cos_inside: f64,
        beam: f64,
    },
    Rect {
        centre: DVec3,
        u: DVec3,
        v: DVec3,
        normal: DVec3,
        two_sided: bool,
    },
    Disk {
        centre: DVec3,
        normal: DVec3,
        radius: f64,
        two_sided: bool,
    },
    Sphere {
        centre: DVec3,
        radius: f64,
    },
    /// Radiance `Cl` (times the map's) from every direction.
    Dome(Dome),
}

/// A validated light.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    pub name: String,
    /// Its place in the file.
    pub id: u32,
    /// `color * intensity`.
    pub cl: DVec3,
    pub shape: Shape,
    pub falloff: Falloff,
    /// Points on the light per receiver (1 for distant, point, spot).
    pub samples: u32,
}

/// The lights' fingerprint: XXH3-128 of everything they are (names,
/// colours, shapes, falloffs, samples), in 32 hex digits. Recorded by the
/// stages that use them, so that clouds lit otherwise are told apart.
pub fn digest(lights: &[Light]) -> String {
    format!(
        "{:032x}",
        xxhash_rust::xxh3::xxh3_128(format!("{lights:?}").as_bytes())
    )
}

/// The most samples an area light may ask for.
pub const MAX_SAMPLES: u32 = 1 << 16;

/// The patterns of a light mask: separated by commas or spaces, except
/// inside `{...}` (a glob's alternatives) and inside double quotes (a name
/// with spaces or commas: `"key light"`; the quotes are dropped). An
/// unclosed brace or quote is an error.
fn mask_patterns(patterns: &str) -> Result<Vec<String>> {
    let (mut out, mut cur, mut depth, mut quoted) = (Vec::new(), String::new(), 0u32, false);
    for c in patterns.chars() {
        match c {
            '"' => quoted = !quoted,
            '{' if !quoted => {
                depth += 1;
                cur.push(c);
            }
            '}' if !quoted && depth > 0 => {
                depth -= 1;
                cur.push(c);
            }
            c if !quoted && depth == 0 && (c == ',' || c.is_whitespace()) => {
                if !cur.is_empty() {
                    out.push(std::mem::take(&mut cur));
                }
            }
            c => cur.push(c),
        }
    }
    if quoted || depth > 0 {
        let what = if quoted { "a quote" } else { "a brace" };
        return Err(Error::param(
            "lmask",
            format!("'{patterns}': {what} is not closed"),
        ));
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    Ok(out)
}

/// The light mask (Houdini's `lmask`): names and glob patterns separated
/// by commas or spaces (not inside `{a,b}` or double quotes); a pattern
/// starting with `^` excludes. A light is used when it matches some
/// including pattern (all lights when there is none) and no excluding
/// one. Returns the indices of the lights used.
pub fn mask(lights: &[Light], patterns: &str) -> Result<Vec<usize>> {
    let mut include: Vec<GlobMatcher> = Vec::new();
    let mut exclude: Vec<GlobMatcher> = Vec::new();
    for p in mask_patterns(patterns)? {
        let p = p.as_str();
        let (list, pat) = match p.strip_prefix('^') {
            Some(rest) => (&mut exclude, rest),
            None => (&mut include, p),
        };
        let g = Glob::new(pat)
            .map_err(|e| Error::param("lmask", format!("'{p}': {e}")))?
            .compile_matcher();
        list.push(g);
    }
    let used: Vec<usize> = (0..lights.len())
        .filter(|&i| {
            let n = lights[i].name.as_str();
            (include.is_empty() || include.iter().any(|g| g.is_match(n)))
                && !exclude.iter().any(|g| g.is_match(n))
        })
        .collect();
    if used.is_empty() {
        let names: Vec<&str> = lights.iter().map(|l| l.name.as_str()).collect();
        return Err(Error::param(
            "lmask",
            format!(
                "'{patterns}' selects no light (the lights are: {})",
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                }
            ),
        ));
    }
    Ok(used)
}

/// One ray's worth of light at a receiver: the unit direction to the
/// light, the distance (infinite for a distant light), and the irradiance
/// it brings if unoccluded (`Cl` times falloff, shape and the receiver's
/// cosine).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arrival {
    pub dir: DVec3,
    pub dist: f64,
    pub e: DVec3,
}

/// A rank-1 lattice point (Fibonacci-like, golden ratio) `k` of `n`,
/// shifted by `(r1, r2)` modulo 1 (Cranley-Patterson rotation): evenly
/// spread for any `n`.
#[inline]
pub fn lattice(k: u32, n: u32, r1: f64, r2: f64) -> (f64, f64) {
    const PHI: f64 = 0.618_033_988_749_894_8;
    let a = (k as f64 + r1) / n as f64;
    let b = (k as f64 * PHI + r2).fract();
    (a.min(1.0 - f64::EPSILON / 2.0), b)
}

impl Light {
    /// This light after the change of frame `c` (see [`LightsFile::in_frame`]).
    pub fn in_frame(&self, c: &Change) -> Light {
        if c.is_identity() {
            return self.clone();
        }
        let (p, v) = (|q: DVec3| c.point(q), |d: DVec3| c.vector(d));
        let shape = match &self.shape {
            Shape::Distant { to_light } => Shape::Distant {
                to_light: v(*to_light),
            },
            Shape::Point { position } => Shape::Point {
                position: p(*position),
            },
            Shape::Spot {
                position,
                axis,
                cos_outside,
                cos_inside,
                beam,
            } => Shape::Spot {
                position: p(*position),
                axis: v(*axis),
                cos_outside: *cos_outside,
                cos_inside: *cos_inside,
                beam: *beam,
            },
            Shape::Rect {
                centre,
                u,
                v: dv,
                normal,
                two_sided,
            } => Shape::Rect {
                centre: p(*centre),
                u: p(*u),
                v: p(*dv),
                normal: v(*normal),
                two_sided: *two_sided,
            },
            Shape::Disk {
                centre,
                normal,
                radius,
                two_sided,
            } => Shape::Disk {
                centre: p(*centre),
                normal: v(*normal),
                radius: c.length(*radius),
                two_sided: *two_sided,
            },
            Shape::Sphere { centre, radius } => Shape::Sphere {
                centre: p(*centre),
                radius: c.length(*radius),
            },
            Shape::Dome(d) => Shape::Dome(Dome {
                map: d.map.clone(),
                up: v(d.up),
                zero: v(d.zero),
                right: v(d.right),
            }),
        };
        let cl = match self.falloff {
            Falloff::InverseSquare => self.cl * (c.scale * c.scale),
            Falloff::None => self.cl,
        };
        Light {
            shape,
            cl,
            ..self.clone()
        }
    }

    fn falloff_at(&self, d2: f64) -> f64 {
        match self.falloff {
            Falloff::None => 1.0,
            Falloff::InverseSquare => 1.0 / d2,
        }
    }

    /// Light from a point `q` of the light with emitter weight `w` at the
    /// receiver `p` with unit normal `n`, for one of `share` samples.
    #[inline]
    fn arrival_from(&self, p: DVec3, n: DVec3, q: DVec3, w: f64, share: f64) -> Option<Arrival> {
        let to = q - p;
        let d2 = to.length_squared();
        if d2.is_nan() || d2 <= 0.0 {
            return None;
        }
        let dist = d2.sqrt();
        let dir = to / dist;
        let cos = n.dot(dir);
        if cos <= 0.0 || w <= 0.0 {
            return None;
        }
        Some(Arrival {
            dir,
            dist,
            e: self.cl * (cos * w * share * self.falloff_at(d2)),
        })
    }

    /// Every sample of this light that can reach the receiver at `p` with
    /// unit normal `n` (none that faces away or falls outside a cone):
    /// `r1, r2` shift the area light's sample lattice.
    pub fn arrivals(&self, p: DVec3, n: DVec3, r1: f64, r2: f64, out: &mut Vec<Arrival>) {
        out.clear();
        let share = 1.0 / self.samples as f64;
        self.points(p, Some(n), r1, r2, |at| match at {
            LightPoint::Towards(to_light, w) => {
                let cos = n.dot(to_light);
                if cos > 0.0 {
                    out.push(Arrival {
                        dir: to_light,
                        dist: f64::INFINITY,
                        e: self.cl * w * (cos * share),
                    });
                }
            }
            LightPoint::At { q, w, area } => {
                let share = if area { share } else { 1.0 };
                out.extend(self.arrival_from(p, n, q, w, share));
            }
        });
    }

    /// The light each sample of this light sends to a point `p` inside a
    /// medium (no receiver cosine, no shadow test; `sssingle`): an area
    /// light's samples each with the whole `Cl` (their mean is the light),
    /// none that sends nothing (outside a spot's cone, a one-sided emitter
    /// facing away). `r1, r2` shift the area light's lattice.
    pub fn emissions(&self, p: DVec3, r1: f64, r2: f64, out: &mut Vec<Arrival>) {
        out.clear();
        self.points(p, None, r1, r2, |at| match at {
            LightPoint::Towards(to_light, w) => out.push(Arrival {
                dir: to_light,
                dist: f64::INFINITY,
                e: self.cl * w,
            }),
            LightPoint::At { q, w, .. } => {
                let to = q - p;
                let d2 = to.length_squared();
                if w > 0.0 && d2 > 0.0 && d2.is_finite() {
                    let dist = d2.sqrt();
                    out.push(Arrival {
                        dir: to / dist,
                        dist,
                        e: self.cl * (w * self.falloff_at(d2)),
                    });
                }
            }
        });
    }

    /// The points of this light as seen from `p` (with normal `n`, or a
    /// point inside a medium), in order: a distant light's direction, a
    /// point or spot light's position, an area light's lattice of
    /// `samples` points (shifted by `r1, r2`), each with its emitter
    /// weight towards `p`, a dome's `samples` directions drawn from the
    /// same lattice, each with its `L / pdf`.
    fn points(&self, p: DVec3, n: Option<DVec3>, r1: f64, r2: f64, mut f: impl FnMut(LightPoint)) {
        match &self.shape {
            Shape::Distant { to_light } => f(LightPoint::Towards(*to_light, DVec3::ONE)),
            Shape::Point { position } => f(LightPoint::At {
                q: *position,
                w: 1.0,
                area: false,
            }),
            Shape::Spot {
                position,
                axis,
                cos_outside,
                cos_inside,
                beam,
            } => {
                let from = (p - *position).normalize_or_zero();
                let c = from.dot(*axis);
                let edge = smoothstep(*cos_outside, *cos_inside, c);
                if edge > 0.0 {
                    let w = edge
                        * if *beam > 0.0 {
                            c.max(0.0).powf(*beam)
                        } else {
                            1.0
                        };
                    f(LightPoint::At {
                        q: *position,
                        w,
                        area: false,
                    });
                }
            }
            Shape::Rect {
                centre,
                u,
                v,
                normal,
                two_sided,
            } => {
                for k in 0..self.samples {
                    let (a, b) = lattice(k, self.samples, r1, r2);
                    let q = *centre + *u * (a - 0.5) + *v * (b - 0.5);
                    let w = emitter_cos(*normal, p - q, *two_sided);
                    f(LightPoint::At { q, w, area: true });
                }
            }
            Shape::Disk {
                centre,
                normal,
                radius,
                two_sided,
            } => {
                let (t1, t2) = crate::geom::tangent_basis(*normal);
                for k in 0..self.samples {
                    let (a, b) = lattice(k, self.samples, r1, r2);
                    let (rho, phi) = (*radius * a.sqrt(), 2.0 * PI * b);
                    let q = *centre + t1 * (rho * phi.cos()) + t2 * (rho * phi.sin());
                    let w = emitter_cos(*normal, p - q, *two_sided);
                    f(LightPoint::At { q, w, area: true });
                }
            }
            Shape::Sphere { centre, radius } => {
                let axis = p - *centre;
                if axis.length() <= *radius {
                    return; // inside the light: documented as dark
                }
                let axis = axis.normalize();
                let (t1, t2) = crate::geom::tangent_basis(axis);
                for k in 0..self.samples {
                    // Cosine-weighted on the hemisphere facing the
                    // receiver (uniform on its projected disk): the
                    // `2 cos` emitter weight over the uniform density
                    // becomes `cos_emit / z`, which is 1 far away.
                    let (a, b) = lattice(k, self.samples, r1, r2);
                    let (rho, phi) = (a.sqrt(), 2.0 * PI * b);
                    let z = (1.0 - rho * rho).max(0.0).sqrt();
                    if z <= 0.0 {
                        continue;
                    }
                    let m = axis * z + t1 * (rho * phi.cos()) + t2 * (rho * phi.sin());
                    let q = *centre + m * *radius;
                    let w = emitter_cos(m, p - q, false) / z;
                    f(LightPoint::At { q, w, area: true });
                }
            }
            Shape::Dome(dome) => {
                for k in 0..self.samples {
                    let (a, b) = lattice(k, self.samples, r1, r2);
                    if let Some(d) = dome.draw(a, b, n) {
                        f(LightPoint::Towards(d.dir, d.weight));
                    }
                }
            }
        }
    }
}

/// A point of a light as a receiver sees it: a direction to light at
/// infinity with its weight (a distant light's 1, a dome direction's
/// `L / pdf`), or a point `q` of the light with its emitter weight `w`
/// (`area`: one of an area light's samples).
enum LightPoint {
    Towards(DVec3, DVec3),
    At { q: DVec3, w: f64, area: bool },
}

/// The emitter's cosine towards `to_receiver` (0 behind a one-sided one).
#[inline]
fn emitter_cos(normal: DVec3, to_receiver: DVec3, two_sided: bool) -> f64 {
    let c = normal.dot(to_receiver.normalize_or_zero());
    if two_sided {
        c.abs()
    } else {
        c.max(0.0)
    }
}
