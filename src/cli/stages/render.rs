//! `render`: ray-cast a mesh from a pinhole camera, filter the cloud's
//! `ssM` at the hit points, write an OpenEXR image (and a PNG preview).

use std::path::PathBuf;

use crate::cli::{self, GatherArgs, MaterialArgs, MsgArgs, SingleArgs, SsArgs};
use crate::files;
use crate::formats::exr::{Compression, ExrOptions};
use crate::formats::{self, Format, Select};
use crate::geom::mesh::TriMesh;
use crate::stages::filter::{Lazy, SingleSetup, WalkSetup};
use crate::stages::render;
use crate::Error;
use clap::Parser;

/// Renders a mesh through a pinhole camera (formats/CAMERA.md): P, N and
/// coverage passes by ray casting, then the beauty = ssM + ssS filtered
/// from the cloud at every hit (computed lazily when the cloud has only
/// illum), plus with --direct a diffuse direct term. Writes an OpenEXR
/// image (channels beauty, ssM, ssS, P, N, A) and, with --png, a
/// tone-mapped sRGB preview (alone without -o).
#[derive(Parser, Debug)]
#[command(version, allow_negative_numbers = true)]
pub struct Args {
    /// The mesh (OBJ or PLY with faces).
    #[arg(long, value_name = "MESH")]
    pub mesh: PathBuf,
    /// The camera file (JSON).
    #[arg(long, value_name = "FILE")]
    pub camera: PathBuf,
    /// The cloud: P and ssM, ssS (or P, N, ptarea, illum and --sd to
    /// compute ssM lazily; --single-lights for ssS).
    #[arg(long, value_name = "CLOUD")]
    pub cloud: PathBuf,
    /// Output image (OpenEXR).
    #[arg(short, long, value_name = "OUT.exr", required_unless_present = "png")]
    pub output: Option<PathBuf>,
    /// A PNG preview (beside the OpenEXR, or alone without -o).
    #[arg(long, value_name = "OUT.png")]
    pub png: Option<PathBuf>,
    /// Preview exposure: 1 - exp(-exposure * beauty) (the bake's EXPOSURE).
    #[arg(long, default_value_t = 1.2)]
    pub exposure: f64,
    /// Image width in pixels, in place of the camera's (given alone, the
    /// height follows the camera's aspect).
    #[arg(long, value_name = "PIXELS")]
    pub width: Option<u32>,
    /// Image height in pixels, in place of the camera's (given alone, the
    /// width follows the camera's aspect).
    #[arg(long, value_name = "PIXELS")]
    pub height: Option<u32>,
    #[command(flatten)]
    pub gather: GatherArgs,
    /// Add a direct diffuse term from these lights (JSON, as illum's):
    /// beauty = ssM + ssS + kd * illum, with shadows from the mesh.
    #[arg(long, value_name = "LIGHTS")]
    pub direct: Option<PathBuf>,
    /// Light mask for --direct (names and globs, ^ excludes).
    #[arg(long, default_value = "*")]
    pub lmask: String,
    /// Diffuse reflectance of the direct term: R,G,B or one value.
    #[arg(long, value_name = "R,G,B", default_value = "0.2")]
    pub kd: String,
    /// OpenEXR compression.
    #[arg(long, value_name = "C", default_value = "zip")]
    pub compression: Compression,
    /// What the beauty sums (comma-separated, repeatable) [default: ssM
    /// and ssS, those the cloud has or can compute].
    #[arg(long = "attr", value_name = "NAME,..", value_delimiter = ',')]
    pub attrs: Vec<String>,
    /// Camera rays a pixel (1: through its centre; more: jittered in
    /// strata), seeded by --seed.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub spp: u32,
    /// How a ray's value is spread over the pixels: its own (box), or
    /// Mitsuba's default Gaussian (0.5 pixel, cut at 2).
    #[arg(long, value_name = "F", default_value = "box")]
    pub pixel_filter: render::PixelFilter,
    #[command(flatten)]
    pub ss: SsArgs,
    /// Lazy ssS: the lights (JSON) single scattering is computed with, for
    /// the cloud points read, seen from the camera (with sssingle's model
    /// options).
    #[arg(long, value_name = "FILE")]
    pub single_lights: Option<PathBuf>,
    /// Lazy ssS: light mask (names and globs, ^ excludes).
    #[arg(long, value_name = "PATTERNS", default_value = "*")]
    pub single_lmask: String,
    #[command(flatten)]
    pub single: SingleArgs,
    #[command(flatten)]
    pub material: MaterialArgs,
    #[command(flatten)]
    pub walk: cli::LazyWalkArgs,
    /// USD stages (--mesh, --camera, the lights) read at this time code
    /// (the frame of an animation), as the other stages' --frame.
    #[arg(long, value_name = "TIME")]
    pub frame: Option<f64>,
    #[command(flatten)]
    pub msg: MsgArgs,
}

