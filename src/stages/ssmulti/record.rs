//! From what a caller was given to the [`Params`] a run takes ([`Given`]:
//! merge, defaults and checks, next to the maths), and what a run records
//! in the cloud's detail read back ([`Record`]): by `sssingle`, `filter`,
//! `render` and `illum` alike, through this one type.

use super::kernel::{Falloff, FalloffKind};
use super::params::{validate, Base, Norm, Params, PerPoint};
use super::simd::Simd;
use crate::cloud::{Cloud, DetailValue};
use crate::error::{Error, Result};
use crate::medium::{self, Spec};

/// `ssmulti`'s options as given: the command line's, or the Python
/// module's keywords, parsed and not yet checked.
#[derive(Clone, Debug, PartialEq)]
pub struct Given {
    /// Diffuse reflectance (seed model) [default: 1, 1, 1].
    pub rd: Option<[f64; 3]>,
    /// Scattering distance: the seed model runs only with one; the
    /// physical model's is 1 (its distances are the medium's).
    pub sd: Option<f64>,
    pub bounce: f64,
    pub rgb: bool,
    pub falloff: FalloffKind,
    /// The exp falloff's decay, or Burley's `kappa` [default: theirs].
    pub sigma: Option<f64>,
    pub norm: Norm,
    pub tolerance: f64,
    pub simd: Simd,
    /// The medium: model, material and values given one by one.
    pub medium: medium::Given,
    /// The seed model's per-point parameters (the physical model's are
    /// in its material).
    pub per_point: Option<PerPoint>,
    /// The run is the walk method's (`--method walk`): no kernel, so a
    /// medium that absorbs nothing is allowed (a walk ends by leaving the
    /// mesh), and the kernel's checks do not apply.
    pub walk: bool,
}

impl Default for Given {
    fn default() -> Self {
        Given {
            rd: None,
            sd: None,
            bounce: 0.0,
            rgb: false,
            falloff: FalloffKind::Smooth,
            sigma: None,
            norm: Norm::Seed,
            tolerance: 0.0,
            simd: Simd::Auto,
            medium: medium::Given::default(),
            per_point: None,
            walk: false,
        }
    }
}

/// A run decided: its parameters, the per-point parameters and the
/// constant they vary.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    pub params: Params,
    pub per_point: PerPoint,
    pub base: Base,
}

impl Given {
    /// The run these options ask for, checked (an error names the
    /// parameter at fault); `None` for the seed model without `sd` (no
    /// `ssM` can be computed: `filter` and `render` then compute none).
    pub fn resolve(&self) -> Result<Option<Plan>> {
        let choice = self.medium.resolve(None)?;
        let medium = choice.medium();
        let sd = match (self.sd, medium) {
            (Some(sd), _) => sd,
            (None, Some(_)) => 1.0,
            (None, None) => return Ok(None),
        };
        let params = Params {
            rd: self.rd.unwrap_or([1.0; 3]),
            sd,
            bounce: self.bounce,
            rgb: self.rgb,
            falloff: Falloff::new(self.falloff, self.sigma),
            norm: self.norm,
            tolerance: self.tolerance,
            simd: self.simd,
            medium,
        };
        if !self.walk {
            validate(&params)?;
        }
        let per_point = match &self.per_point {
            None => {
                let (attrs, levels) = self.medium.per_point();
                PerPoint { attrs, levels }
            }
            Some(_) if medium.is_some() => {
                let why = "is the seed model's: the physical model's per-point parameters are in the material file (per_point)";
                return Err(Error::param("per_point", why));
            }
            Some(p) => p.clone(),
        };
        let base = match choice.recipe() {
            Some(r) => Base::Physical(r),
            None => Base::Seed,
        };
        Ok(Some(Plan {
            params,
            per_point,
            base,
        }))
    }

    /// [`Given::resolve`]'s parameters alone.
    pub fn params(&self) -> Result<Option<Params>> {
        Ok(self.resolve()?.map(|r| r.params))
    }

    /// [`Given::resolve`], where a run is required: the seed model without
    /// `sd` is an error naming it.
    pub fn plan(&self) -> Result<Plan> {
        self.resolve()?.ok_or_else(|| {
            let why = "required by --model seed (the scattering distance; or --model physical)";
            Error::param("sd", why)
        })
    }
}

/// What a run of `ssmulti` recorded in a cloud's detail
/// ([`Params::details`]): each `None` not recorded.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Record {
    /// The physical model's medium (`ssmulti_model physical`, `_albedo`,
    /// `_mfp`, `_eta`, `_g`); `None` without a whole record of it.
    pub medium: Option<Spec>,
    /// The seed model's Rd, sd and t_rgb.
    pub rd: Option<[f64; 3]>,
    pub sd: Option<f64>,
    pub rgb: Option<bool>,
}

