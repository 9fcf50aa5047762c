//! The options several stages share: ssmulti's (`ssmulti`, and `filter`
//! and `render` to compute `ssM` lazily), sssingle's model (`sssingle`,
//! `filter`, `render`), and the parsers of `R,G,B` and `X,Y,Z` values;
//! and the whole command lines of `sssingle` and `illum`, which `pctile
//! split --for` parses too.

use std::path::PathBuf;

use clap::Parser;

use super::{env_flag, IoArgs};
use crate::medium::{self, Medium, Model};
use crate::stages::filter::{self, SingleSetup};
use crate::stages::ssmulti::{self, Falloff, FalloffKind, Norm, Params, Simd};
use crate::stages::sssingle;

/// Which cloud points `filter` and `render` gather at a shade point.
#[derive(clap::Args, Debug, Clone)]
pub struct GatherArgs {
    /// Use the N nearest cloud points.
    #[arg(long, value_name = "N", conflicts_with = "radius")]
    pub nfp: Option<usize>,
    /// Use the cloud points within this fraction of the scattering
    /// distance D = sd * max(Rd) (the physical model's largest distance)
    /// [default: 0.25, but never under twice the cloud's spacing
    /// sqrt(Tarea / scatter_count), else sqrt(mean ptarea); the physical
    /// model's ssM: twice the spacing].
    #[arg(long, value_name = "FRACTION")]
    pub radius: Option<f64>,
    /// Only cloud points whose normal faces the shade point's side.
    #[arg(long)]
    pub facing: bool,
}

impl GatherArgs {
    /// `filter`'s setup for `cloud` (named `cloud_name` in an error)
    /// with these options: the attributes `attrs` gathered, `ssM` and
    /// `ssS` made lazily by `multi` and `single`; how the reach was
    /// chosen is a debug message.
    pub fn setup<'a>(
        &self,
        cloud: &crate::cloud::Cloud,
        cloud_name: &str,
        attrs: &'a [String],
        multi: Option<&'a ssmulti::Params>,
        single: Option<&'a SingleSetup<'a>>,
        msg: &super::Messages,
    ) -> anyhow::Result<filter::Setup<'a>> {
        let setup = filter::Setup::new(
            cloud,
            attrs,
            multi,
            single,
            self.nfp,
            self.radius,
            self.facing,
        )
        .map_err(super::at(cloud_name))?;
        if let Some(note) = &setup.note {
            msg.debug(note);
        }
        Ok(setup)
    }
}

/// `ssmulti`'s parameters (also `filter`'s, for lazy evaluation).
#[derive(clap::Args, Debug, Clone)]
pub struct SsArgs {
    /// Diffuse reflectance: R,G,B (or one value for all three) [default:
    /// 1,1,1; filter's and render's lazy ssS: the cloud's ssmulti_rd].
    #[arg(long, value_name = "R,G,B")]
    pub rd: Option<String>,
    /// Scattering distance (per channel: Rd * sd).
    #[arg(long)]
    pub sd: Option<f64>,
    /// Bounce attenuation, 0 (off) to 1.
    #[arg(long, default_value_t = 0.0)]
    pub bounce: f64,
    /// Per-channel distances (Houdini's t_rgb): each channel reaches its Rd times sd.
    #[arg(long)]
    pub rgb: bool,
    /// Falloff kernel.
    #[arg(long, value_enum, default_value = "smooth")]
    pub falloff: FalloffKind,
    /// exp: decay rate (default 4); burley: D / d (default 5.625: the
    /// profile's mean radius equals the smooth falloff's).
    #[arg(long)]
    pub sigma: Option<f64>,
    /// Normalisation.
    #[arg(long, value_enum, default_value = "seed")]
    pub norm: Norm,
    /// 0: the exact method; up to 0.5: the approximate one, which sums a
    /// cluster of sources whole when its radius is at most T times the
    /// kernel's length scale; the error grows like T^2 (docs/PERFORMANCE.md,
    /// "ssmulti").
    #[arg(long, default_value_t = 0.0)]
    pub tolerance: f64,
}

