//! `measure`: adds face attributes `area` and `perimeter` to a mesh.

use crate::cli::{self, IoArgs};
use crate::formats::Select;
use clap::Parser;

/// Add face attributes `area` and `perimeter` to a mesh (Houdini's Measure
/// SOP). Degenerate faces measure 0.
#[derive(Parser, Debug)]
#[command(version)]
pub struct Args {
    #[command(flatten)]
    pub io: IoArgs,
}

/// Runs the stage: reads its input, works, writes its output.
pub fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("measure");
    let mut mesh = args.io.read(&Select::only(&["P"]))?;
    let rep = crate::stages::measure::measure(&mut mesh).map_err(cli::at(&args.io.input_name()))?;
    msg.info(format!(
        "{} faces, total area {} ({} degenerate)",
        rep.faces, rep.total_area, rep.degenerate
    ));
    args.io.write_owned(mesh)
}
