//! `pcinfo`: prints a cloud's summary (points, attributes with type, role
//! and min/max/mean, detail attributes, faces).

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Parser;
use pcsss::cli::{self, MsgArgs};
use pcsss::formats::Select;

pcsss::global_allocator!();

/// Print a point cloud's or mesh's summary: elements, attributes (type,
/// role, min/max/mean), detail attributes, faces.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// Input files (PLY, OBJ or OpenEXR); standard input when none or '-'.
    #[arg(value_name = "IN")]
    inputs: Vec<PathBuf>,
    /// USD stages read at this time code (the frame of an animation).
    #[arg(long, value_name = "TIME")]
    frame: Option<f64>,
    /// Print a USD stage's frames instead: the whole time codes from its
    /// startTimeCode to its endTimeCode, one a line (`make frames`
    /// bakes each).
    #[arg(long)]
    time_codes: bool,
    #[command(flatten)]
    msg: MsgArgs,
}

fn run(args: Args) -> anyhow::Result<()> {
    // The report is the product: nowhere to write it is an error.
    pcsss::files::check_stdout_open()?;
    if args.time_codes {
        let mut out = std::io::stdout().lock();
        for p in &args.inputs {
            let name = p.display().to_string();
            let file = pcsss::formats::usd::stage_file(p)
                .ok_or_else(|| anyhow::anyhow!("{name}: not a USD stage (--time-codes)"))?;
            let codes = pcsss::tools::info::frames(file).context(name)?;
            for t in codes {
                writeln!(out, "{t}").context("<stdout>")?;
            }
        }
        out.flush().context("<stdout>")?;
        return Ok(());
    }
    let inputs: Vec<Option<PathBuf>> = if args.inputs.is_empty() {
        vec![None]
    } else {
        args.inputs.into_iter().map(Some).collect()
    };
    let many = inputs.len() > 1;
    // Written with errors returned (a broken pipe is success), never
    // `println!`, which panics on them.
    let mut out = std::io::stdout().lock();
    for p in &inputs {
        let cloud = cli::read_input(p.as_deref(), &Select::All)?;
        let text = pcsss::tools::info::summary(&cloud);
        if many {
            writeln!(out, "{}:", cli::display_name(p.as_deref())).context("<stdout>")?;
        }
        out.write_all(text.as_bytes()).context("<stdout>")?;
    }
    out.flush().context("<stdout>")?;
    Ok(())
}

fn main() -> ExitCode {
    cli::main("pcinfo", run)
}
