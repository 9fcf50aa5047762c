//! `texture`: an image sampled at every point into an attribute.

use std::path::PathBuf;

use crate::cli::{self, IoArgs};
use crate::formats::texture::{self as image, Decode};
use crate::formats::Select;
use crate::geom::mesh::TriMesh;
use crate::stages::texture::{self, Wrap};
use clap::Parser;

/// Sample an image (PNG or OpenEXR) at every point into a colour
/// attribute, through the point's place on the mesh it was scattered on
/// (sourceprim, sourceuv) and the mesh's texture coordinates (OBJ vt, PLY
/// u v or s t), bilinearly. A material's per_point then reads it.
#[derive(Parser, Debug)]
#[command(version)]
pub struct Args {
    #[command(flatten)]
    pub io: IoArgs,
    /// The mesh the cloud was scattered on, with texture coordinates.
    #[arg(long, value_name = "MESH")]
    pub mesh: PathBuf,
    /// The image.
    #[arg(long, value_name = "IMAGE")]
    pub image: PathBuf,
    /// The attribute to write.
    #[arg(long = "as", value_name = "NAME")]
    pub name: String,
    /// Past the image's edge: wrap around, or extend the edge.
    #[arg(long, value_enum, default_value = "repeat")]
    pub wrap: Wrap,
    /// How the image's values become linear: auto decodes 8-bit PNG as
    /// sRGB and takes 16-bit PNG and OpenEXR as linear.
    #[arg(long, value_enum, default_value = "auto")]
    pub decode: Decode,
}

/// Runs the stage: reads its input, works, writes its output.
pub fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("texture");
    let name = args.io.input_name();
    let image_name = args.image.display().to_string();
    let tex = image::read(&args.image, args.decode).map_err(cli::at(&image_name))?;
    let mesh_name = args.mesh.display().to_string();
    let mesh_cloud = cli::read_input(Some(&args.mesh), &Select::All)?;
    let mesh = TriMesh::from_cloud(&mesh_cloud).map_err(cli::at(&mesh_name))?;
    let uvs = texture::mesh_uvs(&mesh_cloud).map_err(cli::at(&mesh_name))?;
    let mut cloud = args
        .io
        .read(&Select::only(&["P", "sourceprim", "sourceuv"]))?;
    texture::texture(&mut cloud, &mesh, &uvs, &tex, &args.name, args.wrap)
        .map_err(cli::at(&name))?;
    msg.info(format!(
        "{} points took {} from a {} x {} image",
        cloud.len(),
        args.name,
        tex.width,
        tex.height
    ));
    args.io.write_owned(cloud)
}
