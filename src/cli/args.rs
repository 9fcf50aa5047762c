//! The options several stages share: ssmulti's (`ssmulti`, and `filter`
//! and `render` to compute `ssM` lazily), sssingle's model (`sssingle`,
//! `filter`, `render`), and the parsers of `R,G,B` and `X,Y,Z` values;
//! and the whole command lines of `sssingle` and `illum`, which `pctile
//! split --for` parses too.

use std::path::PathBuf;

use clap::Parser;

use super::{env_flag, IoArgs};
use crate::medium::{self, Model};
use crate::stages::filter;
use crate::stages::ssmulti::{self, FalloffKind, Norm, Simd};
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
    /// `ssS` made as `lazy` says; how the reach was chosen is a debug
    /// message.
    pub fn setup<'a>(
        &self,
        cloud: &crate::cloud::Cloud,
        cloud_name: &str,
        attrs: &'a [String],
        lazy: filter::Lazy<'a>,
        msg: &super::Messages,
    ) -> anyhow::Result<filter::Setup<'a>> {
        let setup = filter::Setup::new(cloud, attrs, lazy, self.nfp, self.radius, self.facing)
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
    /// kernel's length scale (Burley, the physical model's: T times its
    /// distance, and its error at most about T^2 of a receiver's sum lit
    /// over its disk); the error grows like T^2 (docs/DESIGN.md,
    /// "Approximate method"; docs/PERFORMANCE.md, "ssmulti").
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
}

/// `ssmulti`'s method (also read by `pctile split --for ssmulti
/// --stage-args`).
#[derive(clap::Args, Debug, Clone)]
pub struct WalkArgs {
    /// How ssM is computed: diffusion (a kernel over the cloud's
    /// neighbours), or walk (random walks through --mesh from each point:
    /// the physical model on any closed shape, docs/DESIGN.md, "The walk
    /// method").
    #[arg(long, value_enum, default_value = "diffusion")]
    pub method: ssmulti::Method,
    /// The walk method: the mesh the points lie on (closed).
    #[arg(long, value_name = "MESH", required_if_eq("method", "walk"))]
    pub mesh: Option<PathBuf>,
    /// The walk method: walks a point (1 to 1048576).
    #[arg(long, value_name = "N", default_value_t = 64)]
    pub walks: u32,
    /// The walk method: the seed of every point's random stream.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// The walk method: filter the walks' noise on the cloud, among
    /// neighbours that face alike and whose estimates agree within their
    /// noise (ssM_err holds each point's, unfiltered).
    #[arg(long)]
    pub denoise: bool,
    /// The walk method: sample these lights (illum's, JSON or USD) at the
    /// walks' scattering events, rather than take their light from illum
    /// where a walk leaves (docs/DESIGN.md, "The light a walk takes").
    #[arg(long, value_name = "FILE")]
    pub lights: Option<PathBuf>,
    /// With --lights: the lights to use, as illum's --lmask.
    #[arg(long, value_name = "PATTERNS", default_value = "*")]
    pub lmask: String,
    /// The walk method: walk from the direction of this eye, X,Y,Z:
    /// ssM is then the light towards it (exact at edges and for any
    /// light; render takes it as it is), baked for that eye as sssingle's
    /// ssS is (docs/DESIGN.md, "The exit").
    #[arg(
        long,
        value_name = "X,Y,Z",
        allow_hyphen_values = true,
        conflicts_with = "camera"
    )]
    pub eye: Option<String>,
    /// The walk method: --eye at a camera file's position (formats/CAMERA.md).
    #[arg(long, value_name = "FILE")]
    pub camera: Option<PathBuf>,
}

/// The walk method for the `ssM` that `filter` and `render` compute
/// lazily (as `ssmulti --method walk` does for the whole cloud).
#[derive(clap::Args, Debug, Clone)]
pub struct LazyWalkArgs {
    /// Lazy ssM: how it is computed, diffusion (a kernel) or walk (random
    /// walks through --walk-mesh, render's --mesh without it).
    #[arg(long, value_enum, default_value = "diffusion")]
    pub method: ssmulti::Method,
    /// Lazy ssM by walks: the closed mesh the cloud's points lie on.
    #[arg(long, value_name = "MESH")]
    pub walk_mesh: Option<PathBuf>,
    /// Lazy ssM by walks: walks a point (1 to 1048576).
    #[arg(long, value_name = "N", default_value_t = 64)]
    pub walks: u32,
    /// Lazy ssM by walks: the seed of every point's random stream.
    #[arg(long, value_name = "S", default_value_t = 0)]
    pub walk_seed: u64,
    /// Lazy ssM by walks: filter the walks' noise on the cloud.
    #[arg(long)]
    pub denoise: bool,
    /// Lazy ssM by walks: sample these lights at the walks' events, as
    /// ssmulti --lights.
    #[arg(long, value_name = "FILE")]
    pub walk_lights: Option<PathBuf>,
    /// With --walk-lights: the lights to use, as illum's --lmask.
    #[arg(long, value_name = "PATTERNS", default_value = "*")]
    pub walk_lmask: String,
}

impl LazyWalkArgs {
    /// The lights the lazy walks sample (`--walk-lights`), moved into the
    /// cloud's `frame`; none without it.
    pub fn lights(
        &self,
        frame: &crate::frame::Frame,
    ) -> anyhow::Result<Option<Vec<crate::lights::Light>>> {
        match &self.walk_lights {
            None => Ok(None),
            Some(path) => {
                let file = super::read_lights(path, &self.walk_lmask)
                    .map_err(|e| super::as_param(e, "walk_lmask"))?;
                Ok(Some(file.in_frame(frame)))
            }
        }
    }

