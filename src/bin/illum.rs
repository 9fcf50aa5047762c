//! `illum`: direct irradiance at every point from a lights file, with
//! shadows from a mesh.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use pcsss::cli::{self, IoArgs};
use pcsss::formats::Select;
use pcsss::geom::bvh::Occluder;
use pcsss::stages::illum;

pcsss::global_allocator!();

/// Light arriving at every point (Houdini's pcIllum): illum = sum over
/// the lights in the mask of Cl * max(0, N.L) * visibility, visibility from
/// shadow rays against --mesh.
#[derive(Parser, Debug)]
#[command(version)]
#[command(group = clap::ArgGroup::new("shadows").required(true).args(["mesh", "no_shadows"]))]
struct Args {
    #[command(flatten)]
    io: IoArgs,
    /// The lights (JSON, formats/LIGHTS.md).
    #[arg(long, value_name = "FILE")]
    lights: PathBuf,
    /// The mesh that casts shadows (usually the one the points lie on).
    #[arg(long, value_name = "MESH")]
    mesh: Option<PathBuf>,
    /// No shadows: every light reaches every point that faces it.
    #[arg(long)]
    no_shadows: bool,
    /// Lights to use: names and glob patterns, separated by commas or
    /// spaces; ^PATTERN excludes ('*': all).
    #[arg(long, value_name = "PATTERNS", default_value = "*")]
    lmask: String,
    /// Seed of the area lights' sample offsets.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("illum");
    let name = args.io.input_name();
    let used = cli::read_lights(&args.lights, &args.lmask)?;
    // The mesh first: a missing or broken mesh fails before the cloud is read.
    let occluder = match &args.mesh {
        Some(path) => Some(Occluder::new(&cli::read_mesh(path)?)),
        None => None,
    };
    let mut cloud = args.io.read(&Select::only(&["P", "N"]))?;
    let progress = msg.progress();
    let rep = illum::illum(&mut cloud, &used, occluder.as_ref(), args.seed, &progress)
        .map_err(cli::at(&name))?;
    let names: Vec<&str> = used.iter().map(|l| l.name.as_str()).collect();
    msg.info(format!(
        "{} points, lights {}: {} shadow rays, {} blocked; {} points unlit",
        rep.points,
        names.join(", "),
        rep.rays,
        rep.blocked,
        rep.dark
    ));
    args.io.write(&cloud)
}

fn main() -> ExitCode {
    cli::main("illum", run)
}