/// The material: the model both `ssmulti` and `sssingle` use (and
/// `filter` and `render` for what they compute lazily, `illum` for a
/// medium's shadows), with the physical model's medium
/// (docs/DESIGN.md#physical-medium), given here or by `--material`.
#[derive(clap::Args, Debug, Clone)]
pub struct MaterialArgs {
    /// The physical model's medium from a material file (JSON,
    /// formats/MATERIAL.md) or a preset (Jensen et al. 2001's measured
    /// media, lengths in millimetres: apple, chicken1, chicken2, cream,
    /// ketchup, marble, potato, skimmilk, wholemilk, skin1, skin2). Implies
    /// --model physical; an option below that gives another value is an
    /// error naming both.
    #[arg(long, value_name = "FILE|PRESET")]
    pub material: Option<String>,
    /// seed: Marengo's (ssmulti --rd, --sd and the falloffs; sssingle
    /// likewise); physical: a medium (--albedo or --color, --mfp or
    /// --dmfp, --eta, --g): a random walk's reflectance for ssM,
    /// Jensen et al. 2001 for ssS [default: seed, physical with
    /// --material].
    #[arg(long, value_enum)]
    pub model: Option<Model>,
    /// Physical model: single-scattering albedo R,G,B in [0, 1]
    /// [default: 0.8].
    #[arg(long, value_name = "R,G,B")]
    pub albedo: Option<String>,
    /// Physical model: the surface colour R,G,B a flat slab of the medium
    /// shows (its whole diffuse reflectance), in place of --albedo: the
    /// single-scattering albedo is found from it.
    #[arg(
        long,
        visible_alias = "colour",
        value_name = "R,G,B",
        conflicts_with = "albedo"
    )]
    pub color: Option<String>,
    /// Physical model: mean free path R,G,B (1 / extinction).
    #[arg(long, value_name = "R,G,B", conflicts_with = "dmfp")]
    pub mfp: Option<String>,
    /// Physical model: diffuse mean free path R,G,B (1 / sigma_tr, the
    /// distance the diffusion decays over), in place of --mfp.
    #[arg(long, value_name = "R,G,B")]
    pub dmfp: Option<String>,
    /// Henyey-Greenstein asymmetry: in [-0.6, 0.9] for the physical model
    /// (its reflectance table), [-1, 1] for the seed model's sssingle
    /// (used within +-0.998) [default: 0].
    #[arg(long)]
    pub g: Option<f64>,
    /// Relative index of refraction, inside over outside (in [1, 3] for
    /// the physical model: its reflectance table) [default: 1.3].
    #[arg(long)]
    pub eta: Option<f64>,
    /// The length of the scene's unit in millimetres, from the cloud's
    /// recorded `meters_per_unit`: a preset's millimetres follow it
    /// ([`MaterialArgs::in_frame`]); not an option.
    #[arg(skip)]
    pub scene_unit_mm: Option<f64>,
}

impl MaterialArgs {
    /// The options for a cloud in `frame`: a preset's lengths follow the
    /// frame's unit. Returns the line to say when a preset is used and
    /// neither the scene nor the material says how long a unit is (its
    /// millimetres are then the scene's units).
    pub fn in_frame(&mut self, frame: &crate::frame::Frame) -> anyhow::Result<Option<String>> {
        self.scene_unit_mm = frame.meters_per_unit.map(|m| m * 1000.0);
        let Some(arg) = &self.material else {
            return Ok(None);
        };
        let m = medium::material::load_in(arg, self.scene_unit_mm)?;
        Ok(m.unit_assumed.then(|| {
            format!(
                "{}: the scene records no unit (meters_per_unit): the preset's lengths, in millimetres, are taken in the scene's units (1 unit = 1 mm); record the unit (scatter --meters-per-unit, or a USD stage's metersPerUnit) or give the material file's unit_length",
                m.source
            )
        }))
    }
}

/// The recipe of merged options whose distance is `dist` (`diffuse`).
fn recipe(m: &Material, dist: [f64; 3], diffuse: bool) -> medium::Recipe {
    medium::Recipe {
        albedo: m.albedo.0,
        colour: m.albedo.1,
        dist,
        diffuse,
        eta: m.eta,
        g: m.g,
    }
}

/// `ssmulti`'s per-point options (also read by `pctile split --for
/// ssmulti --stage-args`).
#[derive(clap::Args, Debug, Clone)]
pub struct PerPointArgs {
    /// Seed model: Rd or sd taken at each point from an attribute:
    /// rd=ATTR, sd=ATTR (comma-separated). The physical model's are in
    /// the material file (per_point).
    #[arg(long, value_name = "PARAM=ATTR,..")]
    pub per_point: Option<String>,
    /// With --per-point: round Rd to steps of 1 / (N - 1) and sd to N
    /// steps per doubling (2 to 64).
    #[arg(long, value_name = "N", requires = "per_point")]
    pub levels: Option<u32>,
}

