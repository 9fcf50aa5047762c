//! `filter`: `ssM` at shade points from a cloud (Houdini's `SsMulti` with
//! `pcfilter`).

use std::path::PathBuf;

use crate::cli::{self, GatherArgs, IoArgs, MaterialArgs, SingleArgs, SsArgs};
use crate::formats::Select;
use crate::stages::facet::{self, Weight};
use crate::stages::filter::{self, Lazy, SingleSetup, WalkSetup};
use crate::stages::sssingle;
use crate::Error;
use clap::Parser;

/// Reconstructs ssM and ssS (or --attr) at shade points (the input: a
/// PLY/EXR cloud, a mesh's own vertices, or an OpenEXR image of P/N
/// passes) from the cloud's nearest points, with Houdini's pcfilter
/// weights. A cloud with illum but no ssM has it computed lazily, only
/// where a shade point reads it (give ssmulti's --sd, --rd, ...); ssS
/// likewise with --single-lights, --single-mesh and the eye.
#[derive(Parser, Debug)]
#[command(version, allow_negative_numbers = true)]
pub struct Args {
    #[command(flatten)]
    pub io: IoArgs,
    /// The cloud: P and ssM (or P, N, ptarea, illum for lazy evaluation).
    #[arg(long, value_name = "CLOUD")]
    pub cloud: PathBuf,
    #[command(flatten)]
    pub gather: GatherArgs,
    /// The attributes to filter (colour or vector, comma-separated,
    /// repeatable) [default: ssM and ssS, those the cloud has or can
    /// compute].
    #[arg(long = "attr", value_name = "NAME,..", value_delimiter = ',')]
    pub attrs: Vec<String>,
    #[command(flatten)]
    pub ss: SsArgs,
    /// Lazy ssS: the lights (JSON) single scattering is computed with,
    /// for the cloud points read (with --single-mesh and --eye or
    /// --camera, and sssingle's model options).
    #[arg(long, value_name = "FILE", requires = "single_mesh")]
    pub single_lights: Option<PathBuf>,
    /// Lazy ssS: light mask (names and globs, ^ excludes).
    #[arg(long, value_name = "PATTERNS", default_value = "*")]
    pub single_lmask: String,
    /// Lazy ssS: the mesh the cloud lies on.
    #[arg(long, value_name = "MESH", requires = "single_lights")]
    pub single_mesh: Option<PathBuf>,
    /// Lazy ssS: the eye, X,Y,Z.
    #[arg(
        long,
        value_name = "X,Y,Z",
        allow_hyphen_values = true,
        conflicts_with = "camera",
        requires = "single_lights"
    )]
    pub eye: Option<String>,
    /// Lazy ssS: the eye of a camera file.
    #[arg(long, value_name = "FILE", requires = "single_lights")]
    pub camera: Option<PathBuf>,
    /// A mesh's vertex colours tone mapped as render's PNG, 1 -
    /// exp(-exposure * beauty) (without it: the beauty clamped to 1).
    #[arg(long)]
    pub exposure: Option<f64>,
    #[command(flatten)]
    pub single: SingleArgs,
    #[command(flatten)]
    pub material: MaterialArgs,
    #[command(flatten)]
    pub walk: cli::LazyWalkArgs,
}

/// Runs the stage: reads its input, works, writes its output.
pub fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("filter");
    let name = args.io.input_name();
    if let Some(e) = args.exposure {
        filter::check_exposure(e)?;
    }
    let cloud_name = cli::display_name(Some(&args.cloud));
    // The material file is read once, here; the options decided before
    // the cloud is read (a bad one fails fast) and again in its unit.
    let mut medium = args.material.given()?;
    args.ss.given(medium.clone(), None)?.params()?;
    let walk = args.walk.given(None)?;
    let cloud = cli::read_input(Some(&args.cloud), &Select::All)?;
    // The camera's eye and the lights are moved into the cloud's frame,
    // and a preset's lengths follow its unit.
    let frame = cloud.frame().map_err(cli::at(&cloud_name))?;
    if let Some(line) = medium.in_frame(&frame) {
        msg.warn(line);
    }
    let multi = args.ss.given(medium.clone(), None)?.params()?;
    // Lazy single scattering: its parameters, lights and mesh.
    let single = match &args.single_lights {
        None => None,
        Some(lights) => {
            let eye = match (&args.eye, &args.camera) {
                (Some(e), _) => cli::parse_xyz("--eye", e)?,
                (None, Some(cam)) => cli::read_camera(cam)?.in_frame(&frame).position,
                (None, None) => {
                    let why = "lazy ssS needs the eye: --eye X,Y,Z or --camera FILE";
                    return Err(Error::param("single_lights", why).into());
                }
            };
            let file = cli::read_lights(lights, &args.single_lmask)
                .map_err(|e| cli::as_param(e, "single_lmask"))?;
            let (params, lights) = args
                .single
                .lazy(&medium, &args.ss, eye, &cloud, &file, &frame)?;
            let mesh_path = args.single_mesh.as_ref().expect("clap requires it");
            let mesh = cli::read_mesh(mesh_path)?;
            let mesh_name = mesh_path.display().to_string();
            sssingle::check_mesh(&mesh).map_err(cli::at(&mesh_name))?;
            Some((params, lights, mesh))
        }
    };
    let lazy_single = single.as_ref().map(|(params, lights, mesh)| SingleSetup {
        mesh,
        lights,
        params,
    });
    let walk_lights = args.walk.lights(&frame)?;
    let walk = match &walk {
        Some((path, w)) => Some((cli::read_mesh(path)?, *w)),
        None => None,
    };
    let walk_setup = walk.as_ref().map(|(mesh, walk)| WalkSetup {
        mesh,
        walk: *walk,
        lights: walk_lights.as_deref(),
    });
    let lazy = Lazy {
        multi: multi.as_ref(),
        walk: walk_setup.as_ref(),
        single: lazy_single.as_ref(),
    };
    let setup = args
        .gather
        .setup(&cloud, &cloud_name, &args.attrs, lazy, &msg)?;
    let mut shade = args.io.read(&Select::All)?;
    // A mesh's own vertices without normals get them (for --facing).
    let is_mesh = shade.faces().is_some_and(|f| !f.is_empty());
    if is_mesh && !shade.points().has("N") {
        facet::facet_mesh(&mut shade, Weight::Angle, true).map_err(cli::at(&name))?;
    }
    let progress = msg.progress();
    let rep = filter::filter(
        &cloud,
        &cloud_name,
        &mut shade,
        &setup.params,
        &setup.sources,
        &progress,
    )
    .map_err(cli::at(&name))?;
    if is_mesh {
        let terms: Vec<(&str, f64)> = setup
            .sources
            .iter()
            .map(|s| (s.name(), filter::radiance_scale(&cloud, s)))
            .collect();
        filter::add_vertex_colours(&mut shade, &terms, args.exposure).map_err(cli::at(&name))?;
    }
    let (info, warn) = rep.messages();
    info.iter().for_each(|m| msg.info(m));
    for w in warn {
        msg.warn(w);
    }
    args.io.write_owned(shade)
}
