//! `sssingle`'s parameters: what a run takes and records, and the way
//! from what it was given (and what the cloud records of ssmulti's run)
//! to them.

use glam::DVec3;

use super::Model;
use crate::cloud::DetailValue;
use crate::error::{Error, Result};
use crate::medium::{self, spec};
use crate::stages::ssmulti::Record;

/// The most samples a point may ask for.
pub const MAX_SAMPLES: u32 = 4096;

/// Parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    pub model: Model,
    /// Seed model: diffuse reflectance and scattering distance (`lu = Rd *
    /// sd`, as ssmulti's `ld`).
    pub rd: [f64; 3],
    pub sd: f64,
    /// Physical model: single-scattering albedo and mean free path per
    /// channel.
    pub albedo: [f64; 3],
    pub mfp: [f64; 3],
    /// Henyey-Greenstein asymmetry, in [-1, 1] (used clamped to +-0.998).
    pub g: f64,
    /// Relative index of refraction, inside over outside.
    pub eta: f64,
    /// Depth samples per point.
    pub samples: u32,
    /// Seed model: per-channel distances (Marengo's t_rgb).
    pub rgb: bool,
    /// Random seed.
    pub seed: u64,
    /// The eye.
    pub eye: DVec3,
    /// The mesh's normals are smooth across edges up to this angle
    /// (degrees), as `facet --mode smooth`'s.
    pub cusp: f64,
    /// Light that enters the mesh is first traced from the entry point to
    /// its light sample: the mesh (the object itself, or another in the
    /// same file) shadows it, opaque for the seed model, its medium for
    /// the physical one. Off: Marengo's unshadowed estimator.
    pub shadows: bool,
}

impl Params {
    /// What a run records in the cloud's detail: every parameter that
    /// changes `ssS` (the lights and the mesh are added by the stage).
    pub fn details(&self) -> Vec<(&'static str, DetailValue)> {
        let mut d = vec![
            (
                "sssingle_model",
                DetailValue::Str(format!("{:?}", self.model).to_lowercase()),
            ),
            ("sssingle_eye", DetailValue::V3D(self.eye.to_array())),
            ("sssingle_g", DetailValue::F64(self.g)),
            ("sssingle_eta", DetailValue::F64(self.eta)),
            ("sssingle_samples", DetailValue::I32(self.samples as i32)),
            ("sssingle_seed", DetailValue::Str(self.seed.to_string())),
            ("sssingle_cusp", DetailValue::F64(self.cusp)),
            ("sssingle_shadows", DetailValue::I32(self.shadows as i32)),
        ];
        match self.model {
            Model::Seed => d.extend([
                ("sssingle_sd", DetailValue::F64(self.sd)),
                ("sssingle_rd", DetailValue::V3D(self.rd)),
                ("sssingle_rgb", DetailValue::I32(self.rgb as i32)),
            ]),
            Model::Physical => d.extend([
                ("sssingle_albedo", DetailValue::V3D(self.albedo)),
                ("sssingle_mfp", DetailValue::V3D(self.mfp)),
            ]),
        }
        d
    }
}

impl Default for Params {
    fn default() -> Self {
        Params {
            model: Model::Seed,
            rd: [1.0; 3],
            sd: 1.0,
            albedo: [spec::ALBEDO; 3],
            mfp: [1.0; 3],
            g: spec::G,
            eta: spec::ETA,
            samples: 16,
            rgb: false,
            seed: 0,
            eye: DVec3::ZERO,
            cusp: 60.0,
            shadows: true,
        }
    }
}

/// `sssingle`'s options as given (its command line's, or those `filter`
/// and `render` take for lazy `ssS`), parsed and not yet checked.
#[derive(Clone, Debug, PartialEq)]
pub struct Given {
    /// The medium: model, material and values given one by one.
    pub medium: medium::Given,
    /// The seed model's Rd, sd and t_rgb [default: the cloud's record of
    /// ssmulti's run].
    pub rd: Option<[f64; 3]>,
    pub sd: Option<f64>,
    pub rgb: bool,
    pub samples: u32,
    pub seed: u64,
    /// The mesh's normals are smooth up to this angle (degrees).
    pub cusp: f64,
    pub shadows: bool,
}