impl PerPointArgs {
    /// The per-point parameters: the options' (seed model) or the
    /// material's (physical model); `physical` says which model runs.
    pub fn resolve(
        &self,
        material: &MaterialArgs,
        physical: bool,
    ) -> anyhow::Result<ssmulti::per_point::PerPoint> {
        Ok(match &self.per_point {
            None => material.per_point()?,
            Some(_) if physical => {
                let why = "is the seed model's: the physical model's per-point parameters are in the material file (per_point)";
                return Err(crate::Error::param("per_point", why).into());
            }
            Some(list) => ssmulti::per_point::PerPoint::parse(list, self.levels)?,
        })
    }
}

/// [`MaterialArgs`] with `--material` merged in and the defaults set.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    pub model: Model,
    /// The single-scattering albedo or the surface colour (`true`).
    pub albedo: ([f64; 3], bool),
    /// The mean free path or the diffuse one (`true`); `None` not given.
    pub mfp: Option<([f64; 3], bool)>,
    pub g: f64,
    pub eta: f64,
}

impl MaterialArgs {
    /// The options with the material file or preset merged in: an option
    /// given on the command line that the material gives otherwise is an
    /// error naming both.
    pub fn merged(&self) -> anyhow::Result<Material> {
        self.merged_with(None)
    }

    /// [`MaterialArgs::merged`], with the medium a cloud records
    /// (`recorded`, [`medium::material::recorded`]) taken when no
    /// `--material` and no `--model seed` is given: the options then
    /// conflict with it as with a material's. With `--material` too, the
    /// record must agree with the result.
    pub fn merged_with(
        &self,
        recorded: Option<&medium::material::Material>,
    ) -> anyhow::Result<Material> {
        let given = match &self.material {
            Some(m) => Some(medium::material::load_in(m, self.scene_unit_mm)?),
            None => None,
        };
        let seed = self.model == Some(Model::Seed);
        // Options of the medium given on the command line: checked against
        // a record as the medium they make (a record holds the albedo and
        // mean free path, the options may give a colour and a diffuse one).
        let options = self.albedo.is_some()
            || self.color.is_some()
            || self.mfp.is_some()
            || self.dmfp.is_some()
            || self.eta.is_some()
            || self.g.is_some();
        // With options, the record's keys they give are theirs, and the
        // medium that makes is held against the record's.
        let over = |r: &medium::material::Material| {
            let mut f = r.clone();
            if self.albedo.is_some() || self.color.is_some() {
                (f.albedo, f.color) = (None, None);
            }
            if self.mfp.is_some() || self.dmfp.is_some() {
                (f.mfp, f.dmfp) = (None, None);
            }
            if self.eta.is_some() {
                f.eta = None;
            }
            if self.g.is_some() {
                f.g = None;
            }
            f
        };
        let (file, check) = match (given, recorded) {
            (_, _) if seed => (None, None),
            (Some(g), r) => (Some(g), r),
            (None, Some(r)) if options => (Some(over(r)), Some(r)),
            (None, Some(r)) => (Some(r.clone()), None),
            (None, None) => (None, None),
        };
        let merged = self.merged_from(file)?;
        let medium = match check {
            Some(_) => self.medium_of(&merged)?,
            None => None,
        };
        if let (Some(r), Some(md)) = (check, medium) {
            if let Some(what) = medium::material::mismatch(r, &md) {
                let first = [
                    ("--albedo", self.albedo.is_some()),
                    ("--color", self.color.is_some()),
                    ("--mfp", self.mfp.is_some()),
                    ("--dmfp", self.dmfp.is_some()),
                    ("--eta", self.eta.is_some()),
                    ("--g", self.g.is_some()),
                ]
                .into_iter()
                .find_map(|(f, given)| given.then_some(f))
                .unwrap_or("--model");
                let (flag, what_gave) = match &self.material {
                    Some(_) => ("--material", "the material"),
                    None => (first, "the options"),
                };
                let why = format!(
                    "{what_gave} make another medium than {} has: {what} given",
                    r.source
                );
                return Err(crate::Error::param(flag, why).into());
            }
        }
        Ok(merged)
    }

