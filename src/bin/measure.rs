//! `measure`: adds face attributes `area` and `perimeter` to a mesh.

use std::process::ExitCode;

use clap::Parser;
use pcsss::cli::{self, IoArgs};
use pcsss::formats::Select;

pcsss::global_allocator!();

/// Add face attributes `area` and `perimeter` to a mesh (Houdini's Measure
/// SOP). Degenerate faces measure 0.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    #[command(flatten)]
    io: IoArgs,
}

fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("measure");
    let mut mesh = args.io.read(&Select::only(&["P"]))?;
    let rep = pcsss::stages::measure::measure(&mut mesh).map_err(cli::at(&args.io.input_name()))?;
    msg.info(format!(
        "{} faces, total area {} ({} degenerate)",
        rep.faces, rep.total_area, rep.degenerate
    ));
    args.io.write(&mesh)
}

fn main() -> ExitCode {
    cli::main("measure", run)
}
