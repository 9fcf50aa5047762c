//! `scatter`: points on a mesh, stratified by area, reproducible by seed.

use std::process::ExitCode;

use clap::{Parser, ValueEnum};
use pcsss::cli::{self, IoArgs};
use pcsss::formats::Select;
use pcsss::stages::scatter::{self, Amount, Params, PtareaMode};

#[derive(Clone, Copy, Debug, ValueEnum)]
enum PtareaArg {
    /// A triangle's area shared by its points (sums to the mesh's area).
    Prim,
    /// pi r^2 / k from the 8 nearest neighbours (follows local density).
    Knn,
    /// The Voronoi cell in the tangent plane (most accurate; pair with
    /// --relax and promote --normalize).
    Voronoi,
}

/// Scatter points on a mesh (Houdini's Scatter SOP): P, ptarea, sourceprim,
/// sourceuv; the mesh's detail attributes are inherited.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    #[command(flatten)]
    io: IoArgs,
    /// Number of points.
    #[arg(
        short = 'n',
        long = "count",
        conflicts_with = "density",
        required_unless_present = "density"
    )]
    count: Option<usize>,
    /// Points per unit area instead of a count.
    #[arg(long)]
    density: Option<f64>,
    /// Random seed (equal seeds give equal clouds on any thread count).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// How ptarea is estimated.
    #[arg(long, value_enum, default_value = "prim")]
    ptarea: PtareaArg,
    /// Relaxation iterations: spread the points evenly (blue noise) by
    /// repulsion on the surface, like the Scatter SOP's relax iterations.
    #[arg(long, default_value_t = 0)]
    relax: u32,
}

fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("scatter");
    let name = args.io.input_name();
    let mesh = args.io.read(&Select::only(&["P"]))?;
    let amount = match (args.count, args.density) {
        (Some(n), _) => Amount::Count(n),
        (None, Some(d)) => Amount::Density(d),
        (None, None) => unreachable!("clap requires one"),
    };
    let ptarea = match args.ptarea {
        PtareaArg::Prim => PtareaMode::Prim,
        PtareaArg::Knn => PtareaMode::Knn,
        PtareaArg::Voronoi => PtareaMode::Voronoi,
    };
    let progress = msg.progress();
    let cloud = scatter::scatter_with(
        &mesh,
        &Params {
            amount,
            seed: args.seed,
            ptarea,
            relax: args.relax,
        },
        &progress,
    )
    .map_err(cli::at(&name))?;
    msg.info(format!("{} points", cloud.len()));
    args.io.write(&cloud)
}

fn main() -> ExitCode {
    cli::main_of("scatter", || run(cli::parse("scatter")))
}