    fn merged_from(&self, file: Option<medium::material::Material>) -> anyhow::Result<Material> {
        let rgb = |flag: &str, v: &Option<String>| -> anyhow::Result<Option<[f64; 3]>> {
            v.as_deref().map(|x| parse_rgb(flag, x)).transpose()
        };
        let (albedo, color) = (rgb("--albedo", &self.albedo)?, rgb("--color", &self.color)?);
        let (mfp, dmfp) = (rgb("--mfp", &self.mfp)?, rgb("--dmfp", &self.dmfp)?);
        let Some(f) = file else {
            return Ok(Material {
                model: self.model.unwrap_or(Model::Seed),
                albedo: match color {
                    Some(c) => (c, true),
                    None => (albedo.unwrap_or([0.8; 3]), false),
                },
                mfp: mfp.map(|m| (m, false)).or(dmfp.map(|d| (d, true))),
                g: self.g.unwrap_or(0.0),
                eta: self.eta.unwrap_or(1.3),
            });
        };
        let clash = |flag: &str, given: String, key: &str, theirs: String| -> anyhow::Error {
            crate::Error::param(
                flag,
                format!(
                    "{given} conflicts with the material's {key} {theirs} ({})",
                    f.source
                ),
            )
            .into()
        };
        let same = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .all(|(x, y)| (x - y).abs() <= 1e-12 * x.abs().max(y.abs()))
        };
        if self.model == Some(Model::Seed) {
            let why = "seed conflicts with --material (the physical model's medium)";
            return Err(crate::Error::param("--model", why).into());
        }
        // Each pair of options against the material's pair.
        let pick = |flags: [&str; 2],
                    given: [Option<[f64; 3]>; 2],
                    keys: [&str; 2],
                    theirs: [Option<[f64; 3]>; 2]|
         -> anyhow::Result<Option<([f64; 3], bool)>> {
            let mine = given.iter().position(Option::is_some);
            let other = theirs.iter().position(Option::is_some);
            match (mine, other) {
                (Some(i), Some(j)) if i != j || !same(&given[i].unwrap(), &theirs[j].unwrap()) => {
                    Err(clash(
                        flags[i],
                        format!("{} {:?}", flags[i], given[i].unwrap()),
                        keys[j],
                        format!("{:?}", theirs[j].unwrap()),
                    ))
                }
                (Some(i), _) => Ok(Some((given[i].unwrap(), i == 1))),
                (None, Some(j)) => Ok(Some((theirs[j].unwrap(), j == 1))),
                (None, None) => Ok(None),
            }
        };
        let a = pick(
            ["--albedo", "--color"],
            [albedo, color],
            ["albedo", "color"],
            [f.albedo, f.color],
        )?;
        let d = pick(
            ["--mfp", "--dmfp"],
            [mfp, dmfp],
            ["mfp", "dmfp"],
            [f.mfp, f.dmfp],
        )?;
        let scalar =
            |flag: &str, given: Option<f64>, key: &str, theirs: Option<f64>, default: f64| match (
                given, theirs,
            ) {
                (Some(x), Some(y)) if !same(&[x], &[y]) => {
                    Err(clash(flag, format!("{flag} {x}"), key, format!("{y}")))
                }
                (x, y) => Ok(x.or(y).unwrap_or(default)),
            };
        Ok(Material {
            model: Model::Physical,
            albedo: a.unwrap_or(([0.8; 3], false)),
            mfp: d,
            g: scalar("--g", self.g, "g", f.g, 0.0)?,
            eta: scalar("--eta", self.eta, "eta", f.eta, 1.3)?,
        })
    }

    /// The material's per-point parameters (none without `--material`).
    pub fn per_point(&self) -> anyhow::Result<ssmulti::per_point::PerPoint> {
        Ok(match &self.material {
            Some(m) => {
                let m = medium::material::load_in(m, self.scene_unit_mm)?;
                ssmulti::per_point::PerPoint {
                    attrs: m.per_point,
                    levels: m.levels,
                }
            }
            None => Default::default(),
        })
    }

    /// How the physical model's medium is given; `None` for the seed
    /// model.
    pub fn recipe(&self) -> anyhow::Result<Option<medium::Recipe>> {
        let m = self.merged()?;
        Ok(match (m.model, m.mfp) {
            (Model::Physical, Some((dist, diffuse))) => Some(recipe(&m, dist, diffuse)),
            _ => None,
        })
    }

    /// The physical model's medium; `None` for the seed model.
    pub fn medium(&self) -> anyhow::Result<Option<Medium>> {
        self.medium_of(&self.merged()?)
    }

    /// The medium of the merged options `m`; `None` for the seed model.
    pub fn medium_of(&self, m: &Material) -> anyhow::Result<Option<Medium>> {
        if m.model == Model::Seed {
            return Ok(None);
        }
        let Some((dist, diffuse)) = m.mfp else {
            return Err(crate::Error::param(
                "--mfp",
                "required by --model physical (the mean free path; or --dmfp, or --material)",
            )
            .into());
        };
        let medium = self::recipe(m, dist, diffuse).medium();
        Ok(Some(medium?))
    }
}