impl Record {
    /// The record `cloud` holds (an empty one when ssmulti has not run
    /// on it). A key of the wrong kind or length is taken as not there.
    pub fn of(cloud: &Cloud) -> Record {
        let rgb = |name: &str| -> Option<[f64; 3]> {
            let v = cloud.detail(name)?.components();
            (v.len() == 3).then(|| [v[0], v[1], v[2]])
        };
        let one = |name: &str| match cloud.detail(name)?.components()[..] {
            [x] => Some(x),
            _ => None,
        };
        let physical =
            matches!(cloud.detail("ssmulti_model"), Some(DetailValue::Str(m)) if m == "physical");
        let medium = || -> Option<Spec> {
            Some(Spec {
                source: "the cloud's ssmulti record".into(),
                albedo: Some(rgb("ssmulti_albedo")?),
                mfp: Some(rgb("ssmulti_mfp")?),
                eta: Some(one("ssmulti_eta")?),
                g: Some(one("ssmulti_g")?),
                ..Spec::default()
            })
        };
        Record {
            medium: if physical { medium() } else { None },
            rd: rgb("ssmulti_rd"),
            sd: one("ssmulti_sd"),
            rgb: one("ssmulti_rgb").map(|x| x == 1.0),
        }
    }

    /// The seed model's Rd, sd and t_rgb: those given, else the
    /// record's, else Rd 1 (sd then `None`); a value given that differs
    /// from the record is an error naming both. (A flag cannot be given
    /// as off: the record's on stays on.)
    pub fn seed(
        &self,
        rd: Option<[f64; 3]>,
        sd: Option<f64>,
        rgb: bool,
    ) -> Result<([f64; 3], Option<f64>, bool)> {
        let differ = |x: f64, y: f64| (x - y).abs() > 1e-9 * x.abs().max(y.abs());
        let clash = |name: &str, given: String, theirs: String| {
            let why = format!(
                "{name} {given} conflicts with the cloud's ssmulti_{name} {theirs} (ssmulti's run)"
            );
            Error::param(name, why)
        };
        let rd = match (rd, self.rd) {
            (Some(v), Some(r)) if v.iter().zip(r).any(|(&x, y)| differ(x, y)) => {
                return Err(clash("rd", format!("{v:?}"), format!("{r:?}")))
            }
            (Some(v), _) => v,
            (None, Some(r)) => r,
            (None, None) => [1.0; 3],
        };
        let sd = match (sd, self.sd) {
            (Some(g), Some(r)) if differ(g, r) => {
                return Err(clash("sd", g.to_string(), r.to_string()))
            }
            (g, r) => g.or(r),
        };
        Ok((rd, sd, rgb || self.rgb == Some(true)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloud::Cloud;

    /// What a run records reads back as the run's own values.
    #[test]
    fn a_record_reads_back_what_a_run_wrote() {
        let mut given = Given::default();
        given.medium.material = Some(medium::material::load("skin1").unwrap().in_scene(Some(1.0)));
        let p = given.params().unwrap().unwrap();
        let mut cloud = Cloud::default();
        cloud.record("ssmulti_", p.details());
        let r = Record::of(&cloud);
        let m = p.medium.unwrap();
        let spec = r.medium.clone().unwrap();
        assert_eq!(spec.mismatch(&m), None);
        assert_eq!((spec.albedo, spec.mfp), (Some(m.albedo), Some(m.mfp)));
        // The seed model's values.
        let seed = Given {
            rd: Some([0.5, 0.6, 0.7]),
            sd: Some(2.0),
            rgb: true,
            ..Given::default()
        };
        let p = seed.params().unwrap().unwrap();
        let mut cloud = Cloud::default();
        cloud.record("ssmulti_", p.details());
        let r = Record::of(&cloud);
        assert_eq!(
            (r.rd, r.sd, r.rgb, r.medium.clone()),
            (Some(p.rd), Some(2.0), Some(true), None)
        );
        assert_eq!(r.seed(None, None, false).unwrap(), (p.rd, Some(2.0), true));
        let e = r.seed(None, Some(3.0), false).unwrap_err().to_string();
        assert!(
            e.contains("sd 3 conflicts with the cloud's ssmulti_sd 2"),
            "{e}"
        );
        // No record: Rd 1 and no sd.
        assert_eq!(
            Record::default().seed(None, None, false).unwrap(),
            ([1.0; 3], None, false)
        );
    }

    #[test]
    fn the_seed_model_needs_sd_and_keeps_per_point_apart() {
        assert_eq!(Given::default().resolve().unwrap(), None);
        let e = Given::default().plan().unwrap_err();
        assert!(
            matches!(&e, Error::Param { name, .. } if name == "sd"),
            "{e}"
        );
        let mut g = Given {
            per_point: Some(PerPoint::parse("rd=Cd", None).unwrap()),
            ..Given::default()
        };
        g.medium.material = Some(medium::material::load("skin1").unwrap());
        let e = g.resolve().unwrap_err();
        assert!(
            matches!(&e, Error::Param { name, .. } if name == "per_point"),
            "{e}"
        );
    }
}
