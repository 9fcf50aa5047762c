//! `follow`: a cloud scattered on a rest mesh, moved onto another frame of
//! the same mesh.

use std::path::PathBuf;

use crate::cli::{self, IoArgs};
use crate::cloud::DetailValue;
use crate::formats::Select;
use crate::names;
use crate::stages::follow;
use clap::Parser;

/// Move a cloud scattered on the rest mesh onto another frame of it (the
/// same vertices and faces, moved): each point goes to the same place of
/// the same triangle (sourceprim, sourceuv), ptarea stretches with its
/// triangle, N is taken again from the frame as facet recorded it. The
/// points stay the same points on every frame (no popping).
#[derive(Parser, Debug)]
#[command(version)]
pub struct Args {
    #[command(flatten)]
    pub io: IoArgs,
    /// The mesh the cloud was scattered on.
    #[arg(long, value_name = "MESH")]
    pub rest: PathBuf,
    /// The frame to move it to.
    #[arg(long, value_name = "MESH")]
    pub mesh: PathBuf,
}

/// Runs the stage: reads its input, works, writes its output.
pub fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("follow");
    let name = args.io.input_name();
    let rest = cli::read_mesh(&args.rest)?;
    let (frame, time) = cli::read_mesh_timed(&args.mesh)?;
    // The frame's topology is checked before the cloud is read.
    follow::on_frame(&rest, &frame).map_err(cli::at(&args.mesh.display().to_string()))?;
    let mut cloud = args.io.read(&Select::All)?;
    let rep = follow::follow(&mut cloud, &rest, &frame).map_err(cli::at(&name))?;
    // The cloud is now at the frame's time code, not the rest's.
    match time {
        Some(t) => cloud.set_detail(names::D_USD_TIME, DetailValue::F64(t)),
        None => cloud.remove_detail(names::D_USD_TIME),
    }
    msg.info(format!(
        "{} points moved; the surface's area is {:.4} of the rest mesh's{}",
        rep.points,
        rep.area_ratio,
        if rep.normals { "; N taken again" } else { "" }
    ));
    args.io.write_owned(cloud)
}
