//! `pctile`: spatial tiles of a cloud with halos (split), and the owned
//! points of baked tiles back in the input's order (merge).

use std::path::Path;
use std::path::PathBuf;
use std::process::ExitCode;

use crate::cli::{self, stage_args, MsgArgs};
use crate::files;
use crate::formats::Format;
use crate::tiles::{self, ForRequest, Request, TileCount};
use clap::{CommandFactory, Parser, Subcommand};

/// Cuts a PLY cloud into spatial tiles, each with a halo of the points
/// within reach of it, so that a stage can bake each tile as its own job
/// (a Slurm array task, a make -j target) and `pctile merge` can put the
/// results back together, equal to the untiled bake.
#[derive(Parser, Debug)]
#[command(version)]
pub struct Args {
    #[command(subcommand)]
    pub cmd: Cmd,
    #[command(flatten)]
    pub msg: MsgArgs,
}

#[derive(Subcommand, Debug)]
pub enum Cmd {
    /// Tiles of IN (PLY; standard input when absent or '-') in DIR:
    /// tile_NNNN.ply, manifest.json, rest.ply (elements other than
    /// vertex). The input is streamed, never loaded whole.
    Split {
        /// The cloud: PLY of any encoding; standard input when absent or
        /// '-' (spooled to DIR: it is read three times).
        #[arg(value_name = "IN")]
        input: Option<PathBuf>,
        /// The directory to write the tiles to (made if missing).
        #[arg(short, long, value_name = "DIR")]
        output: PathBuf,
        /// This many tiles, balanced by point count.
        #[arg(
            long,
            value_name = "N",
            required_unless_present_any = ["tile_size", "tile_memory"],
            conflicts_with_all = ["tile_size", "tile_memory"]
        )]
        tiles: Option<usize>,
        /// As many tiles as hold about this many owned points each.
        #[arg(long, value_name = "POINTS", conflicts_with = "tile_memory")]
        tile_size: Option<u64>,
        /// The fewest tiles whose largest, halo included, the stage bakes
        /// in this much memory (bytes, or with a K, M, G suffix: powers of
        /// 1024), at --point-bytes a point.
        #[arg(long, value_name = "BYTES", allow_negative_numbers = true)]
        tile_memory: Option<String>,
        /// With --tile-memory: a point's bytes in the stage [default: the
        /// measured figure for --for ssmulti, 230; else 400].
        #[arg(long, value_name = "B", requires = "tile_memory")]
        point_bytes: Option<u64>,
        /// The halo's width: points within it of a tile are in the tile
        /// as sources.
        #[arg(
            long,
            value_name = "H",
            required_unless_present = "for_stage",
            allow_negative_numbers = true
        )]
        halo: Option<f64>,
        /// Compute the halo from this stage's reach (ssmulti, filter,
        /// sssingle, illum) with --stage-args, plus 1e-5 of it for the
        /// stages' float rounding; with --halo too, the halo is checked to
        /// be wide enough.
        #[arg(long = "for", value_name = "STAGE", value_enum)]
        for_stage: Option<tiles::reach::Stage>,
        /// The stage's arguments, as one string ("--sd 0.6 --rd 0.9,0.5,0.3"),
        /// split into words as a shell splits them (quotes kept together).
        #[arg(
            long,
            value_name = "ARGS",
            allow_hyphen_values = true,
            requires = "for_stage"
        )]
        stage_args: Option<String>,
    },
    /// The owned points of the tiles of DIR's manifest, in the input's
    /// order, with the elements kept aside; TILE files are the baked tiles
    /// (each says which tile it is), else the manifest's own files.
    Merge {
        /// The split's directory (its manifest.json).
        #[arg(value_name = "DIR")]
        dir: PathBuf,
        /// Baked tile files [default: the tiles the manifest lists in DIR].
        #[arg(value_name = "TILE", conflicts_with = "from")]
        tiles: Vec<PathBuf>,
        /// The baked tiles are the manifest's file names in this directory
        /// (a stage's output directory: other files there are ignored).
        #[arg(long, value_name = "OUTDIR")]
        from: Option<PathBuf>,
        /// Output file; standard output when absent or '-'.
        #[arg(short, long, value_name = "FILE")]
        output: Option<PathBuf>,
        /// Output format: ply, ply-ascii, ply-be.
        #[arg(long, value_name = "FORMAT")]
        format: Option<Format>,
    },
}

