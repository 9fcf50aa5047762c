//! `illum`: direct irradiance at every point from a lights file, with
//! shadows from a mesh.

use crate::cli;
pub use crate::cli::IllumArgs as Args;
use crate::formats::Select;
use crate::stages::illum;

/// Runs the stage: reads its input, works, writes its output.
pub fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("illum");
    let name = args.io.input_name();
    let lights_file = cli::read_lights(&args.lights, &args.lmask)?;
    if args.thickness && args.mesh.is_none() {
        let why = "needs --mesh (the mesh the points lie on)";
        return Err(crate::Error::param("thickness", why).into());
    }
    if args.indirect.is_some() && args.mesh.is_none() {
        let why = "needs --mesh (the surface the light travels between)";
        return Err(crate::Error::param("indirect", why).into());
    }
    // The material file is read once, here; decided now (a bad option
    // fails fast) and again in the cloud's unit.
    let mut given = args.material.given()?;
    let medium = given.resolve(None)?.medium();
    if args.indirect.is_some() && medium.is_none() {
        let why = "needs the medium ssmulti ran with (--model physical and its options)";
        return Err(crate::Error::param("indirect", why).into());
    }
    // The mesh first: a missing or broken mesh fails before the cloud is read.
    let (occluder, mesh) = match &args.mesh {
        Some(path) => {
            let name = path.display().to_string();
            let mesh = cli::read_mesh(path)?;
            let occ = illum::occluder(&mesh).map_err(cli::at(&name))?;
            (Some(occ), Some(mesh))
        }
        None => (None, None),
    };
    let mut cloud = match args.indirect {
        // The indirect light needs the last run's ssM; the direct light
        // the cloud may hold already.
        Some(_) => args.io.read(&Select::only(&[
            "P",
            "N",
            "sourceprim",
            "ssM",
            "illum",
            "illum_cos",
            "illum_diffuse",
            "illum_indirect",
            "thickness",
        ]))?,
        None => args.io.read(&Select::only(&["P", "N", "sourceprim"]))?,
    };
    // The lights are moved into the cloud's frame, and a preset's lengths
    // follow its unit.
    let frame = cloud.frame().map_err(cli::at(&name))?;
    let used = lights_file.in_frame(&frame);
    if medium.is_some() {
        if let Some(line) = given.in_frame(&frame) {
            msg.warn(line);
        }
    }
    let medium = given.resolve(None)?.medium();
    let progress = msg.progress();
    let passage = medium.as_ref().map(|m| illum::Passage {
        sigma_t: 1.0 / glam::DVec3::from_array(m.mfp),
        eta: m.eta,
    });
    let shadows = match (&occluder, &mesh) {
        (Some(occ), Some(mesh)) => Some(illum::Shadows::new(mesh, occ, passage)),
        _ => None,
    };
    // With --indirect, the direct light of the same lights, shadows and
    // points is the cloud's already when ssmulti passed it through.
    let again = args.indirect.is_some()
        && illum::holds_direct(&cloud, &used, shadows.as_ref(), args.seed)
            .map_err(cli::at(&name))?;
    let rep = if again {
        None
    } else {
        Some(
            illum::illum(&mut cloud, &used, shadows.as_ref(), args.seed, &progress)
                .map_err(cli::at(&name))?,
        )
    };
    if let (true, Some(mesh)) = (args.thickness, &mesh) {
        if !(again && illum::holds_thickness(&cloud, mesh)) {
            let open = illum::thickness(&mut cloud, mesh, &progress).map_err(cli::at(&name))?;
            if open > 0 {
                msg.warn(format!(
                "{open} points see no back to the mesh along -N (an open mesh?): their thickness is taken as infinite"
            ));
            }
        }
    }
    if let (Some(rays), Some(occ), Some(mesh), Some(m)) = (args.indirect, &occluder, &mesh, &medium)
    {
        let from = match &args.exitance {
            Some(path) => Some(cli::read_input(
                Some(path),
                &Select::only(&["P", "N", "ssM", "illum", "illum_cos"]),
            )?),
            None => None,
        };
        // (The exitance cloud's own fault names it.)
        if let (Some(f), Some(path)) = (&from, &args.exitance) {
            illum::check_exitance(f).map_err(cli::at(&path.display().to_string()))?;
        }
        let rep = illum::indirect_from(
            &mut cloud,
            from.as_ref(),
            args.gather_at_exitance,
            occ,
            mesh,
            m,
            rays,
            args.seed,
            &progress,
        )
        .map_err(cli::at(&name))?;
        msg.info(format!(
            "indirect light: {} rays, {} met the surface",
            rep.rays, rep.hits
        ));
    }
    let names: Vec<&str> = used.iter().map(|l| l.name.as_str()).collect();
    match rep {
        Some(rep) => msg.info(format!(
            "{} points, lights {}: {} shadow rays, {} blocked; {} points unlit",
            rep.points,
            names.join(", "),
            rep.rays,
            rep.blocked,
            rep.dark
        )),
        None => msg.info(format!(
            "{} points, lights {}: the direct light is the cloud's (the same lights, shadows, seed and points)",
            cloud.len(),
            names.join(", ")
        )),
    }
    args.io.write_owned(cloud)
}
