//! `ssmulti`'s parameters: what a run takes, checks and records, and the
//! distances its kernels reach. A leaf of the folder: the method's files
//! take their parameters from here.

use super::kernel::{reach, Falloff};
use super::simd::Simd;
use crate::cloud::DetailValue;
use crate::error::{Error, Result};
use crate::medium::{Medium, Recipe};

/// How `ssM` is computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// Sums of a diffusion kernel over the cloud's neighbours (either
    /// model).
    #[default]
    Diffusion,
    /// Random walks through the mesh from each point (the physical model;
    /// needs the mesh): converges to the medium's multiple scattering on
    /// any closed shape.
    Walk,
}

/// How the sum is normalised (`docs/DESIGN.md#normalisations`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Norm {
    /// Houdini's: by the disk integral at the largest distance (with
    /// --rgb, no Rd).
    Seed,
    /// With --rgb, each channel by its own disk integral, times Rd.
    Channel,
    /// By the kernel-weighted area present within reach, times Rd.
    Local,
    /// Each source's light spread over the kernel-weighted area within
    /// its own reach, times Rd (the physical model's default): an even
    /// surface returns Rd times its light whatever its sampling, and a
    /// closed one all the light that enters, times Rd. Twice the work:
    /// a first pass sums each point's area within reach.
    Source,
}

/// Parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    /// Diffuse reflectance per channel.
    pub rd: [f64; 3],
    /// Scattering distance.
    pub sd: f64,
    /// Bounce attenuation, 0 (off) to 1.
    pub bounce: f64,
    /// Per-channel distances (`t_rgb`).
    pub rgb: bool,
    pub falloff: Falloff,
    pub norm: Norm,
    /// 0: exact. Above: the approximate method's tolerance.
    pub tolerance: f64,
    /// The pair loop's instruction set (the fused one rounds differently).
    pub simd: Simd,
    /// The physical model (`docs/DESIGN.md#physical-multiple-scattering`):
    /// a medium's diffusion in place of Rd, sd and the falloff. `None`:
    /// Marengo's model.
    pub medium: Option<Medium>,
}

/// The Burley shape `kappa = D / d` of the physical model: the truncation
/// at `D` keeps 99% of the untruncated profile's energy
/// (`1 - e^-kappa / 4 - 3 e^(-kappa/3) / 4 = 0.99`); the 1% beyond is given
/// back inside, so a flat surface still returns the whole reflectance.
pub const PHYSICAL_KAPPA: f64 = 12.952_642_092_055_077;

impl Default for Params {
    fn default() -> Self {
        Params {
            rd: [1.0; 3],
            sd: 1.0,
            bounce: 0.0,
            rgb: false,
            falloff: Falloff::Smooth,
            norm: Norm::Seed,
            tolerance: 0.0,
            simd: Simd::Auto,
            medium: None,
        }
    }
}

impl Params {
    /// What a run records in the cloud's detail: every parameter that
    /// changes `ssM` (not the instruction set, which changes its last
    /// bits only).
    pub fn details(&self) -> Vec<(&'static str, DetailValue)> {
        if let Some(m) = &self.medium {
            let p = self.resolved();
            return vec![
                ("ssmulti_model", DetailValue::Str("physical".into())),
                ("ssmulti_albedo", DetailValue::V3D(m.albedo)),
                ("ssmulti_mfp", DetailValue::V3D(m.mfp)),
                ("ssmulti_eta", DetailValue::F64(m.eta)),
                ("ssmulti_g", DetailValue::F64(m.g)),
                ("ssmulti_reflectance", DetailValue::V3D(m.rm)),
                ("ssmulti_colour", DetailValue::V3D(m.colour())),
                ("ssmulti_dmfp", DetailValue::V3D(m.dmfp)),
                ("ssmulti_distances", DetailValue::V3D(p.distances())),
                (
                    "ssmulti_falloff",
                    DetailValue::Str(format!("burley {:?}", physical_kappa(&p))),
                ),
                (
                    "ssmulti_norm",
                    DetailValue::Str(format!("{:?}", p.norm).to_lowercase()),
                ),
                ("ssmulti_bounce", DetailValue::F64(self.bounce)),
                ("ssmulti_tolerance", DetailValue::F64(self.tolerance)),
                ("ssmulti_radiance", DetailValue::Str(RADIANCE.into())),
            ];
        }
        let falloff = match self.falloff {
            Falloff::Smooth => "smooth".to_string(),
            Falloff::Exp { sigma } => format!("exp {sigma:?}"),
            Falloff::Burley { kappa } => format!("burley {kappa:?}"),
        };
        vec![
            ("ssmulti_sd", DetailValue::F64(self.sd)),
            ("ssmulti_rd", DetailValue::V3D(self.rd)),
            ("ssmulti_rgb", DetailValue::I32(self.rgb as i32)),
            ("ssmulti_falloff", DetailValue::Str(falloff)),
            (
                "ssmulti_norm",
                DetailValue::Str(format!("{:?}", self.norm).to_lowercase()),
            ),
            ("ssmulti_bounce", DetailValue::F64(self.bounce)),
            ("ssmulti_tolerance", DetailValue::F64(self.tolerance)),
        ]
    }

