//! The halo a stage needs (`pctile split --for STAGE --stage-args ...`):
//! the farthest a source can be from a point the stage computes, with
//! the stage's own arguments.

use clap::Parser;

use crate::cli::args::SsArgs;
use crate::cloud::{Cloud, Detail};
use crate::stages::{filter, ssmulti};

/// What `--for` adds to a stage's reach, relatively: the stages compare
/// distances in f32 relative to their leaves (1.2e-7 of a leaf's size),
/// so a source at the reach to f64 may be inside it to the stage; with
/// the exp and Burley falloffs, truncated with a step, it would count.
pub const MARGIN: f64 = 1e-5;

/// The stages `--for` knows.
pub const STAGES: &str = "ssmulti, filter, sssingle, illum";

#[derive(Parser, Debug)]
#[command(no_binary_name = true)]
struct Multi {
    #[command(flatten)]
    io: crate::cli::IoArgs,
    #[command(flatten)]
    ss: SsArgs,
}

/// The options of `filter` that set its reach; the others are skipped.
#[derive(Parser, Debug)]
#[command(no_binary_name = true, ignore_errors = true)]
struct Filter {
    #[arg(long)]
    nfp: Option<usize>,
    #[arg(long, default_value_t = 0.25)]
    radius: f64,
    #[command(flatten)]
    ss: SsArgs,
}

/// `ssmulti`'s reach with parameters `p`: the kernel's truncation.
pub fn ssmulti_reach(p: &ssmulti::Params) -> f64 {
    let ld1 = p.rd.iter().copied().fold(0.0, f64::max) * p.sd;
    ssmulti::reach(p.falloff, ld1)
}

/// The halo `stage` needs when run with `args`, on a cloud with the
/// details `detail` (a filter radius may come from `ssmulti_sd`) that has
/// `ssM` or not (without it, `filter` computes it lazily, and reaches a
/// kernel farther).
pub fn reach_for(
    stage: &str,
    args: &[String],
    detail: &[Detail],
    has_ssm: bool,
) -> anyhow::Result<f64> {
    let bad = |e: clap::Error| {
        let text = e.render().to_string();
        let line = text
            .lines()
            .next()
            .unwrap_or("")
            .trim_start_matches("error: ")
            .to_string();
        crate::Error::param("--stage-args", format!("{stage}: {line}"))
    };
    match stage {
        "ssmulti" => {
            let a = Multi::try_parse_from(args).map_err(bad)?;
            match a.ss.params()? {
                Some(p) => Ok(ssmulti_reach(&p)),
                None => Err(crate::Error::param("--stage-args", "ssmulti needs --sd").into()),
            }
        }
        "filter" => {
            let a = Filter::try_parse_from(args).map_err(bad)?;
            if a.nfp.is_some() {
                return Err(crate::Error::param(
                    "--stage-args",
                    "filter --nfp has no bounded reach (the nearest points can be anywhere): give --radius",
                )
                .into());
            }
            let multi = a.ss.params()?;
            let cloud = Cloud {
                elements: Vec::new(),
                detail: detail.to_vec(),
                comments: Vec::new(),
                obj_info: Vec::new(),
            };
            let d = filter::distance(&cloud, multi.as_ref(), None)?;
            if !(a.radius.is_finite() && a.radius > 0.0) {
                return Err(crate::Error::param(
                    "--radius",
                    format!("{}: must be a finite fraction > 0", a.radius),
                )
                .into());
            }
            let lazy = match (&multi, has_ssm) {
                (Some(p), false) => ssmulti_reach(p),
                _ => 0.0,
            };
            Ok(a.radius * d + lazy)
        }
        // Both compute a point from the lights and the mesh only.
        "sssingle" | "illum" => Ok(0.0),
        _ => Err(crate::Error::param(
            "--for",
            format!("unknown stage '{stage}' (one of: {STAGES})"),
        )
        .into()),
    }
}