impl Default for Given {
    fn default() -> Self {
        let d = Params::default();
        Given {
            medium: medium::Given::default(),
            rd: None,
            sd: None,
            rgb: false,
            samples: d.samples,
            seed: d.seed,
            cusp: d.cusp,
            shadows: d.shadows,
        }
    }
}

impl Params {
    /// The parameters for the eye `eye` from what was `given`, checked (an
    /// error names the parameter at fault), with `record` what the cloud
    /// holds of ssmulti's run: taken where nothing is given (the physical
    /// medium, or the seed model's Rd, sd and t_rgb); a value given that
    /// differs from it is an error naming both.
    pub fn resolve(given: &Given, eye: DVec3, record: &Record) -> Result<Params> {
        let choice = given.medium.resolve(record.medium.as_ref())?;
        let (rd, sd, rgb) = record.seed(given.rd, given.sd, given.rgb)?;
        let sd = match (choice.model, sd) {
            (Model::Seed, None) => {
                let why = "required by --model seed (the scattering distance)";
                return Err(Error::param("sd", why));
            }
            (_, sd) => sd.unwrap_or(0.0),
        };
        let d = Params::default();
        let medium = choice.medium();
        let p = Params {
            model: choice.model,
            rd,
            sd,
            // (The seed model has no albedo.)
            albedo: medium.map_or(d.albedo, |m| m.albedo),
            mfp: medium.map_or(d.mfp, |m| m.mfp),
            g: choice.g,
            eta: choice.eta,
            samples: given.samples,
            rgb,
            seed: given.seed,
            eye,
            cusp: given.cusp,
            shadows: given.shadows,
        };
        validate(&p)?;
        Ok(p)
    }
}

/// Checks the parameters; an error names the one at fault.
pub fn validate(p: &Params) -> Result<()> {
    let rgb_in = |name: &str, v: [f64; 3], ok: &dyn Fn(f64) -> bool, what: &str| -> Result<()> {
        match v.iter().position(|&x| !ok(x)) {
            Some(c) => Err(Error::param(
                name,
                format!("channel {c} is {:?}: {what}", v[c]),
            )),
            None => Ok(()),
        }
    };
    if !(p.eta.is_finite() && p.eta > 0.0 && p.eta <= 1e3) {
        return Err(Error::param(
            "eta",
            format!("{:?} is not in (0, 1e3]", p.eta),
        ));
    }
    if !(p.g.is_finite() && (-1.0..=1.0).contains(&p.g)) {
        return Err(Error::param("g", format!("{:?} is not in [-1, 1]", p.g)));
    }
    if !(1..=MAX_SAMPLES).contains(&p.samples) {
        return Err(Error::param(
            "samples",
            format!("{} is not in 1..={MAX_SAMPLES}", p.samples),
        ));
    }
    if !p.eye.is_finite() {
        return Err(Error::param("eye", format!("{:?} is not finite", p.eye)));
    }
    if !(p.cusp.is_finite() && (0.0..=180.0).contains(&p.cusp)) {
        return Err(Error::param(
            "cusp",
            format!("{:?} is not an angle in [0, 180] degrees", p.cusp),
        ));
    }
    match p.model {
        Model::Seed => {
            let finite = |x: f64| x.is_finite() && x >= 0.0;
            rgb_in("rd", p.rd, &finite, "not a finite number >= 0")?;
            if !finite(p.sd) {
                return Err(Error::param(
                    "sd",
                    format!("{:?} is not a finite number >= 0", p.sd),
                ));
            }
        }
        Model::Physical => {
            rgb_in(
                "albedo",
                p.albedo,
                &|x| (0.0..=1.0).contains(&x),
                "not in [0, 1]",
            )?;
            rgb_in(
                "mfp",
                p.mfp,
                &|x| x.is_finite() && x > 0.0,
                "not a finite distance > 0",
            )?;
        }
    }
    Ok(())
}
