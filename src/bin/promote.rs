//! `promote`: reduces a point or face attribute to a detail attribute, or
//! normalises `ptarea` to the mesh's area.

use std::process::ExitCode;

use clap::Parser;
use pcsss::cli::{self, IoArgs};
use pcsss::formats::Select;
use pcsss::stages::promote::{self, Class, Method};

pcsss::global_allocator!();

/// Promote a point or face attribute to a detail attribute (Houdini's
/// Attribute Promote SOP): `--attr area --class face --as Tarea`. With
/// `--normalize`, scale `ptarea` by Tarea / Tptarea so it sums to the
/// mesh's area (and set Tptarea to the new sum).
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    #[command(flatten)]
    io: IoArgs,
    /// Element to read the attribute from.
    #[arg(long, value_enum, default_value = "point")]
    class: Class,
    /// Attribute to promote.
    #[arg(long, required_unless_present = "normalize")]
    attr: Option<String>,
    /// Reduction.
    #[arg(long, value_enum, default_value = "sum")]
    method: Method,
    /// Detail attribute name [default: T and the attribute's name, e.g. Tarea].
    #[arg(long = "as", value_name = "DETAIL")]
    as_name: Option<String>,
    /// Normalise ptarea: ptarea *= Tarea / Tptarea.
    #[arg(long, conflicts_with = "attr")]
    normalize: bool,
}

fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.io.messages("promote");
    let name = args.io.input_name();
    let ctx = cli::at(&name);
    if args.normalize {
        let mut cloud = args.io.read(&Select::only(&["ptarea"]))?;
        let (tarea, before) = promote::normalize(&mut cloud).map_err(ctx)?;
        msg.info(format!(
            "ptarea scaled by Tarea / Tptarea = {tarea} / {before}"
        ));
        return args.io.write(&cloud);
    }
    let attr = args.attr.expect("clap requires --attr");
    let mut cloud = args.io.read(&Select::only(&[&attr]))?;
    let as_name = args.as_name.unwrap_or_else(|| format!("T{attr}"));
    let v = promote::promote(&mut cloud, args.class, &attr, args.method, &as_name).map_err(ctx)?;
    msg.info(format!(
        "{as_name} = {}",
        pcsss::tools::info::detail_text(&v)
    ));
    args.io.write(&cloud)
}

fn main() -> ExitCode {
    cli::main("promote", run)
}