/// Runs `pctile` on its command line.
pub fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.msg.messages("pctile");
    let progress = msg.progress();
    match args.cmd {
        Cmd::Split {
            input,
            output,
            tiles: n,
            tile_size,
            tile_memory,
            point_bytes,
            halo,
            for_stage,
            stage_args,
        } => {
            let tiles = match (n, tile_size, tile_memory) {
                (Some(n), _, _) => TileCount::Tiles(n),
                (None, Some(s), _) => TileCount::Size(s),
                (None, None, Some(m)) => TileCount::Memory {
                    bytes: cli::parse_bytes("--tile-memory", &m)?,
                    per_point: point_bytes,
                },
                _ => unreachable!("clap requires one"),
            };
            let request = Request {
                input_name: cli::display_name(input.as_deref()),
                input,
                dir: output,
                tiles,
                halo,
                for_stage: for_request(for_stage, stage_args.as_deref())?,
            };
            let m = request.run(&progress)?;
            let halo_pts: u64 = m.tiles.iter().map(|t| t.halo).sum();
            let more = 100.0 * halo_pts as f64 / m.points.max(1) as f64;
            msg.info(format!(
                "{} points into {} tiles (halo {}: {} halo points, {more:.1}% more)",
                m.points,
                m.tiles.len(),
                m.halo,
                halo_pts,
            ));
            Ok(())
        }
        Cmd::Merge {
            dir,
            tiles: files,
            from,
            output,
            format,
        } => {
            let m = merge(&dir, files, from.as_deref(), output, format, &progress)?;
            msg.info(format!("{} points from {} tiles", m.points, m.tiles.len()));
            Ok(())
        }
    }
}

/// The stage a split's halo is for, with its arguments (one string, split
/// as a shell splits it) parsed as the stage parses them, in the cloud's
/// unit too.
fn for_request(
    stage: Option<tiles::reach::Stage>,
    args: Option<&str>,
) -> anyhow::Result<Option<ForRequest>> {
    let Some(stage) = stage else {
        return Ok(None);
    };
    let words = tiles::reach::stage_words(args.unwrap_or(""))?;
    let params = stage_args::parse(stage, &words)?;
    let w = words.clone();
    let in_unit: tiles::request::InUnit = std::sync::Arc::new(move |mm| {
        stage_args::parse_in(stage, &w, Some(mm)).map_err(|e| {
            e.downcast::<crate::Error>()
                .unwrap_or_else(|e| crate::Error::invalid(e.to_string()))
        })
    });
    Ok(Some(ForRequest {
        stage,
        args: words,
        params,
        in_unit: Some(in_unit),
    }))
}

/// `pctile merge`: the tiles `files` (else the manifest's, in `from` or
/// `dir`) merged to `out` (stdout when absent or '-') as PLY.
fn merge(
    dir: &Path,
    files: Vec<PathBuf>,
    from: Option<&Path>,
    out: Option<PathBuf>,
    format: Option<Format>,
    progress: &crate::progress::Progress,
) -> anyhow::Result<tiles::Manifest> {
    let files = match (from, files.is_empty()) {
        (None, false) => files,
        (from, _) => tiles::Manifest::read(dir)?.tile_files(from.unwrap_or(dir)),
    };
    // The output is none of what the merge reads: the manifest, the rest
    // file, any tile.
    let out = out.filter(|p| p != Path::new("-"));
    if let Some(o) = &out {
        let manifest = dir.join(tiles::MANIFEST);
        let rest = dir.join(tiles::REST);
        let mut inputs: Vec<&Path> = vec![&manifest, &rest];
        inputs.extend(files.iter().map(|f| f.as_path()));
        files::check_outputs(&[files::Output::file(o)], &inputs)?;
    }
    let format = match (format, out.as_deref()) {
        (Some(f), _) => f,
        (None, Some(o)) => {
            Format::for_output(o).map_err(|why| crate::Error::param("output", why))?
        }
        (None, None) => Format::DEFAULT,
    };
    let Format::Ply(enc) = format else {
        let why = "merge writes PLY (streaming); convert with pcconvert";
        return Err(crate::Error::param("format", why).into());
    };
    let mut m = None;
    files::write_output(out.as_deref(), |w| {
        m = Some(tiles::merge(dir, &files, w, enc, progress)?);
        Ok(())
    })?;
    Ok(m.expect("merged"))
}

/// `pctile`'s main: a stage's parameter is named as its option within
/// `--stage-args`.
pub fn main() -> ExitCode {
    let (args, matches) = cli::parse_matches::<Args>("pctile");
    // A stage's parameter is named as its option within --stage-args.
    let stage = match &args.cmd {
        Cmd::Split { for_stage, .. } => *for_stage,
        Cmd::Merge { .. } => None,
    };
    let cmd = Args::command();
    let flag = |name: &str| cli::flag_of(&cmd, name).or_else(|| stage_args::flag_of(stage?, name));
    cli::main_of("pctile", &flag, || {
        cli::check_named_paths(&cmd, &matches, &[])?;
        run(args)
    })
}
