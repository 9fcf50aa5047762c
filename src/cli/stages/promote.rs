//! `promote`: reduces a point or face attribute to a detail attribute, or
//! normalises `ptarea` to the mesh's area.

use crate::cli::{self, IoArgs};
use crate::formats::Select;
use crate::stages::promote::{self, Class, Method};
use clap::Parser;

/// Promote a point or face attribute to a detail attribute (Houdini's
/// Attribute Promote SOP): `--attr area --class face --as Tarea`. With
/// `--normalize`, scale `ptarea` by Tarea / Tptarea so it sums to the
/// mesh's area (and set Tptarea to the new sum).
#[derive(Parser, Debug)]
#[command(version)]
pub struct Args {
    #[command(flatten)]
    pub io: IoArgs,
    /// Element to read the attribute from.
    #[arg(long, value_enum, default_value = "point")]
    pub class: Class,
    /// Attribute to promote.
    #[arg(long, required_unless_present = "normalize")]
    pub attr: Option<String>,
    /// Reduction.
    #[arg(long, value_enum, default_value = "sum")]
    pub method: Method,
    /// Detail attribute name [default: T and the attribute's name, e.g. Tarea].
    #[arg(long = "as", value_name = "DETAIL")]
    pub as_name: Option<String>,
    /// Normalise ptarea: ptarea *= Tarea / Tptarea.
    #[arg(long, conflicts_with = "attr")]
    pub normalize: bool,
}

/// Runs the stage: reads its input, works, writes its output.
pub fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("promote");
    let name = args.io.input_name();
    let ctx = cli::at(&name);
    if args.normalize {
        let mut cloud = args.io.read(&Select::only(&["ptarea"]))?;
        let (tarea, before) = promote::normalize(&mut cloud).map_err(ctx)?;
        msg.info(format!(
            "ptarea scaled by Tarea / Tptarea = {tarea} / {before}"
        ));
        return args.io.write_owned(cloud);
    }
    let attr = args.attr.expect("clap requires --attr");
    let mut cloud = args.io.read(&Select::only(&[&attr]))?;
    let as_name = args.as_name.unwrap_or_else(|| format!("T{attr}"));
    let v = promote::promote(&mut cloud, args.class, &attr, args.method, &as_name).map_err(ctx)?;
    msg.info(format!(
        "{as_name} = {}",
        crate::tools::info::detail_text(&v)
    ));
    args.io.write_owned(cloud)
}
