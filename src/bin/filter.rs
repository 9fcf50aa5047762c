//! `filter`: `ssM` at shade points from a cloud (Houdini's `SsMulti` with
//! `pcfilter`).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use pcsss::cli::{self, IoArgs, SsArgs};
use pcsss::formats::Select;
use pcsss::stages::facet::{self, Weight};
use pcsss::stages::filter::{self, Params, Source};
use pcsss::Error;

/// Reconstructs ssM at shade points (the input: a PLY/EXR cloud, a mesh's
/// own vertices, or an OpenEXR image of P/N passes) from the cloud's
/// nearest points, with Houdini's pcfilter weights. A cloud with illum
/// but no ssM is computed lazily, only where a shade point reads it (give
/// the ssmulti parameters: --sd, --rd, ...).
#[derive(Parser, Debug)]
#[command(version, allow_negative_numbers = true)]
struct Args {
    #[command(flatten)]
    io: IoArgs,
    /// The cloud: P and ssM (or P, N, ptarea, illum for lazy evaluation).
    #[arg(long, value_name = "CLOUD")]
    cloud: PathBuf,
    /// Use the N nearest cloud points.
    #[arg(long, value_name = "N", conflicts_with = "radius")]
    nfp: Option<usize>,
    /// Use the cloud points within this fraction of the scattering
    /// distance D = sd * max(Rd).
    #[arg(long, value_name = "FRACTION", default_value_t = 0.25)]
    radius: f64,
    /// Only cloud points whose normal faces the shade point's side.
    #[arg(long)]
    facing: bool,
    #[command(flatten)]
    ss: SsArgs,
}

fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("filter");
    let name = args.io.input_name();
    let cloud_name = cli::display_name(Some(&args.cloud));
    let lazy_params = args.ss.params()?;
    let r = args.radius;
    if !(r.is_finite() && r > 0.0) {
        return Err(Error::param("--radius", format!("{r}: must be a finite fraction > 0")).into());
    }
    let cloud = cli::read_input(Some(&args.cloud), &Select::All)?;
    let source = Source::choose(&cloud, lazy_params.as_ref()).map_err(cli::at(&cloud_name))?;
    let reach = source
        .reach(&cloud, args.nfp, args.radius)
        .map_err(cli::at(&cloud_name))?;
    let mut shade = args.io.read(&Select::All)?;
    // A mesh's own vertices without normals get them (for --facing).
    let is_mesh = shade.faces().is_some_and(|f| !f.is_empty());
    if is_mesh && !shade.points().has("N") {
        facet::facet_mesh(&mut shade, Weight::Angle).map_err(cli::at(&name))?;
    }
    let progress = msg.progress();
    let rep = filter::filter(
        &cloud,
        &mut shade,
        &Params {
            reach,
            facing: args.facing,
        },
        source,
        &progress,
    )
    .map_err(cli::at(&name))?;
    if is_mesh {
        filter::add_vertex_colours(&mut shade).map_err(cli::at(&name))?;
    }
    let (info, warn) = rep.messages();
    info.iter().for_each(|m| msg.info(m));
    if let Some(w) = warn {
        msg.warn(w);
    }
    args.io.write(&shade)
}

fn main() -> ExitCode {
    cli::main_of("filter", || run(cli::parse("filter")))
}