    /// The farthest a point can be from a point whose `ssM` it changes:
    /// the kernel's truncation at the largest distance `max(Rd * sd)`
    /// ([`reach`]), twice that with [`Norm::Source`] (a source's light is
    /// divided by the area within its own reach). A tile's halo must be
    /// at least this wide.
    pub fn reach(&self) -> f64 {
        let p = self.resolved();
        let r = reach(p.falloff, Distances::of(&p).ld1);
        if p.norm == Norm::Source {
            2.0 * r
        } else {
            r
        }
    }

    /// The parameters the sums run with: for the physical model, the
    /// Burley kernel (its `kappa` from `--sigma`, else
    /// [`PHYSICAL_KAPPA`]), a distance a channel, and a normalisation by
    /// each channel's own disk (`Channel`, unless `Local` was asked for).
    pub fn resolved(&self) -> Params {
        if self.medium.is_none() {
            return *self;
        }
        Params {
            falloff: Falloff::Burley {
                kappa: physical_kappa(self),
            },
            rgb: true,
            norm: match self.norm {
                Norm::Seed => Norm::Source,
                n => n,
            },
            ..*self
        }
    }

    /// Each channel's kernel distance `D`: `Rd * sd`, or for the physical
    /// model `kappa d` with the Burley shape `d` a third of the diffuse
    /// mean free path (the profile's long exponential, `e^(-r / 3d)`,
    /// decays as the diffusion does, `e^(-sigma_tr r)`).
    pub fn distances(&self) -> [f64; 3] {
        match &self.medium {
            None => self.rd.map(|r| r * self.sd),
            Some(m) => {
                let kappa = physical_kappa(self);
                m.dmfp.map(|l| kappa * l / 3.0)
            }
        }
    }

    /// What each channel's normalised sum is multiplied by: `Rd`, or the
    /// medium's multiple-scattering reflectance.
    pub fn gains(&self) -> [f64; 3] {
        match &self.medium {
            None => self.rd,
            Some(m) => m.rm,
        }
    }
}

/// How `ssM` becomes radiance, as the physical model records it.
pub const RADIANCE: &str = "ssM / pi (Lambertian exit)";

/// The physical model's Burley `kappa`: `--sigma`'s with `--falloff
/// burley`, else [`PHYSICAL_KAPPA`] (a resolved `Params` gives its own).
pub(super) fn physical_kappa(p: &Params) -> f64 {
    match p.falloff {
        Falloff::Burley { kappa } => kappa,
        _ => PHYSICAL_KAPPA,
    }
}

/// The largest tolerance of the approximate method: a cluster half as wide
/// as the kernel's length scale. The benchmark measures up to 0.4
/// (benches/results/ssmulti_accuracy.txt); far beyond, clusters as wide
/// as the kernel itself are summed at one point and the error reaches
/// tens of percent.
pub const MAX_TOLERANCE: f64 = 0.5;

/// Points per leaf (a multiple of the lane count).
pub const LEAF: usize = 64;

/// Checks the parameters; an error names the one at fault.
pub fn validate(p: &Params) -> Result<()> {
    if let Some(m) = &p.medium {
        if let Some(c) = m.dmfp.iter().position(|d| !d.is_finite()) {
            return Err(Error::param(
                "albedo",
                format!(
                    "channel {c} is {:?}: a medium that absorbs nothing diffuses without end (give an albedo below 1)",
                    m.albedo[c]
                ),
            ));
        }
        let r = p.resolved();
        let ld = r.distances();
        let kappa = physical_kappa(&r) as f32;
        if let Some(c) = (0..3).find(|&c| !(ld[c] > 0.0 && (kappa / ld[c] as f32).is_finite())) {
            return Err(Error::param(
                "mfp",
                format!(
                    "channel {c}: a kernel distance of {:e} is too small for the float pair loop: give the scene in larger units",
                    ld[c]
                ),
            ));
        }
        return validate_rest(&Params {
            medium: None,
            rd: ld,
            sd: 1.0,
            ..r
        });
    }
    validate_rest(p)
}

