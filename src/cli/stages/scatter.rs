//! `scatter`: points on a mesh, stratified by area, reproducible by seed.

use crate::cli::{self, IoArgs};
use crate::formats::Select;
use crate::frame::{Frame, UpAxis};
use crate::stages::scatter::{self, Amount, Params, PtareaMode};
use clap::Parser;

/// Scatter points on a mesh (Houdini's Scatter SOP): P, ptarea, sourceprim,
/// sourceuv; the mesh's detail attributes are inherited.
#[derive(Parser, Debug)]
#[command(version)]
#[command(group = clap::ArgGroup::new("amount").required(true).args(["count", "density"]))]
pub struct Args {
    #[command(flatten)]
    pub io: IoArgs,
    /// Number of points.
    #[arg(short = 'n', long = "count")]
    pub count: Option<usize>,
    /// Points per unit area instead of a count.
    #[arg(long)]
    pub density: Option<f64>,
    /// Random seed (equal seeds give equal clouds on any thread count).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// How ptarea is estimated.
    #[arg(long, value_enum, default_value = "prim")]
    pub ptarea: PtareaMode,
    /// Relaxation iterations: spread the points evenly by repulsion on the
    /// surface, like the Scatter SOP's relax iterations (--blue is faster
    /// and more even than relaxing random points).
    #[arg(long, default_value_t = 0)]
    pub relax: u32,
    /// Blue noise (Poisson-disk quality, the exact count asked for): weighted
    /// sample elimination from --candidates times as many random points,
    /// 2 relaxation iterations (or --relax), close pairs pushed apart. The
    /// accurate choice: pair it with --ptarea centroid.
    #[arg(long)]
    pub blue: bool,
    /// Candidates per point for --blue (1.5 to 64): more give a more
    /// even set, slower.
    #[arg(long, default_value_t = scatter::CANDIDATES, value_name = "RATIO")]
    pub candidates: f64,
    /// The mesh's up axis, recorded in the cloud's detail (`up_axis`): a
    /// lights or camera file that states another is turned into it
    /// (Blender's OBJ export is y, its PLY export z).
    #[arg(long, value_enum, value_name = "AXIS")]
    pub up_axis: Option<UpAxis>,
    /// Metres per unit of the mesh's coordinates, recorded in the cloud's
    /// detail (`meters_per_unit`): lights and cameras in other units are
    /// scaled into it.
    #[arg(long, value_name = "M")]
    pub meters_per_unit: Option<f64>,
}

/// Runs the stage: reads its input, works, writes its output.
pub fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("scatter");
    let name = args.io.input_name();
    let progress = msg.progress();
    let mut ph = progress.phases("scatter io");
    let stated = Frame {
        up: args.up_axis,
        meters_per_unit: args.meters_per_unit,
    };
    stated
        .check()
        .map_err(|why| crate::Error::param("meters_per_unit", why))?;
    let mesh = args.io.read(&Select::only(&["P"]))?;
    ph.mark("read");
    let frame = mesh.frame_with(&stated).map_err(cli::at(&name))?;
    let amount = match (args.count, args.density) {
        (Some(n), _) => Amount::Count(n),
        (None, Some(d)) => Amount::Density(d),
        (None, None) => unreachable!("clap requires one"),
    };
    let mut cloud = scatter::scatter_with(
        &mesh,
        &Params {
            amount,
            seed: args.seed,
            ptarea: args.ptarea,
            relax: args.relax,
            blue: args.blue,
            candidates: args.candidates,
        },
        &progress,
    )
    .map_err(cli::at(&name))?;
    cloud.set_frame(&frame);
    ph.mark("scatter");
    msg.info(format!("{} points", cloud.len()));
    args.io.write_owned(cloud)?;
    ph.mark("write");
    Ok(())
}
