//! `sssingle`: single scattering `ssS` at every point, for one eye.

use crate::cli;
pub use crate::cli::SssingleArgs as Args;
use crate::formats::Select;
use crate::stages::{ssmulti, sssingle};

/// Runs the stage: reads its input, works, writes its output.
pub fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("sssingle");
    let name = args.io.input_name();
    let given_eye = match &args.eye {
        Some(e) => Some(cli::parse_xyz("--eye", e)?),
        None => None,
    };
    let camera = match (&args.eye, &args.camera) {
        (None, Some(cam)) => Some(cli::read_camera(cam)?),
        _ => None,
    };
    // The material options alone first (a bad one fails fast); then the
    // cloud, whose record of ssmulti's run fills in what is not given.
    let mut medium = args.material.given()?;
    medium.check()?;
    let given = args
        .single
        .given(medium.clone(), args.rd.as_deref(), args.sd, args.rgb)?;
    let lights_file = cli::read_lights(&args.lights, &args.lmask)?;
    let mesh = cli::read_mesh(&args.mesh)?;
    let mesh_name = args.mesh.display().to_string();
    sssingle::check_mesh(&mesh).map_err(cli::at(&mesh_name))?;
    let mut cloud = args.io.read(&Select::only(&["P", "N"]))?;
    // The lights and the camera are moved into the cloud's frame.
    let frame = cloud.frame().map_err(cli::at(&name))?;
    let lights = lights_file.in_frame(&frame);
    if let Some(line) = medium.in_frame(&frame) {
        msg.warn(line);
    }
    let eye = match (given_eye, camera) {
        (Some(e), _) => e,
        (None, Some(cam)) => cam.in_frame(&frame).position,
        (None, None) => unreachable!("clap requires one"),
    };
    let given = sssingle::Given { medium, ..given };
    let record = ssmulti::Record::of(&cloud);
    let params = sssingle::Params::resolve(&given, glam::DVec3::from_array(eye), &record)?;
    let progress = msg.progress();
    let rep = sssingle::sssingle(&mut cloud, &mesh, &lights, &params, &progress)
        .map_err(cli::at(&name))?;
    msg.info(format!(
        "{} points, {} seen from the eye; {} rays towards the lights, {} entered; {} shadow rays, {} blocked",
        rep.points, rep.computed, rep.rays, rep.entered, rep.shadow_rays, rep.shadowed
    ));
    for w in rep.warnings() {
        msg.warn(w);
    }
    if rep.reflected > 0 {
        msg.info(format!(
            "{} points reflect the view ray totally (eta below 1): ssS = 0 there",
            rep.reflected
        ));
    }
    args.io.write_owned(cloud)
}
