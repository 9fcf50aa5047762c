//! `ssmulti`: multiple scattering `ssM` at every cloud point.

use std::process::ExitCode;

use clap::{Parser, ValueEnum};
use pcsss::cli::{self, IoArgs};
use pcsss::formats::Select;
use pcsss::stages::ssmulti::{self, Falloff, Norm, Params, BURLEY_KAPPA};

#[derive(Clone, Copy, Debug, ValueEnum)]
enum FalloffArg {
    /// 1 - smoothstep(0, D, r) (the seed's).
    Smooth,
    /// exp(-sigma r / D) (the seed's alternative).
    Exp,
    /// Christensen-Burley diffusion profile, shape D / sigma, truncated at D.
    Burley,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum NormArg {
    /// The seed's (Houdini's): by the disk integral at the largest distance.
    Seed,
    /// With --rgb, each channel by its own disk integral, times Rd.
    Channel,
    /// By the kernel-weighted area present within reach, times Rd.
    Local,
}

/// Multiple scattering at every point (the seed's ssIntegMulti): reads P,
/// N, ptarea, illum; adds ssM.
#[derive(Parser, Debug)]
#[command(version, allow_negative_numbers = true)]
struct Args {
    #[command(flatten)]
    io: IoArgs,
    /// Diffuse reflectance: R,G,B (or one value for all three).
    #[arg(long, value_name = "R,G,B", default_value = "1,1,1")]
    rd: String,
    /// Scattering distance (per channel: Rd * sd).
    #[arg(long)]
    sd: f64,
    /// Bounce attenuation, 0 (off) to 1.
    #[arg(long, default_value_t = 0.0)]
    bounce: f64,
    /// Per-channel distances (the seed's t_rgb).
    #[arg(long)]
    rgb: bool,
    /// Falloff kernel.
    #[arg(long, value_enum, default_value = "smooth")]
    falloff: FalloffArg,
    /// exp: decay rate (default 4); burley: D / d (default 5.625: the
    /// profile's mean radius equals the smooth falloff's).
    #[arg(long)]
    sigma: Option<f64>,
    /// Normalisation.
    #[arg(long, value_enum, default_value = "seed")]
    norm: NormArg,
    /// 0: exact; above: the approximate method's tolerance.
    #[arg(long, default_value_t = 0.0)]
    tolerance: f64,
}

fn parse_rgb(s: &str) -> anyhow::Result<[f64; 3]> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| anyhow::anyhow!("parameter --rd: '{s}': {e}"))?;
    match v[..] {
        [x] => Ok([x; 3]),
        [r, g, b] => Ok([r, g, b]),
        _ => anyhow::bail!("parameter --rd: '{s}' is not R,G,B or one value"),
    }
}

fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("ssmulti");
    let name = args.io.input_name();
    let falloff = match args.falloff {
        FalloffArg::Smooth => Falloff::Smooth,
        FalloffArg::Exp => Falloff::Exp {
            sigma: args.sigma.unwrap_or(4.0),
        },
        FalloffArg::Burley => Falloff::Burley {
            kappa: args.sigma.unwrap_or(BURLEY_KAPPA),
        },
    };
    let params = Params {
        rd: parse_rgb(&args.rd)?,
        sd: args.sd,
        bounce: args.bounce,
        rgb: args.rgb,
        falloff,
        norm: match args.norm {
            NormArg::Seed => Norm::Seed,
            NormArg::Channel => Norm::Channel,
            NormArg::Local => Norm::Local,
        },
        tolerance: args.tolerance,
    };
    // Parameters before reading: an absurd one fails fast.
    ssmulti::validate(&params)?;
    let mut cloud = args
        .io
        .read(&Select::only(&["P", "N", "ptarea", "illum"]))?;
    let progress = msg.progress();
    let rep = ssmulti::ssmulti(&mut cloud, &params, &progress).map_err(cli::at(&name))?;
    msg.info(format!(
        "{} points, {} sources, {} pairs",
        rep.points, rep.sources, rep.pairs
    ));
    args.io.write(&cloud)
}

fn main() -> ExitCode {
    cli::main_of("ssmulti", || run(cli::parse("ssmulti")))
}