    /// The walks asked for (none for the diffusion method), checked, and
    /// the mesh they go through: `--walk-mesh`, else `default`; without
    /// either, an error naming `--walk-mesh`.
    pub fn given(
        &self,
        default: Option<&std::path::Path>,
    ) -> anyhow::Result<Option<(PathBuf, ssmulti::walk::WalkParams)>> {
        if self.method != ssmulti::Method::Walk {
            return Ok(None);
        }
        let w = ssmulti::walk::WalkParams {
            walks: self.walks,
            seed: self.walk_seed,
            denoise: self.denoise,
            eye: None,
        };
        ssmulti::walk::validate(&w)?;
        let mesh = match (&self.walk_mesh, default) {
            (Some(m), _) => m.clone(),
            (None, Some(m)) => m.to_path_buf(),
            (None, None) => {
                let why = "lazy ssM by walks needs the mesh the points lie on";
                return Err(crate::Error::param("walk_mesh", why).into());
            }
        };
        Ok(Some((mesh, w)))
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
    /// The seed model's per-point parameters given (the physical model's
    /// are in its material).
    pub fn given(&self) -> anyhow::Result<Option<ssmulti::per_point::PerPoint>> {
        let pp = self.per_point.as_deref();
        Ok(pp
            .map(|list| ssmulti::per_point::PerPoint::parse(list, self.levels))
            .transpose()?)
    }
}

impl MaterialArgs {
    /// What the options give of the medium: the values parsed, the
    /// material file read (once: a stage keeps what this returns). The
    /// library decides the medium from it ([`medium::Given::resolve`]).
    pub fn given(&self) -> anyhow::Result<medium::Given> {
        let rgb = |flag: &str, v: &Option<String>| -> anyhow::Result<Option<[f64; 3]>> {
            v.as_deref().map(|x| parse_rgb(flag, x)).transpose()
        };
        let options = medium::Spec {
            source: "the options".into(),
            albedo: rgb("--albedo", &self.albedo)?,
            color: rgb("--color", &self.color)?,
            mfp: rgb("--mfp", &self.mfp)?,
            dmfp: rgb("--dmfp", &self.dmfp)?,
            eta: self.eta,
            g: self.g,
            ..medium::Spec::default()
        };
        let material = self
            .material
            .as_deref()
            .map(medium::material::load)
            .transpose()?;
        Ok(medium::Given {
            model: self.model,
            material,
            options,
        })
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
    /// What the options give, with the medium `medium` and the seed
    /// model's `rd`, `sd` and `rgb` (ssmulti's options, or sssingle's
    /// own); [`sssingle::Params::resolve`] decides.
    pub fn given(
        &self,
        medium: medium::Given,
        rd: Option<&str>,
        sd: Option<f64>,
        rgb: bool,
    ) -> anyhow::Result<sssingle::Given> {
        Ok(sssingle::Given {
            medium,
            rd: rd.map(|r| parse_rgb("--rd", r)).transpose()?,
            sd,
            rgb,
            samples: self.samples,
            seed: self.seed,
            cusp: self.cusp,
            shadows: !self.no_shadows,
        })
    }

    /// Lazy `ssS` (filter's and render's): the parameters for the eye
    /// `eye` from these options and the cloud's record of ssmulti's run
    /// (ssmulti's `ss` options give the seed model's Rd, sd and t_rgb),
    /// and the lights of `file` moved into `frame`.
    pub fn lazy(
        &self,
        medium: &medium::Given,
        ss: &SsArgs,
        eye: [f64; 3],
        cloud: &crate::cloud::Cloud,
        file: &crate::lights::LightsFile,
        frame: &crate::frame::Frame,
    ) -> anyhow::Result<(sssingle::Params, Vec<crate::lights::Light>)> {
        let given = self.given(medium.clone(), ss.rd.as_deref(), ss.sd, ss.rgb)?;
        let record = ssmulti::Record::of(cloud);
        let eye = glam::DVec3::from_array(eye);
        let params = sssingle::Params::resolve(&given, eye, &record)?;
        Ok((params, file.in_frame(frame)))
    }
}

impl SsArgs {
    /// What the options give, with the medium `medium` and the seed
    /// model's per-point parameters `per_point`; [`ssmulti::Given::resolve`]
    /// decides. `PCSSS_NO_AVX2` in the environment forces the baseline
    /// pair loop.
    pub fn given(
        &self,
        medium: medium::Given,
        per_point: Option<ssmulti::per_point::PerPoint>,
    ) -> anyhow::Result<ssmulti::Given> {
        Ok(ssmulti::Given {
            rd: self
                .rd
                .as_deref()
                .map(|r| parse_rgb("--rd", r))
                .transpose()?,
            sd: self.sd,
            bounce: self.bounce,
            rgb: self.rgb,
            falloff: self.falloff,
            sigma: self.sigma,
            norm: self.norm,
            tolerance: self.tolerance,
            simd: if env_flag("PCSSS_NO_AVX2") {
                Simd::Baseline
            } else {
                Simd::Auto
            },
            medium,
            per_point,
            walk: false,
        })
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
    /// With --indirect: the exitance from this cloud's points (ssM, illum,
    /// illum_cos: a coarser cloud on the same mesh, lit by the same
    /// lights, that ssmulti ran on) rather than from the input's, which
    /// then needs no ssM.
    #[arg(long, value_name = "CLOUD", requires = "indirect")]
    pub exitance: Option<std::path::PathBuf>,
    /// With --exitance: cast the rays at the exitance cloud's points (it
    /// needs N) and carry the light they gather to the input's points by
    /// their nearest 8 facing the same way: the rays of the coarser cloud
    /// alone, each point's light averaged over several points' rays.
    #[arg(long, requires = "exitance")]
    pub gather_at_exitance: bool,
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
