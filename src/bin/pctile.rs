//! `pctile`: spatial tiles of a cloud with halos (split), and the owned
//! points of baked tiles back in the input's order (merge).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};
use pcsss::cli::{self, output, MsgArgs};
use pcsss::formats::Format;
use pcsss::tiles::{self, reach, split::TileCount, ForStage, SplitOptions};

/// Cuts a PLY cloud into spatial tiles, each with a halo of the points
/// within reach of it, so that a stage can bake each tile as its own job
/// (a Slurm array task, a make -j target) and `pctile merge` can put the
/// results back together, equal to the untiled bake.
#[derive(Parser, Debug)]
#[command(version)]
struct Args {
    #[command(subcommand)]
    cmd: Cmd,
    #[command(flatten)]
    msg: MsgArgs,
}

#[derive(Subcommand, Debug)]
enum Cmd {
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
        #[arg(long = "for", value_name = "STAGE")]
        for_stage: Option<String>,
        /// The stage's arguments, as one string ("--sd 0.6 --rd 0.9,0.5,0.3").
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

fn run(args: Args) -> anyhow::Result<()> {
    let msg = args.msg.messages("pctile");
    let progress = msg.progress();
    match args.cmd {
        Cmd::Split {
            input,
            output: dir,
            tiles: n,
            tile_size,
            tile_memory,
            point_bytes,
            halo,
            for_stage,
            stage_args,
        } => {
            let name = cli::display_name(input.as_deref());
            if dir.exists() && !dir.is_dir() {
                anyhow::bail!("{}: not a directory", dir.display());
            }
            // A directory made here goes again when the split fails: a
            // failed split leaves nothing behind.
            let made = !dir.exists();
            std::fs::create_dir_all(&dir).with_context(|| dir.display().to_string())?;
            let done = (|| -> anyhow::Result<()> {
                // Standard input is read three times: spooled to a temp file
                // in DIR first.
                let spool;
                let path = match input.as_deref() {
                    Some(p) if p != std::path::Path::new("-") => p.to_path_buf(),
                    _ => {
                        spool = tempfile::Builder::new()
                            .prefix(".pctile-input-")
                            .tempfile_in(&dir)
                            .with_context(|| dir.display().to_string())?;
                        let mut f = spool.as_file();
                        std::io::copy(&mut std::io::stdin().lock(), &mut f).context("<stdin>")?;
                        spool.path().to_path_buf()
                    }
                };
                let for_stage = match for_stage {
                    None => None,
                    Some(stage) => {
                        let words: Vec<String> = stage_args
                            .as_deref()
                            .unwrap_or("")
                            .split_whitespace()
                            .map(String::from)
                            .collect();
                        let head =
                            pcsss::formats::ply::read::PlyChunks::new(std::io::BufReader::new(
                                std::fs::File::open(&path).with_context(|| name.clone())?,
                            ))
                            .map_err(cli::at(&name))?;
                        let has_ssm = head.header().elements.iter().any(|e| {
                            e.name == "vertex"
                                && e.props.iter().any(|p| p.name == "ssM_r" || p.name == "ssM")
                        });
                        let r = reach::reach_for(&stage, &words, &head.header().detail, has_ssm)?;
                        Some(ForStage {
                            stage,
                            args: words,
                            reach: r,
                        })
                    }
                };
                let halo = match (halo, &for_stage) {
                    (Some(h), Some(f)) if h < f.reach => {
                        return Err(pcsss::Error::param(
                            "--halo",
                            format!(
                                "{h} is narrower than {}'s reach {} with those arguments",
                                f.stage, f.reach
                            ),
                        )
                        .into())
                    }
                    (Some(h), _) => h,
                    (None, Some(f)) => f.reach * (1.0 + reach::MARGIN),
                    (None, None) => unreachable!("clap requires --halo or --for"),
                };
                let tiles = match (n, tile_size, tile_memory) {
                    (Some(n), _, _) => TileCount::Tiles(n),
                    (None, Some(s), _) => TileCount::Size(s),
                    (None, None, Some(m)) => TileCount::Memory {
                        bytes: parse_bytes(&m)?,
                        per_point: point_bytes
                            .or_else(|| {
                                for_stage
                                    .as_ref()
                                    .and_then(|f| tiles::split::point_bytes(&f.stage))
                            })
                            .unwrap_or(400),
                    },
                    _ => unreachable!("clap requires one"),
                };
                let opt = SplitOptions {
                    tiles,
                    halo,
                    for_stage,
                };
                let m = tiles::split(&path, &name, &dir, &opt, &progress)?;
                let halo_pts: u64 = m.tiles.iter().map(|t| t.halo).sum();
                msg.info(format!(
                    "{} points into {} tiles (halo {}: {} halo points, {:.1}% more)",
                    m.points,
                    m.tiles.len(),
                    m.halo,
                    halo_pts,
                    if m.points > 0 {
                        100.0 * halo_pts as f64 / m.points as f64
                    } else {
                        0.0
                    }
                ));
                Ok(())
            })();
            if done.is_err() && made {
                let _ = std::fs::remove_dir_all(&dir);
            }
            done
        }
        Cmd::Merge {
            dir,
            tiles: files,
            from,
            output: out,
            format,
        } => {
            let files = match from {
                None => files,
                Some(from) => tiles::Manifest::read(&dir)?
                    .tiles
                    .iter()
                    .map(|t| from.join(&t.file))
                    .collect(),
            };
            let format = format
                .or_else(|| out.as_deref().and_then(Format::from_path))
                .unwrap_or(Format::DEFAULT);
            let enc = match format {
                Format::Ply(e) => e,
                Format::Exr => {
                    return Err(pcsss::Error::param(
                        "--format",
                        "merge writes PLY (streaming); convert with pcconvert",
                    )
                    .into())
                }
            };
            let out = out.filter(|p| p != std::path::Path::new("-"));
            if let Some(o) = &out {
                output::check_output(o)?;
            }
            let mut m = None;
            output::write_output(out.as_deref(), |w| {
                m = Some(tiles::merge(&dir, &files, w, enc, &progress)?);
                Ok(())
            })?;
            let m = m.expect("merged");
            msg.info(format!("{} points from {} tiles", m.points, m.tiles.len()));
            Ok(())
        }
    }
}

/// `2G`, `512M`, `64K` (powers of 1024), or bytes.
fn parse_bytes(s: &str) -> anyhow::Result<u64> {
    let bad = || {
        pcsss::Error::param(
            "--tile-memory",
            format!("'{s}': a size > 0 such as 2G, 512M or bytes"),
        )
    };
    let t = s.trim();
    let (num, mul) = match t.chars().last() {
        Some(c) if c.is_ascii_alphabetic() => {
            let m: u64 = match c.to_ascii_uppercase() {
                'K' => 1 << 10,
                'M' => 1 << 20,
                'G' => 1 << 30,
                'T' => 1 << 40,
                _ => return Err(bad().into()),
            };
            (&t[..t.len() - 1], m)
        }
        _ => (t, 1),
    };
    let x: f64 = num.parse().map_err(|_| bad())?;
    if !(x.is_finite() && x >= 1.0 && x * (mul as f64) < 1e18) {
        return Err(bad().into());
    }
    Ok((x * mul as f64) as u64)
}

fn main() -> ExitCode {
    cli::main_of("pctile", || run(cli::parse("pctile")))
}
