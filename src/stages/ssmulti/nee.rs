//! The lights sampled at a walk's scattering events (`ssmulti --method
//! walk --lights`, `docs/DESIGN.md#the-light-a-walk-takes`): next-event
//! estimation, as a path tracer takes direct light inside a medium.
//!
//! At each event of two or more (single scattering is sssingle's), for
//! each light: one of its samples (a distant light's direction, a point
//! light's place, a point of an area light), the straight line from the
//! event towards it to where it leaves the mesh (through a dielectric, the
//! line that refracts towards the light there, found by a few steps with
//! the face it meets), `e^(-sigma_t s)` along it, Fresnel's transmittance
//! out, the shadow ray on from there (`lights::shadow`, through the medium
//! where it crosses the mesh again), and the phase function between the
//! walk's direction and the line.
//!
//! The cloud's `illum` holds the same lights; a walk that samples them
//! follows the light between surfaces itself (it flies on through the air
//! where it leaves and walks on where it comes back in:
//! [`crate::medium::mesh_walk::Walker::reentering`]) and takes, where it
//! leaves under the sky, the constant domes' radiance. Domes are not
//! sampled.

use std::f64::consts::PI;

use glam::DVec3;
use rand_pcg::Pcg32;

use crate::cloud::{Cloud, DetailValue};
use crate::error::{Error, Result};
use crate::geom::bvh::Facing;
use crate::geom::mesh::TriMesh;
use crate::lights::shadow::{Passage, Shadows};
use crate::lights::{Arrival, Light, Shape};
use crate::maths::uniform53;
use crate::medium::mesh_walk::{Event, Walker};
use crate::medium::Medium;
use crate::optics::{fresnel, hg, refract};

/// Steps that find, through a dielectric, the line from an event that
/// refracts towards the light where it leaves.
const STEPS: usize = 4;

/// The lights a run samples and the shadows they cast.
pub struct Sampled<'a> {
    lights: Vec<Light>,
    shadows: Shadows<'a>,
}

impl<'a> Sampled<'a> {
    /// The lights of `lights` but its domes, for a walk through `mesh`
    /// (BVH `occ`) in `medium` (the shadows' passage through the mesh).
    /// They must be the lights `illum` lit `cloud` with (its
    /// `illum_lights_digest`), else the cloud's light and the sampled
    /// light would not add up; a dome with a map is refused (its light
    /// is neither spread evenly nor sampled).
    pub fn new(
        lights: &[Light],
        cloud: &Cloud,
        mesh: &'a TriMesh,
        occ: &'a crate::geom::bvh::Occluder,
        medium: &Medium,
    ) -> Result<Sampled<'a>> {
        let digest = crate::lights::digest(lights);
        match cloud.detail("illum_lights_digest") {
            Some(DetailValue::Str(d)) if *d == digest => {}
            Some(_) => {
                return Err(Error::param(
                    "lights",
                    "not the lights illum lit the cloud with (illum_lights_digest differs): \
                     give ssmulti the same lights file as illum",
                ))
            }
            None => {
                return Err(Error::param(
                    "lights",
                    "the cloud does not say which lights lit it (no illum_lights_digest): \
                     run illum with this lights file first",
                ))
            }
        }
        if let Some(l) = lights
            .iter()
            .find(|l| matches!(&l.shape, Shape::Dome(d) if d.map.is_some()))
        {
            return Err(Error::param(
                "lights",
                format!(
                    "light {:?} is a dome with a map, which the walk does not sample: \
                     leave --lights out to take its light from illum",
                    l.name
                ),
            ));
        }
        let passage = Passage {
            sigma_t: DVec3::from_array(medium.mfp.map(|m| 1.0 / m)),
            eta: medium.eta,
        };
        Ok(Sampled {
            lights: lights
                .iter()
                .filter(|l| !matches!(l.shape, Shape::Dome(_)))
                .cloned()
                .collect(),
            shadows: Shadows::new(mesh, occ, Some(passage)),
        })
    }

    /// The exitance per channel the lights give a walk in `medium` at its
    /// event `e` (by reciprocity: `pi` times the radiance the event sends
    /// back along the walk), drawing from `r`; `buf` a scratch list.
    pub fn at(
        &self,
        e: &Event,
        medium: &Medium,
        walker: &Walker,
        r: &mut Pcg32,
        buf: &mut Vec<Arrival>,
    ) -> [f64; 3] {
        let mut out = [0.0; 3];
        for l in &self.lights {
            let (r1, r2) = (uniform53(r), uniform53(r));
            l.emissions(e.pos, r1, r2, buf);
            if buf.is_empty() {
                continue;
            }
            // One of the samples, each the whole light's (their mean is
            // the light).
            let k = ((uniform53(r) * buf.len() as f64) as usize).min(buf.len() - 1);
            let a = buf[k];
            let Some(c) = connect(walker, e.pos, a.dir, medium.eta) else {
                continue;
            };
            let rest = if a.dist.is_finite() {
                (a.dist - c.s).max(0.0)
            } else {
                a.dist
            };
            let q = e.pos + c.inside * c.s;
            let reach = self.shadows.from_triangle(None, q, c.tri, a.dir, rest);
            // Through the boundary: Fresnel's transmittance, and the beam
            // narrowed or widened as it bends (`cos_i / cos_t`); the
            // radiance the event sends back leaves through the walk's
            // start, where it falls by `eta^2` (the start's Fresnel
            // transmittance is in the walk's weight).
            let eta2 = medium.eta * medium.eta;
            let bend = (1.0 - fresnel(c.cos_i, medium.eta)) * c.cos_i / c.cos_t / eta2;
            let phase = hg(medium.g, e.dir.dot(c.inside));
            for (ch, o) in out.iter_mut().enumerate() {
                let tr = (-c.s / medium.mfp[ch]).exp();
                *o += e.weight[ch] * phase * tr * reach.through[ch] * a.e[ch] * bend;
            }
        }
        out.map(|x| x * PI)
    }
}

/// The line from an event to where it leaves towards a light.
struct Connection {
    /// The face it leaves by and how far that is.
    tri: usize,
    s: f64,
    /// Its unit direction inside.
    inside: DVec3,
    /// The light's cosine with the face outside, and the line's inside.
    cos_i: f64,
    cos_t: f64,
}

/// The line from `x` that leaves the mesh towards the light along unit
/// `to_light`: itself at eta 1; through a dielectric the one that
/// refracts into `to_light` at the face it meets (a few steps: the face
/// the light's refraction there points to, then the face that line
/// meets). `None` where the light is below the face's horizon or the
/// line does not leave.
fn connect(walker: &Walker, x: DVec3, to_light: DVec3, eta: f64) -> Option<Connection> {
    let occ = walker.occluder();
    let mut inside = to_light;
    let mut last = None;
    for _ in 0..STEPS {
        let (tri, s) = occ.nearest(x, inside, 0.0, f64::INFINITY, Facing::Leaving)?;
        let f = walker.normal(tri);
        let cos_i = to_light.dot(f);
        if cos_i <= 0.0 {
            return None;
        }
        let cos_t = inside.dot(f);
        if eta == 1.0 {
            return Some(Connection {
                tri,
                s,
                inside,
                cos_i,
                cos_t,
            });
        }
        // The light travelling along -to_light refracted in through f.
        let want = -refract(-to_light, f, 1.0 / eta)?;
        let settled = want.dot(inside) > 1.0 - 1e-12;
        last = Some(Connection {
            tri,
            s,
            inside,
            cos_i,
            cos_t,
        });
        if settled {
            break;
        }
        inside = want;
    }
    last.filter(|c| c.cos_t > 0.0)
}
