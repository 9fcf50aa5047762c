//! `filter`: `ssM` at shade points from a cloud (the seed's `SsMulti` with
//! `pcfilter`).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use pcsss::cli::{self, IoArgs, SsArgs};
use pcsss::formats::Select;
use pcsss::stages::facet::{self, Weight};
use pcsss::stages::filter::{self, Params, Reach, Source};

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
    /// distance D = sd * max(Rd) [default: 0.25].
    #[arg(long, value_name = "FRACTION")]
    radius: Option<f64>,
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
    if let Some(r) = args.radius {
        if !(r.is_finite() && r > 0.0) {
            anyhow::bail!("parameter --radius: {r}: must be a finite fraction > 0");
        }
    }
    let cloud = cli::read_input(Some(&args.cloud), &Select::All)?;
    let has_ssm = cloud.points().has("ssM");
    let source = match (&lazy_params, has_ssm) {
        (_, true) => Source::Eager,
        (Some(p), false) => Source::Lazy(p),
        (None, false) => anyhow::bail!(
            "{cloud_name}: no point attribute 'ssM' (made by ssmulti): run ssmulti, or give --sd (and --rd ...) to compute it here for the points the shade points read"
        ),
    };
    // D: the lazy run's, else the one ssmulti recorded.
    let d = match (&source, &lazy_params) {
        (Source::Lazy(_), Some(p)) => Some(p.sd * p.rd.iter().copied().fold(0.0, f64::max)),
        _ => match (cloud.detail("ssmulti_sd"), cloud.detail("ssmulti_rd")) {
            (Some(sd), Some(rd)) => {
                let sd = sd.as_f64().unwrap_or(f64::NAN);
                let rd = rd.components().into_iter().fold(0.0, f64::max);
                Some(sd * rd)
            }
            _ => None,
        },
    };
    let reach = match (args.nfp, args.radius) {
        (Some(n), _) => Reach::Nearest(n),
        (None, r) => {
            let f = r.unwrap_or(0.25);
            let Some(d) = d.filter(|d| d.is_finite() && *d > 0.0) else {
                anyhow::bail!(
                    "{cloud_name}: --radius is a fraction of D = sd * max(Rd), and the cloud records no ssmulti_sd/ssmulti_rd (made by ssmulti): give --sd and --rd, or use --nfp"
                );
            };
            Reach::Radius(f * d)
        }
    };
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
    msg.info(format!(
        "{} shade points from {} cloud points, {:.1} read each on average",
        rep.shade_points, rep.cloud_points, rep.mean_used
    ));
    if let Some((read, computed)) = rep.lazy {
        msg.info(format!(
            "lazy: ssM computed at {computed} of {} cloud points ({read} read)",
            rep.cloud_points
        ));
    }
    if rep.empty > 0 {
        msg.warn(format!(
            "{} shade points had no cloud point in reach: ssM = 0 there",
            rep.empty
        ));
    }
    args.io.write(&shade)
}

fn main() -> ExitCode {
    cli::main_of("filter", || run(cli::parse("filter")))
}
