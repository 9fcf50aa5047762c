//! `facet`: normals `N` from a mesh, on a cloud's points or the mesh's own
//! vertices.

use std::path::PathBuf;

use crate::cli::{self, IoArgs};
use crate::formats::Select;
use crate::geom::mesh::TriMesh;
use crate::stages::facet::{self, Mode, Params, Weight};
use clap::Parser;

/// Add normals N (Houdini's Facet SOP). With --mesh, the input is a point
/// cloud and each point takes the mesh's normal where it lies (its
/// sourceprim/sourceuv, else the closest point); without, the input is a
/// mesh and its own vertices get smooth normals.
#[derive(Parser, Debug)]
#[command(version)]
pub struct Args {
    #[command(flatten)]
    pub io: IoArgs,
    /// The mesh the points lie on.
    #[arg(long, value_name = "MESH")]
    pub mesh: Option<PathBuf>,
    /// Face normals, or vertex normals interpolated.
    #[arg(long, value_enum, default_value = "smooth")]
    pub mode: Mode,
    /// Faces meeting at more than this angle (degrees) keep a sharp edge.
    #[arg(long, default_value_t = 60.0)]
    pub cusp: f64,
    /// Weighting of faces around a vertex.
    #[arg(long, value_enum, default_value = "angle")]
    pub weight: Weight,
    /// Do not weld vertices at the same position: each copy of a vertex
    /// split at a UV seam averages only its own faces.
    #[arg(long)]
    pub no_weld: bool,
}

/// Runs the stage: reads its input, works, writes its output.
pub fn run(args: Args) -> anyhow::Result<()> {
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
    args.io.write_owned(cloud)
}
