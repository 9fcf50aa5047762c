//! `ssmulti`: multiple scattering `ssM` at every cloud point.

use crate::cli::{self, IoArgs, MaterialArgs, PerPointArgs, SsArgs};
use crate::formats::Select;
use crate::stages::ssmulti;
use clap::Parser;

/// Multiple scattering at every point (Marengo's ssIntegMulti, or with
/// --model physical a medium, its reflectance from random walks): reads P, N,
/// ptarea, illum; adds ssM.
#[derive(Parser, Debug)]
#[command(version, allow_negative_numbers = true)]
pub struct Args {
    #[command(flatten)]
    pub io: IoArgs,
    #[command(flatten)]
    pub ss: SsArgs,
    #[command(flatten)]
    pub material: MaterialArgs,
    #[command(flatten)]
    pub per_point: PerPointArgs,
    #[command(flatten)]
    pub walk: cli::WalkArgs,
}

/// Runs the stage: reads its input, works, writes its output.
pub fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("ssmulti");
    let name = args.io.input_name();
    // The options decided before reading: an absurd one fails fast. The
    // material file is read once, here.
    let mut medium = args.material.given()?;
    let per_point = args.per_point.given()?;
    let by_walks = args.walk.method == ssmulti::Method::Walk;
    let early = ssmulti::Given {
        walk: by_walks,
        ..args.ss.given(medium.clone(), per_point.clone())?
    }
    .plan()?;
    // The walk method's mesh before the cloud: a missing one fails fast.
    let walk = match (args.walk.method, &args.walk.mesh) {
        (ssmulti::Method::Walk, Some(path)) => {
            let w = ssmulti::walk::WalkParams {
                walks: args.walk.walks,
                seed: args.walk.seed,
                denoise: args.walk.denoise,
                eye: None,
            };
            ssmulti::walk::check(&early, &w)?;
            Some((cli::read_mesh(path)?, w))
        }
        _ => None,
    };
    let eye_given = args.walk.eye.is_some() || args.walk.camera.is_some();
    if eye_given && walk.is_none() {
        let why = "walks from the eye's direction: it takes --method walk";
        return Err(crate::Error::param("eye", why).into());
    }
    let eye = match &args.walk.eye {
        Some(e) => Some(cli::parse_xyz("--eye", e)?),
        None => None,
    };
    let camera = match &args.walk.camera {
        Some(c) => Some(cli::read_camera(c)?),
        None => None,
    };
    // The lights the walks sample, read before the cloud.
    let lights = match (&walk, &args.walk.lights) {
        (Some(_), Some(path)) => Some(cli::read_lights(path, &args.walk.lmask)?),
        (None, Some(_)) => {
            let why = "samples lights at the walks' events: it takes --method walk";
            return Err(crate::Error::param("lights", why).into());
        }
        _ => None,
    };
    let mut wanted = vec![
        "P",
        "N",
        "ptarea",
        "illum",
        "illum_cos",
        "illum_diffuse",
        "thickness",
    ];
    if walk.is_some() {
        wanted.push("illum_indirect");
    }
    let (attrs, _) = medium.per_point();
    let named = per_point.as_ref().map_or(attrs, |p| p.attrs.clone());
    wanted.extend(named.iter().map(|(_, a)| a.as_str()));
    let mut cloud = args.io.read(&Select::only(&wanted))?;
    // A preset's lengths in the cloud's unit.
    let frame = cloud.frame().map_err(cli::at(&name))?;
    if let Some(line) = medium.in_frame(&frame) {
        msg.warn(line);
    }
    let ssmulti::Plan {
        params,
        per_point,
        base,
    } = ssmulti::Given {
        walk: by_walks,
        ..args.ss.given(medium, per_point)?
    }
    .plan()?;
    let progress = msg.progress();
    if let Some((mesh, w)) = &walk {
        // The eye in the cloud's frame (a camera's is moved there).
        let w = &ssmulti::walk::WalkParams {
            eye: camera
                .as_ref()
                .map(|c| c.in_frame(&frame).position)
                .or(eye)
                .map(glam::DVec3::from_array),
            ..*w
        };
        let plan = ssmulti::Plan {
            params,
            per_point,
            base,
        };
        let used = lights.as_ref().map(|f| f.in_frame(&frame));
        let (rep, groups) = ssmulti::walk::ssmulti_walk_per_point(
            &mut cloud,
            mesh,
            &plan,
            w,
            used.as_deref(),
            &progress,
        )
        .map_err(cli::at(&name))?;
        if groups > 1 {
            msg.info(format!("per-point parameters: {groups} groups of points"));
        }
        msg.info(format!(
            "{} points, {} of them walked, {} walks, {} scattering events, {} left the mesh lit",
            rep.points, rep.computed, rep.walks, rep.events, rep.exits
        ));
        for w in rep.warnings() {
            msg.warn(w);
        }
        return args.io.write_owned(cloud);
    }
    let rep = if per_point.attrs.is_empty() {
        ssmulti::ssmulti(&mut cloud, &params, &progress).map_err(cli::at(&name))?
    } else {
        let (rep, groups) = ssmulti::per_point::ssmulti_per_point(
            &mut cloud, &params, &base, &per_point, &progress,
        )
        .map_err(cli::at(&name))?;
        msg.info(format!("per-point parameters: {groups} groups of points"));
        rep
    };
    msg.info(format!(
        "{} points, {} sources, {} pairs{}",
        rep.points,
        rep.sources,
        rep.pairs,
        if rep.grey {
            " (white light: one channel)"
        } else {
            ""
        }
    ));
    if params.medium.is_some() && !rep.by_incidence {
        msg.warn(
            "the cloud has no illum_cos (illum makes it): the light is taken as arriving along the normal",
        );
    }
    if rep.isolated > 0 {
        msg.warn(format!(
            "{} of {} points are farther apart than their kernel reaches (give more points, or longer distances): each returns its own light",
            rep.isolated, rep.points
        ));
    }
    args.io.write_owned(cloud)
}