/// Runs `render` on its command line.
pub fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.msg.messages("render");
    render::check_exposure(args.exposure)?;
    check_outputs(&args)?;
    render::Pixels {
        spp: args.spp,
        filter: args.pixel_filter,
        seed: 0,
    }
    .validate()?;
    let cam_file = cli::read_camera(&args.camera)?.sized(args.width, args.height)?;
    // The material file is read once, here; the options decided before
    // the cloud is read (a bad one fails fast) and again in its unit.
    let mut medium = args.material.given()?;
    args.ss.given(medium.clone(), None)?.params()?;
    let walk = args.walk.given(Some(&args.mesh))?;
    // The direct term's parameters and lights, checked before any work.
    let kd = cli::parse_rgb("--kd", &args.kd)?;
    render::check_kd(kd)?;
    let lights_file = match &args.direct {
        Some(path) => Some(cli::read_lights(path, &args.lmask)?),
        None => None,
    };
    let single_file = match &args.single_lights {
        Some(path) => Some(
            cli::read_lights(path, &args.single_lmask)
                .map_err(|e| cli::as_param(e, "single_lmask"))?,
        ),
        None => None,
    };
    let cloud_name = args.cloud.display().to_string();
    let cloud = cli::read_input(Some(&args.cloud), &Select::All)?;
    // The camera and the lights are moved into the cloud's frame, and a
    // preset's lengths follow its unit.
    let frame = cloud.frame().map_err(cli::at(&cloud_name))?;
    if let Some(line) = medium.in_frame(&frame) {
        msg.warn(line);
    }
    let lazy = args.ss.given(medium.clone(), None)?.params()?;
    let cam = cam_file.in_frame(&frame);
    let lights_used = lights_file.map(|f| f.in_frame(&frame));
    let single = match &single_file {
        Some(file) => {
            let eye = cam.position;
            Some(
                args.single
                    .lazy(&medium, &args.ss, eye, &cloud, file, &frame)?,
            )
        }
        None => None,
    };
    let mesh_name = args.mesh.display().to_string();
    let mesh = cli::read_input(Some(&args.mesh), &Select::All)?;
    let tris = match single {
        Some(_) => Some(TriMesh::from_cloud(&mesh).map_err(cli::at(&mesh_name))?),
        None => None,
    };
    let lazy_single = single
        .as_ref()
        .zip(tris.as_ref())
        .map(|((params, lights), mesh)| SingleSetup {
            mesh,
            lights,
            params,
        });
    let walk_lights = args.walk.lights(&frame)?;
    let walk_mesh = match &walk {
        Some((path, w)) => Some((cli::read_mesh(path)?, *w)),
        None => None,
    };
    // Render's walks start from its camera: the light towards it
    // (docs/DESIGN.md, the exit).
    let walk_setup = walk_mesh.as_ref().map(|(mesh, walk)| WalkSetup {
        mesh,
        walk: crate::stages::ssmulti::walk::WalkParams {
            eye: Some(glam::DVec3::from_array(cam.position)),
            ..*walk
        },
        lights: walk_lights.as_deref(),
    });
    let lazy = Lazy {
        multi: lazy.as_ref(),
        walk: walk_setup.as_ref(),
        single: lazy_single.as_ref(),
    };
    let setup = args
        .gather
        .setup(&cloud, &cloud_name, &args.attrs, lazy, &msg)?;
    let scene = render::Scene {
        mesh: &mesh,
        mesh_name: &mesh_name,
        camera: &cam,
        cloud: &cloud,
        cloud_name: &cloud_name,
        filter: setup.params.clone(),
        sources: &setup.sources,
        direct: lights_used.as_deref().map(|l| (l, kd)),
        pixels: render::Pixels {
            spp: args.spp,
            filter: args.pixel_filter,
            seed: args.single.seed,
        },
    };
    let progress = msg.progress();
    let (shade, rep, frep) = render::render_scene(&scene, &progress)?;
    msg.info(format!(
        "{} of {} pixels see the mesh",
        rep.covered, rep.pixels
    ));
    let (info, warn) = frep.messages();
    info.iter().skip(1).for_each(|m| msg.info(m));
    for w in warn {
        msg.warn(w);
    }
    write_outputs(&args, &shade)
}

/// The outputs named as render writes them, before any work: an OpenEXR
/// and a PNG (`cli::main` checked that they can be written and are no
/// input).
fn check_outputs(args: &Args) -> anyhow::Result<()> {
    if let Some(out) = &args.output {
        if !out
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
        {
            let why = format!("{}: render writes OpenEXR: name a .exr file", out.display());
            return Err(Error::param("output", why).into());
        }
    }
    if let Some(png) = &args.png {
        if png
            .extension()
            .is_none_or(|e| !e.eq_ignore_ascii_case("png"))
        {
            let why = format!("{}: name a .png file", png.display());
            return Err(Error::param("png", why).into());
        }
    }
    Ok(())
}

/// The image `shade` written: the OpenEXR and the PNG preview, both
/// complete before either is in place (all or none).
fn write_outputs(args: &Args, shade: &crate::cloud::Cloud) -> anyhow::Result<()> {
    let opt = ExrOptions {
        compression: args.compression,
        half: vec![],
    };
    // Both files complete before either is in place: all or none.
    let exr = match &args.output {
        Some(path) => Some(files::Staged::write(path, |w| {
            formats::write_cloud_with(w, shade, Format::Exr, &opt)
        })?),
        None => None,
    };
    let png = match &args.png {
        Some(path) => Some(files::Staged::write(path, |w| {
            render::write_png(w, shade, "beauty", args.exposure)
        })?),
        None => None,
    };
    if let Some(exr) = exr {
        exr.commit()?;
    }
    if let Some(png) = png {
        png.commit()?;
    }
    Ok(())
}
