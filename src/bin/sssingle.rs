//! `sssingle`: single scattering `ssS` at every point, for one eye.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use pcsss::cli::{self, IoArgs, SingleArgs};
use pcsss::formats::Select;
use pcsss::stages::sssingle;

pcsss::global_allocator!();

/// Single scattering at every point for one eye (Marengo's ssIntegSingle,
/// or Jensen et al.'s physical model): light refracted into the surface,
/// scattered once towards the eye and refracted out. Reads P and N; adds
/// ssS. The maths: docs/DESIGN.md#sssingle.
#[derive(Parser, Debug)]
#[command(version, allow_negative_numbers = true)]
#[command(group = clap::ArgGroup::new("view").required(true).args(["eye", "camera"]))]
struct Args {
    #[command(flatten)]
    io: IoArgs,
    /// The mesh the points lie on (where light enters, and the far side).
    #[arg(long, value_name = "MESH")]
    mesh: PathBuf,
    /// The lights (JSON, formats/LIGHTS.md), as illum's.
    #[arg(long, value_name = "FILE")]
    lights: PathBuf,
    /// Lights to use: names and glob patterns, separated by commas or
    /// spaces; ^PATTERN excludes ('*': all).
    #[arg(long, value_name = "PATTERNS", default_value = "*")]
    lmask: String,
    /// The eye: X,Y,Z (e.g. --eye=-3,4,5).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    eye: Option<String>,
    /// The eye of a camera file (formats/CAMERA.md).
    #[arg(long, value_name = "FILE")]
    camera: Option<PathBuf>,
    /// Seed model: diffuse reflectance R,G,B (or one value).
    #[arg(long, value_name = "R,G,B", default_value = "1,1,1")]
    rd: String,
    /// Seed model: scattering distance (per channel: Rd * sd).
    #[arg(long, value_name = "D")]
    sd: Option<f64>,
    /// Seed model: per-channel distances (Marengo's t_rgb).
    #[arg(long)]
    rgb: bool,
    #[command(flatten)]
    single: SingleArgs,
}

fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("sssingle");
    let name = args.io.input_name();
    let eye = match (&args.eye, &args.camera) {
        (Some(e), _) => cli::parse_xyz("--eye", e)?,
        (None, Some(cam)) => cli::read_camera(cam)?.position,
        (None, None) => unreachable!("clap requires one"),
    };
    // Parameters and the lights before the geometry: a bad one fails fast.
    let params = args.single.params(&args.rd, args.sd, args.rgb, eye)?;
    let lights = cli::read_lights(&args.lights, &args.lmask)?;
    let mesh = cli::read_mesh(&args.mesh)?;
    let mut cloud = args.io.read(&Select::only(&["P", "N"]))?;
    let progress = msg.progress();
    let rep = sssingle::sssingle(&mut cloud, &mesh, &lights, &params, &progress)
        .map_err(cli::at(&name))?;
    msg.info(format!(
        "{} points, {} seen from the eye; {} rays towards the lights, {} entered",
        rep.points, rep.computed, rep.rays, rep.entered
    ));
    let dark = rep.points - rep.computed;
    if rep.eye_inside {
        msg.warn(format!(
            "the eye is inside the mesh: {dark} of {} points saw nothing",
            rep.points
        ));
    } else if dark == rep.points && rep.points > 0 {
        msg.warn("no point is seen from the eye: ssS is 0 everywhere");
    }
    if rep.reflected > 0 {
        msg.info(format!(
            "{} points reflect the view ray totally (eta below 1): ssS = 0 there",
            rep.reflected
        ));
    }
    args.io.write(&cloud)
}

fn main() -> ExitCode {
    cli::main("sssingle", run)
}
