//! `facet`: normals `N` from a mesh, on a cloud's points or the mesh's own
//! vertices.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use pcsss::cli::{self, IoArgs};
use pcsss::formats::Select;
use pcsss::geom::mesh::TriMesh;
use pcsss::stages::facet::{self, Mode, Params, Weight};

pcsss::global_allocator!();

/// Add normals N (Houdini's Facet SOP). With --mesh, the input is a point
/// cloud and each point takes the mesh's normal where it lies (its
/// sourceprim/sourceuv, else the closest point); without, the input is a
/// mesh and its own vertices get smooth normals.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    #[command(flatten)]
    io: IoArgs,
    /// The mesh the points lie on.
    #[arg(long, value_name = "MESH")]
    mesh: Option<PathBuf>,
    /// Face normals, or vertex normals interpolated.
    #[arg(long, value_enum, default_value = "smooth")]
    mode: Mode,
    /// Faces meeting at more than this angle (degrees) keep a sharp edge.
    #[arg(long, default_value_t = 60.0)]
    cusp: f64,
    /// Weighting of faces around a vertex.
    #[arg(long, value_enum, default_value = "angle")]
    weight: Weight,
    /// Do not weld vertices at the same position: each copy of a vertex
    /// split at a UV seam averages only its own faces.
    #[arg(long)]
    no_weld: bool,
}

fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("facet");
    let name = args.io.input_name();
    let (mode, weight) = (args.mode, args.weight);
    let mut cloud = args
        .io
        .read(&Select::only(&["P", "sourceprim", "sourceuv"]))?;
    let rep = match &args.mesh {
        Some(path) => {
            let mesh_cloud = cli::read_input(Some(path), &Select::only(&["P"]))?;
            let mesh = TriMesh::from_cloud(&mesh_cloud)
                .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            facet::facet_points(
                &mut cloud,
                &mesh,
                &Params {
                    mode,
                    weight,
                    cusp: args.cusp,
                    weld: !args.no_weld,
                },
            )
            .map_err(cli::at(&name))?
        }
        None => {
            if cloud.faces().is_none() {
                anyhow::bail!("{name}: a point cloud without faces needs --mesh MESH (the mesh its points lie on)");
            }
            if matches!(mode, Mode::Flat) {
                anyhow::bail!("{name}: --mode flat needs --mesh and a point cloud: a mesh's shared vertices have one normal each");
            }
            facet::facet_mesh(&mut cloud, weight, !args.no_weld).map_err(cli::at(&name))?
        }
    };
    if rep.projected > 0 {
        msg.info(format!(
            "{} points without sourceprim placed by closest point",
            rep.projected
        ));
    }
    if rep.zero_normals > 0 {
        msg.warn(format!(
            "{} points got a zero normal (degenerate faces)",
            rep.zero_normals
        ));
    }
    args.io.write(&cloud)
}

fn main() -> ExitCode {
    cli::main("facet", run)
}