/// [`validate`] of Marengo's parameters (and of the physical model's
/// kernels, given as distances with sd 1).
fn validate_rest(p: &Params) -> Result<()> {
    for (c, &x) in p.rd.iter().enumerate() {
        if !(x.is_finite() && x >= 0.0) {
            return Err(Error::param(
                "rd",
                format!("channel {c} is {x:?}: not a finite number >= 0"),
            ));
        }
    }
    // sd 0 is refused, not summed to 0: as sd -> 0 the normalised kernel
    // tends to a delta and ssM to Rd * illum, which no sum over
    // neighbours gives. (A channel's Rd of 0 is fine: ssM is 0 there, as
    // its limit is.)
    if !(p.sd.is_finite() && p.sd > 0.0) {
        return Err(Error::param(
            "sd",
            format!(
                "{:?} is not a finite distance > 0 (as sd -> 0, ssM tends to Rd * illum, which the kernel sum cannot give)",
                p.sd
            ),
        ));
    }
    if !(p.bounce.is_finite() && (0.0..=1.0).contains(&p.bounce)) {
        return Err(Error::param(
            "bounce",
            format!("{:?} is not in [0, 1]", p.bounce),
        ));
    }
    match p.falloff {
        Falloff::Exp { sigma: k } | Falloff::Burley { kappa: k }
            if !(k.is_finite() && k > 0.0 && k <= 1e6) =>
        {
            return Err(Error::param("sigma", format!("{k:?} is not in (0, 1e6]")));
        }
        _ => {}
    }
    // The pair loop's f32 kernel constants (1 / D^2, sigma / D) must be
    // finite: below about 5e-20 they overflow and every weight would come
    // out 0.
    for d in p.distances().into_iter().filter(|&d| d > 0.0) {
        let inv = 1.0 / d as f32;
        let ok = match p.falloff {
            Falloff::Smooth => (inv * inv).is_finite(),
            Falloff::Exp { sigma: k } | Falloff::Burley { kappa: k } => {
                (k as f32 * inv).is_finite()
            }
        };
        if !ok {
            return Err(Error::param(
                "sd",
                format!(
                    "Rd * sd = {d:e} is too small for the float pair loop (the smooth falloff needs at least 5.5e-20): give the scene in larger units"
                ),
            ));
        }
    }
    if !(p.tolerance.is_finite() && (0.0..=MAX_TOLERANCE).contains(&p.tolerance)) {
        return Err(Error::param(
            "tolerance",
            format!("{:?} is not in [0, {MAX_TOLERANCE}]", p.tolerance),
        ));
    }
    Ok(())
}

/// The channels' distances `ld = Rd * sd` and the largest, `ld1`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Distances {
    pub ld: [f64; 3],
    pub ld1: f64,
}

impl Distances {
    pub fn of(p: &Params) -> Distances {
        let ld = p.distances();
        Distances {
            ld,
            ld1: ld.iter().copied().fold(0.0, f64::max),
        }
    }

    /// One kernel serves every channel: not t_rgb, or equal distances.
    pub fn single(&self, rgb: bool) -> bool {
        !rgb || (self.ld[0] == self.ld[1] && self.ld[1] == self.ld[2])
    }
}

/// Which parameters come from which attributes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PerPoint {
    /// (`albedo`, `color`, `mfp` or `dmfp`, attribute name).
    pub attrs: Vec<(String, String)>,
    pub levels: Option<u32>,
}

impl PerPoint {
    /// `PARAM=ATTR` pairs separated by commas (the seed model's
    /// `--per-point rd=Cd,sd=dist`), with `levels`.
    pub fn parse(list: &str, levels: Option<u32>) -> Result<PerPoint> {
        let mut attrs = Vec::new();
        for item in list.split(',').filter(|s| !s.trim().is_empty()) {
            let Some((k, a)) = item.split_once('=') else {
                return Err(Error::param(
                    "per_point",
                    format!("'{item}' is not PARAM=ATTR"),
                ));
            };
            let (k, a) = (k.trim(), a.trim());
            if !SEED_KEYS.contains(&k) || a.is_empty() {
                return Err(Error::param(
                    "per_point",
                    format!("'{item}': PARAM is rd or sd, ATTR an attribute's name"),
                ));
            }
            attrs.push((k.to_string(), a.to_string()));
        }
        if attrs.is_empty() {
            return Err(Error::param("per_point", "names no parameter"));
        }
        if let Some(l) = levels {
            let max = crate::medium::material::MAX_LEVELS;
            if !(2..=max).contains(&l) {
                return Err(Error::param("levels", format!("{l}: not in 2..={max}")));
            }
        }
        Ok(PerPoint { attrs, levels })
    }
}

/// The constant a run starts from: the physical medium's recipe, or the
/// seed model's Rd and sd.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Base {
    Physical(Recipe),
    Seed,
}

/// The parameters each model takes per point.
pub const PHYSICAL_KEYS: [&str; 4] = ["albedo", "color", "mfp", "dmfp"];
pub const SEED_KEYS: [&str; 2] = ["rd", "sd"];
