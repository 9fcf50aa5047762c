//! The halo a stage needs (`pctile split --for STAGE`): the farthest a
//! source can be from a point the stage computes, which each stage states
//! from its own parameters ([`ssmulti::Params::reach`],
//! [`filter::halo_reach`]).

use crate::cloud::{Cloud, Detail};
use crate::error::{Error, Result};
use crate::stages::filter::{self, Source};
use crate::stages::ssmulti;

/// What `--for` adds to a stage's reach, relatively: the stages compare
/// distances in f32 relative to their leaves (1.2e-7 of a leaf's size),
/// so a source at the reach to f64 may be inside it to the stage; with
/// the exp and Burley falloffs, truncated with a step, it would count.
pub const MARGIN: f64 = 1e-5;

/// The stages a split can be for (`pctile split --for`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Stage {
    Ssmulti,
    Filter,
    Sssingle,
    Illum,
}

impl Stage {
    /// Every stage, in `--for`'s order.
    pub const ALL: [Stage; 4] = [Stage::Ssmulti, Stage::Filter, Stage::Sssingle, Stage::Illum];

    /// Its name: the binary's, and what a manifest records.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Ssmulti => "ssmulti",
            Stage::Filter => "filter",
            Stage::Sssingle => "sssingle",
            Stage::Illum => "illum",
        }
    }

    /// The stage a manifest names.
    pub fn from_name(name: &str) -> Option<Stage> {
        Stage::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// A split's `--stage-args`, split into the stage's words as a POSIX
/// shell splits a line (quotes and backslashes: `--material "my
/// skin.json"` is two words), which is how the tile's own run gets them
/// through make, Slurm and Open Job Description (`tile-task.sh`).
pub fn stage_words(args: &str) -> Result<Vec<String>> {
    shlex::split(args).ok_or_else(|| {
        Error::param(
            "stage_args",
            format!("{args:?}: a quote is not closed (or a backslash ends it)"),
        )
    })
}

/// A stage `--for` names, with the parameters that set its reach.
#[derive(Clone, Debug, PartialEq)]
pub enum StageParams {
    Ssmulti(ssmulti::Params),
    /// `filter`: the `nfp` nearest (no bound), or the points within
    /// `radius` of D; with ssmulti's parameters when given (D, and `ssM`
    /// computed lazily on a cloud without it).
    Filter {
        nfp: Option<usize>,
        radius: Option<f64>,
        multi: Option<ssmulti::Params>,
    },
    /// `sssingle` and `illum`: a point's value needs only the lights and
    /// the mesh, no other point.
    Local,
}

/// The halo `stage` needs on a cloud with the details `detail` (a filter
/// radius may come from `ssmulti_sd`) that has `ssM` or not (without it,
/// `filter` computes it lazily, and reaches a kernel farther).
pub fn reach_for(stage: &StageParams, detail: &[Detail], has_ssm: bool) -> Result<f64> {
    match stage {
        StageParams::Ssmulti(p) => Ok(p.reach()),
        StageParams::Filter { nfp, radius, multi } => {
            let cloud = Cloud {
                detail: detail.to_vec(),
                ..Cloud::default()
            };
            let (read, _) = filter::reach(&cloud, *nfp, *radius, multi.as_ref(), None)?;
            let lazy: Vec<Source> = match multi {
                Some(p) if !has_ssm => vec![Source::Multi(p, None)],
                _ => Vec::new(),
            };
            filter::halo_reach(read, &lazy).ok_or_else(|| {
                Error::param(
                    "nfp",
                    "has no bounded reach (the nearest points can be anywhere): give a radius",
                )
            })
        }
        StageParams::Local => Ok(0.0),
    }
}
