//! `pcdiff A B`: compares two clouds attribute by attribute; exits 0 when
//! they agree within tolerance, 1 when they differ, 2 on error.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Parser;
use pcsss::cli::{self, MsgArgs};
use pcsss::formats::Select;
use pcsss::tools::diff::{compare, unknown_names, Options, Tol};

pcsss::global_allocator!();

/// Compare two point clouds attribute by attribute. Values a, b agree when
/// |a - b| <= max(ABS, REL * max(|a|, |b|)) (NaN agrees with NaN). Exit
/// status: 0 same, 1 different, 2 trouble.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    /// The first cloud ('-' for standard input).
    a: PathBuf,
    /// The second cloud.
    b: PathBuf,
    /// Absolute tolerance.
    #[arg(long, default_value_t = 0.0, value_name = "ABS")]
    abs: f64,
    /// Relative tolerance.
    #[arg(long, default_value_t = 0.0, value_name = "REL")]
    rel: f64,
    /// Per-attribute tolerance: NAME=ABS or NAME=ABS,REL (repeatable).
    #[arg(long = "tol", value_name = "NAME=ABS[,REL]", value_parser = parse_tol)]
    tols: Vec<(String, Tol)>,
    /// Attributes not to compare (comma-separated, repeatable).
    #[arg(long, value_delimiter = ',', value_name = "NAMES")]
    ignore: Vec<String>,
    /// Compare only these attributes (comma-separated, repeatable).
    #[arg(long, value_delimiter = ',', value_name = "NAMES")]
    only: Vec<String>,
    #[command(flatten)]
    msg: MsgArgs,
}

fn parse_tol(s: &str) -> Result<(String, Tol), String> {
    let (name, v) = s.split_once('=').ok_or("expected NAME=ABS[,REL]")?;
    let mut it = v.split(',');
    let num = |x: Option<&str>| -> Result<f64, String> {
        x.unwrap_or("0")
            .parse::<f64>()
            .map_err(|_| format!("'{v}' is not ABS[,REL]"))
            .and_then(|t| {
                if t >= 0.0 {
                    Ok(t)
                } else {
                    Err("tolerances are >= 0".into())
                }
            })
    };
    Ok((
        name.to_string(),
        Tol {
            abs: num(it.next())?,
            rel: num(it.next())?,
        },
    ))
}

fn run(args: Args) -> anyhow::Result<bool> {
    for (n, t) in [("--abs", args.abs), ("--rel", args.rel)] {
        anyhow::ensure!(
            t >= 0.0 && t.is_finite(),
            "{n} must be a finite number >= 0"
        );
    }
    // The differences would be lost behind an exit code (as diff, a
    // closed stdout is trouble, exit 2).
    pcsss::files::check_stdout_open()?;
    let msg = args.msg.messages("pcdiff");
    let a = cli::read_input(Some(&args.a), &Select::All)?;
    let b = cli::read_input(Some(&args.b), &Select::All)?;
    let opt = Options {
        tol: Tol {
            abs: args.abs,
            rel: args.rel,
        },
        per_attr: args.tols.into_iter().collect(),
        ignore: args.ignore,
        only: args.only,
    };
    if let Some((flag, name)) = unknown_names(&a, &b, &opt).into_iter().next() {
        let why = format!("'{name}' names no attribute of either cloud");
        return Err(pcsss::Error::param(flag, why).into());
    }
    let rep = compare(&a, &b, &opt);
    for n in &rep.notes {
        msg.info(format!("note: {n}"));
    }
    for d in &rep.details {
        msg.debug(d);
    }
    // (Errors returned, a broken pipe a success: `println!` panics.)
    let mut out = std::io::stdout().lock();
    for d in &rep.differences {
        writeln!(out, "{d}").context("<stdout>")?;
    }
    out.flush().context("<stdout>")?;
    msg.info(format!(
        "{} attributes compared, {} differences",
        rep.compared,
        rep.differences.len()
    ));
    Ok(rep.same())
}

fn main() -> ExitCode {
    let mut same = true;
    let code = cli::main("pcdiff", |args: Args| {
        same = run(args)?;
        Ok(())
    });
    if code != ExitCode::SUCCESS {
        ExitCode::from(2)
    } else if same {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