/// `sssingle`'s sampling options (also `filter`'s and `render`'s, to
/// compute `ssS` for the points they read); the model is
/// [`MaterialArgs`], the seed model's Rd, sd and t_rgb ssmulti's options.
#[derive(clap::Args, Debug, Clone)]
pub struct SingleArgs {
    /// Depth samples per point (stratified), 1 to 4096.
    #[arg(long, default_value_t = 16)]
    pub samples: u32,
    /// Random seed of the depth samples and area lights' offsets.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// The mesh's normals are smooth across edges up to this angle
    /// (degrees), as facet's.
    #[arg(long, default_value_t = 60.0)]
    pub cusp: f64,
    /// Single scattering without shadow rays from where light enters the
    /// mesh to the light: Marengo's unshadowed estimator (light passes
    /// through whatever lies beyond the surface it enters by).
    #[arg(long)]
    pub no_shadows: bool,
}

impl SingleArgs {
    /// The parameters for the eye `eye`, with the material `mat` and the
    /// seed model's `rd`, `sd` and `rgb`, checked (an error names the
    /// option at fault), for the cloud `record` (its detail): what
    /// it records of ssmulti's run is taken where nothing is given (the
    /// physical medium, or the seed model's Rd, sd and t_rgb), and an
    /// option that gives another value is an error naming both.
    pub fn params_for(
        &self,
        mat: &MaterialArgs,
        rd: Option<&str>,
        sd: Option<f64>,
        rgb: bool,
        eye: [f64; 3],
        record: Option<&crate::cloud::Cloud>,
    ) -> anyhow::Result<sssingle::Params> {
        let recorded = record.and_then(medium::material::recorded);
        let m = mat.merged_with(recorded.as_ref())?;
        let medium = mat.medium_of(&m)?;
        let (rd, sd, rgb) = seed_record(rd, sd, rgb, record)?;
        let sd = match (m.model, sd) {
            (Model::Seed, None) => {
                return Err(crate::Error::param(
                    "--sd",
                    "required by --model seed (the scattering distance)",
                )
                .into())
            }
            (_, sd) => sd.unwrap_or(0.0),
        };
        let p = sssingle::Params {
            model: m.model,
            rd,
            sd,
            // (The seed model has no albedo.)
            albedo: medium.map_or([0.8; 3], |m| m.albedo),
            mfp: medium.map_or([1.0; 3], |m| m.mfp),
            g: m.g,
            eta: m.eta,
            samples: self.samples,
            rgb,
            seed: self.seed,
            eye: glam::DVec3::from_array(eye),
            cusp: self.cusp,
            shadows: !self.no_shadows,
        };
        sssingle::validate(&p)?;
        Ok(p)
    }
}

