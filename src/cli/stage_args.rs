//! `pctile split --for STAGE --stage-args ARGS`: a stage's own options,
//! parsed as the stage parses them, into the parameters that set its
//! reach ([`crate::tiles::reach`]).

use clap::{CommandFactory, Parser};

use super::args::{MaterialArgs, PerPointArgs, SsArgs};
use crate::error::Error;
use crate::tiles::reach::{Stage, StageParams};

/// `ssmulti`'s options.
#[derive(Parser, Debug)]
#[command(no_binary_name = true, allow_negative_numbers = true)]
struct Multi {
    #[command(flatten)]
    io: super::IoArgs,
    #[command(flatten)]
    ss: SsArgs,
    #[command(flatten)]
    mat: MaterialArgs,
    #[command(flatten)]
    per_point: PerPointArgs,
    // (A walk's reach is the diffusion method's: the halo it asks for.)
    #[command(flatten)]
    _walk: super::args::WalkArgs,
}

/// The options of `filter` that set its reach; the others are skipped.
#[derive(Parser, Debug)]
#[command(
    no_binary_name = true,
    ignore_errors = true,
    allow_negative_numbers = true
)]
struct Filter {
    #[arg(long)]
    nfp: Option<usize>,
    #[arg(long)]
    radius: Option<f64>,
    #[command(flatten)]
    ss: SsArgs,
    #[command(flatten)]
    mat: MaterialArgs,
}

/// The parameters of `stage` given `args` (its words); an error is about
/// `--stage-args` (or `--for`, for a stage it does not know).
pub fn parse(stage: Stage, args: &[String]) -> anyhow::Result<StageParams> {
    parse_in(stage, args, None)
}

/// [`parse`] in a scene whose unit is `unit_mm` millimetres long (a
/// preset's lengths in it: [`crate::medium::Given::in_scene`]).
pub fn parse_in(
    stage: Stage,
    args: &[String],
    unit_mm: Option<f64>,
) -> anyhow::Result<StageParams> {
    let bad = |e: clap::Error| {
        let text = e.render().to_string();
        let line = text.lines().next().unwrap_or("");
        let line = line.trim_start_matches("error: ");
        Error::param("stage_args", format!("{}: {line}", stage.name()))
    };
    Ok(match stage {
        Stage::Ssmulti => {
            let a = Multi::try_parse_from(args).map_err(bad)?;
            let per_point = a.per_point.given().map_err(|e| within(stage, e))?;
            let given = ss_given(&a.ss, &a.mat, per_point, unit_mm);
            // (Checked as ssmulti checks them, its per-point parameters
            // too; a group's reach beyond these parameters' is refused by
            // the tile's halo check, naming both.)
            match given.and_then(|g| Ok(g.resolve()?)) {
                Ok(Some(plan)) => StageParams::Ssmulti(plan.params),
                Ok(None) => {
                    return Err(Error::param(
                        "stage_args",
                        "ssmulti needs --sd (or --model physical)",
                    )
                    .into())
                }
                Err(e) => return Err(within(stage, e)),
            }
        }
        Stage::Filter => {
            let a = Filter::try_parse_from(args).map_err(bad)?;
            let given = ss_given(&a.ss, &a.mat, None, unit_mm);
            StageParams::Filter {
                nfp: a.nfp,
                radius: a.radius,
                multi: given
                    .and_then(|g| Ok(g.params()?))
                    .map_err(|e| within(stage, e))?,
            }
        }
        // Their reach is 0 whatever they are given, but what they are
        // given must be theirs: parsed by their own command lines (the
        // input, output and files they name may be left out).
        Stage::Sssingle => {
            checked::<super::SssingleArgs>(args, &["view"]).map_err(bad)?;
            StageParams::Local
        }
        Stage::Illum => {
            checked::<super::IllumArgs>(args, &["shadows"]).map_err(bad)?;
            StageParams::Local
        }
    })
}

/// ssmulti's options given, the material's lengths in a scene whose unit
/// is `unit_mm` millimetres long.
fn ss_given(
    ss: &SsArgs,
    mat: &MaterialArgs,
    per_point: Option<crate::stages::ssmulti::per_point::PerPoint>,
    unit_mm: Option<f64>,
) -> anyhow::Result<crate::stages::ssmulti::Given> {
    let mut medium = mat.given()?;
    medium.in_scene(unit_mm);
    ss.given(medium, per_point)
}

/// Parses `args` with `T`'s command line, nothing required (its required
/// arguments and the groups `groups` relaxed): the options are the
/// stage's own and their values of their types.
fn checked<T: clap::Parser>(args: &[String], groups: &[&str]) -> Result<(), clap::Error> {
    let mut cmd = T::command()
        .no_binary_name(true)
        .allow_negative_numbers(true)
        .mut_args(|a| a.required(false));
    for g in groups {
        cmd = cmd.mut_group(*g, |g| g.required(false));
    }
    cmd.try_get_matches_from(args).map(|_| ())
}

/// The option of `stage` that sets its parameter `name` (`--radius`).
fn stage_flag(stage: Stage, name: &str) -> Option<String> {
    let cmd = match stage {
        Stage::Ssmulti => Multi::command(),
        Stage::Filter => Filter::command(),
        Stage::Sssingle | Stage::Illum => return None,
    };
    super::flag_of(&cmd, name)
}

/// The option of `stage` that sets its parameter `name`, as
/// `--stage-args --radius`: how `pctile` names a stage's parameter.
pub fn flag_of(stage: Stage, name: &str) -> Option<String> {
    stage_flag(stage, name).map(|f| format!("--stage-args {f}"))
}

/// A stage's parameter error, as an error about `--stage-args`.
fn within(stage: Stage, e: anyhow::Error) -> anyhow::Error {
    match e.downcast::<Error>() {
        Ok(mut lib) => {
            lib.rename_params(&|name| stage_flag(stage, name));
            Error::param("stage_args", format!("{}: {lib}", stage.name())).into()
        }
        Err(e) => e,
    }
}
