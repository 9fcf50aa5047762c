//! `ssmulti`: multiple scattering `ssM` at every cloud point.

use std::process::ExitCode;

use clap::Parser;
use pcsss::cli::{self, IoArgs, SsArgs};
use pcsss::formats::Select;
use pcsss::stages::ssmulti;

pcsss::global_allocator!();

/// Multiple scattering at every point (Marengo's ssIntegMulti): reads P,
/// N, ptarea, illum; adds ssM.
#[derive(Parser, Debug)]
#[command(version, allow_negative_numbers = true)]
#[command(mut_arg("sd", |a| a.required(true)))]
struct Args {
    #[command(flatten)]
    io: IoArgs,
    #[command(flatten)]
    ss: SsArgs,
}

fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("ssmulti");
    let name = args.io.input_name();
    let params = args.ss.params()?.expect("clap requires --sd");
    // Parameters before reading: an absurd one fails fast.
    ssmulti::validate(&params)?;
    let mut cloud = args
        .io
        .read(&Select::only(&["P", "N", "ptarea", "illum"]))?;
    let progress = msg.progress();
    let rep = ssmulti::ssmulti(&mut cloud, &params, &progress).map_err(cli::at(&name))?;
    msg.info(format!(
        "{} points, {} sources, {} pairs{}",
        rep.points,
        rep.sources,
        rep.pairs,
        if rep.grey {
            " (white light: one channel)"
        } else {
            ""
        }
    ));
    args.io.write(&cloud)
}

fn main() -> ExitCode {
    cli::main("ssmulti", run)
}