/// The seed model's Rd, sd and t_rgb given, else those `record` holds
/// from ssmulti's run (`ssmulti_rd`, `_sd`, `_rgb`), else Rd 1; a value
/// given that differs from the record is an error naming both.
fn seed_record(
    rd: Option<&str>,
    sd: Option<f64>,
    rgb: bool,
    record: Option<&crate::cloud::Cloud>,
) -> anyhow::Result<([f64; 3], Option<f64>, bool)> {
    let detail = |name: &str| record.and_then(|c| c.detail(name)).map(|d| d.components());
    let (r_rd, r_sd, r_rgb) = (
        detail("ssmulti_rd"),
        detail("ssmulti_sd"),
        detail("ssmulti_rgb"),
    );
    let clash = |flag: &str, given: String, key: &str, theirs: String| -> anyhow::Error {
        crate::Error::param(
            flag,
            format!("{flag} {given} conflicts with the cloud's {key} {theirs} (ssmulti's run)"),
        )
        .into()
    };
    let given = rd.map(|g| parse_rgb("--rd", g)).transpose()?;
    let rd = match (given, r_rd.as_deref()) {
        (Some(v), Some(&[a, b, c])) => {
            if v.iter()
                .zip([a, b, c])
                .any(|(x, y)| (x - y).abs() > 1e-9 * x.abs().max(y.abs()))
            {
                let g = rd.unwrap_or_default().to_string();
                return Err(clash("--rd", g, "ssmulti_rd", format!("{:?}", [a, b, c])));
            }
            v
        }
        (Some(v), _) => v,
        (None, Some(&[a, b, c])) => [a, b, c],
        (None, _) => [1.0; 3],
    };
    let sd = match (sd, r_sd.as_deref()) {
        (Some(g), Some([r])) if (g - r).abs() > 1e-9 * g.abs().max(r.abs()) => {
            return Err(clash("--sd", g.to_string(), "ssmulti_sd", r.to_string()))
        }
        (Some(g), _) => Some(g),
        (None, Some([r])) => Some(*r),
        (None, _) => None,
    };
    // (A flag cannot be given as off: the record's on stays on.)
    let rgb = rgb || r_rgb.as_deref().is_some_and(|r| r == [1.0]);
    Ok((rd, sd, rgb))
}

impl SsArgs {
    /// The parameters with the material `mat`, `None` for the seed model
    /// without `--sd`; checked. `PCSSS_NO_AVX2` in the environment forces
    /// the baseline pair loop.
    pub fn params(&self, mat: &MaterialArgs) -> anyhow::Result<Option<Params>> {
        let medium = mat.medium()?;
        let sd = match (self.sd, medium) {
            (Some(sd), _) => sd,
            (None, Some(_)) => 1.0,
            (None, None) => return Ok(None),
        };
        let params = Params {
            rd: parse_rgb("--rd", self.rd.as_deref().unwrap_or("1,1,1"))?,
            sd,
            bounce: self.bounce,
            rgb: self.rgb,
            falloff: Falloff::new(self.falloff, self.sigma),
            norm: self.norm,
            tolerance: self.tolerance,
            simd: if env_flag("PCSSS_NO_AVX2") {
                Simd::Baseline
            } else {
                Simd::Auto
            },
            medium,
        };
        ssmulti::validate(&params)?;
        Ok(Some(params))
    }
}

/// Numbers separated by commas, the value of option `flag`.
fn parse_list(flag: &str, s: &str) -> anyhow::Result<Vec<f64>> {
    Ok(s.split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| crate::Error::param(flag, format!("'{s}': {e}")))?)
}

/// `X,Y,Z`, the value of option `flag` (named in errors).
pub fn parse_xyz(flag: &str, s: &str) -> anyhow::Result<[f64; 3]> {
    match parse_list(flag, s)?[..] {
        [x, y, z] => Ok([x, y, z]),
        _ => Err(crate::Error::param(flag, format!("'{s}' is not X,Y,Z")).into()),
    }
}

/// `R,G,B` or one value for all three, the value of option `flag`
/// (named in errors).
pub fn parse_rgb(flag: &str, s: &str) -> anyhow::Result<[f64; 3]> {
    match parse_list(flag, s)?[..] {
        [x] => Ok([x; 3]),
        [r, g, b] => Ok([r, g, b]),
        _ => Err(crate::Error::param(flag, format!("'{s}' is not R,G,B or one value")).into()),
    }
}

/// A size in bytes, the value of option `flag`: `2G`, `512M`, `64K`
/// (powers of 1024), or bytes.
pub fn parse_bytes(flag: &str, s: &str) -> anyhow::Result<u64> {
    let bad = || crate::Error::param(flag, format!("'{s}': a size > 0 such as 2G, 512M or bytes"));
    let t = s.trim();
    let (num, mul) = match t.chars().last() {
        Some(c) if c.is_ascii_alphabetic() => {
            let m: u64 = match c.to_ascii_uppercase() {
                'K' => 1 << 10,
                'M' => 1 << 20,
                'G' => 1 << 30,
                'T' => 1 << 40,
                _ => return Err(bad().into()),
            };
            (&t[..t.len() - 1], m)
        }
        _ => (t, 1),
    };
    let x: f64 = num.parse().map_err(|_| bad())?;
    if !(x.is_finite() && x >= 1.0 && x * (mul as f64) < 1e18) {
        return Err(bad().into());
    }
    Ok((x * mul as f64) as u64)
}

