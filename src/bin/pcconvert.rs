//! `pcconvert`: rewrites a cloud or mesh in another format or encoding
//! (PLY binary/ASCII/big-endian; OBJ in). Every element, attribute and
//! detail attribute passes through unchanged.

use std::process::ExitCode;

use clap::Parser;
use pcsss::cli::{self, IoArgs};
use pcsss::formats::Select;

pcsss::global_allocator!();

/// Convert a point cloud or mesh between formats and encodings, keeping
/// every element, attribute and detail attribute.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    #[command(flatten)]
    io: IoArgs,
}

fn run(args: Args) -> anyhow::Result<()> {
    // Nothing is decoded that the writer can copy through as bytes.
    let cloud = args.io.read(&Select::only(&[]))?;
    args.io.write(&cloud)
}

fn main() -> ExitCode {
    cli::main("pcconvert", run)
}