/// Single scattering at every point for one eye (Marengo's ssIntegSingle,
/// or Jensen et al.'s physical model): light refracted into the surface,
/// scattered once towards the eye and refracted out. Reads P and N; adds
/// ssS. The maths: docs/DESIGN.md#sssingle.
#[derive(Parser, Debug)]
#[command(version, allow_negative_numbers = true)]
#[command(group = clap::ArgGroup::new("view").required(true).args(["eye", "camera"]))]
pub struct SssingleArgs {
    #[command(flatten)]
    pub io: IoArgs,
    /// The mesh the points lie on (where light enters, and the far side).
    #[arg(long, value_name = "MESH")]
    pub mesh: PathBuf,
    /// The lights (JSON, formats/LIGHTS.md), as illum's.
    #[arg(long, value_name = "FILE")]
    pub lights: PathBuf,
    /// Lights to use: names and glob patterns, separated by commas or
    /// spaces; ^PATTERN excludes ('*': all).
    #[arg(long, value_name = "PATTERNS", default_value = "*")]
    pub lmask: String,
    /// The eye: X,Y,Z (e.g. --eye=-3,4,5).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub eye: Option<String>,
    /// The eye of a camera file (formats/CAMERA.md).
    #[arg(long, value_name = "FILE")]
    pub camera: Option<PathBuf>,
    /// Seed model: diffuse reflectance R,G,B (or one value) [default:
    /// the cloud's ssmulti_rd, else 1,1,1].
    #[arg(long, value_name = "R,G,B")]
    pub rd: Option<String>,
    /// Seed model: scattering distance (per channel: Rd * sd) [default:
    /// the cloud's ssmulti_sd].
    #[arg(long, value_name = "D")]
    pub sd: Option<f64>,
    /// Seed model: per-channel distances (Marengo's t_rgb) [default: the
    /// cloud's ssmulti_rgb].
    #[arg(long)]
    pub rgb: bool,
    #[command(flatten)]
    pub single: SingleArgs,
    #[command(flatten)]
    pub material: MaterialArgs,
}

/// Light arriving at every point (Houdini's pcIllum): illum = sum over
/// the lights in the mask of Cl * max(0, N.L) * visibility, visibility from
/// shadow rays against --mesh.
#[derive(Parser, Debug)]
#[command(version)]
#[command(group = clap::ArgGroup::new("shadows").required(true).args(["mesh", "no_shadows"]))]
pub struct IllumArgs {
    #[command(flatten)]
    pub io: IoArgs,
    /// The lights (JSON, formats/LIGHTS.md).
    #[arg(long, value_name = "FILE")]
    pub lights: PathBuf,
    /// The mesh that casts shadows (usually the one the points lie on).
    #[arg(long, value_name = "MESH")]
    pub mesh: Option<PathBuf>,
    /// No shadows: every light reaches every point that faces it.
    #[arg(long)]
    pub no_shadows: bool,
    /// Also write `thickness`, how far the mesh goes on behind each point
    /// (along -N): the physical model of ssmulti returns less light from
    /// thin parts. Needs --mesh.
    #[arg(long)]
    pub thickness: bool,
    /// Also the light the rest of the surface sends each point (one
    /// bounce between surfaces), gathered by RAYS rays a point from the
    /// input's ssM (a cloud ssmulti --model physical has run on): run
    /// ssmulti again on the output. Needs --mesh.
    #[arg(long, value_name = "RAYS", value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub indirect: Option<u32>,
    /// Lights to use: names and glob patterns, separated by commas or
    /// spaces; ^PATTERN excludes ('*': all).
    #[arg(long, value_name = "PATTERNS", default_value = "*")]
    pub lmask: String,
    /// Seed of the area lights' sample offsets and the indirect rays.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// The medium (--model physical): shadows then let through the light
    /// that crosses the mesh's inside unscattered.
    #[command(flatten)]
    pub material: MaterialArgs,
}
