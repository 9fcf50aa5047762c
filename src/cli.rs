//! What every binary shares: input and output, formats, messages, errors.
//!
//! - The positional argument is the main input; absent or `-` means stdin.
//!   A terminal on stdin with no input is an error, not a hang.
//! - `-o FILE` writes a file atomically (a temp file beside it, renamed
//!   into place when complete); absent or `-` writes stdout.
//! - The output format comes from `--format`, else the output's extension,
//!   else binary little-endian PLY.
//! - Messages go to stderr; `-q` silences them, `-v` adds detail.
//! - Errors are one line, `stage: file: what is wrong`, exit status 1; a
//!   broken pipe (`| head`) is success.

use std::fs::File;
use std::io::{self, BufReader, BufWriter, IsTerminal, Read, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;

use crate::cloud::Cloud;
use crate::formats::exr::{Compression, ExrOptions};
use crate::formats::{self, Format, Select};
use crate::stages::ssmulti::{self, Falloff, FalloffKind, Norm, Params, Simd};
use crate::stages::sssingle::{self, Model};

/// Verbosity flags.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct MsgArgs {
    /// No messages on stderr, errors only.
    #[arg(short, long, global = true)]
    pub quiet: bool,
    /// More messages on stderr (repeat for more).
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    pub verbose: u8,
}

/// The input, output and format arguments of a stage.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct IoArgs {
    /// Input file (PLY, OBJ or OpenEXR); standard input when absent or '-'.
    #[arg(value_name = "IN")]
    pub input: Option<PathBuf>,
    /// Output file; standard output when absent or '-'.
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Output format: ply, ply-ascii, ply-be, exr [default: from the
    /// output file's extension, else ply (binary little-endian)].
    #[arg(long, value_name = "FORMAT")]
    pub format: Option<Format>,
    /// OpenEXR output: compression (none, rle, zips, zip, piz, pxr24,
    /// b44, b44a; pxr24 and b44 are lossy).
    #[arg(long, value_name = "C", default_value = "zip")]
    pub compression: Compression,
    /// OpenEXR output: float attributes stored as 16-bit half (names,
    /// comma-separated).
    #[arg(long, value_name = "ATTR,..", value_delimiter = ',')]
    pub half: Vec<String>,
    #[command(flatten)]
    pub msg: MsgArgs,
}

/// A path that stands for stdin/stdout.
fn is_std(p: &Option<PathBuf>) -> bool {
    p.as_deref().is_none_or(|p| p == Path::new("-"))
}

/// How a path is named in messages.
pub fn display_name(p: Option<&Path>) -> String {
    match p {
        Some(p) if p != Path::new("-") => p.display().to_string(),
        _ => "<stdin>".to_string(),
    }
}

impl IoArgs {
    /// The input's name in messages.
    pub fn input_name(&self) -> String {
        display_name(self.input.as_deref())
    }

    /// Reads the main input, decoding `select`ed attributes now.
    pub fn read(&self, select: &Select) -> anyhow::Result<Cloud> {
        read_input(self.input.as_deref(), select)
    }

    /// The output format in force.
    pub fn output_format(&self) -> Format {
        self.format
            .or_else(|| self.output.as_deref().and_then(Format::from_path))
            .unwrap_or(Format::DEFAULT)
    }

    /// Writes `cloud` to the output in the chosen format.
    pub fn write(&self, cloud: &Cloud) -> anyhow::Result<()> {
        let format = self.output_format();
        let out = if is_std(&self.output) {
            None
        } else {
            self.output.as_deref()
        };
        let opt = ExrOptions {
            compression: self.compression,
            half: self.half.clone(),
        };
        write_output(out, |w| {
            formats::write_cloud_with(w, cloud, format, &opt).map_err(Into::into)
        })
    }

    /// A message printer for `stage`.
    pub fn messages(&self, stage: &'static str) -> Messages {
        self.msg.messages(stage)
    }
}

impl MsgArgs {
    /// A message printer for `stage`.
    pub fn messages(&self, stage: &'static str) -> Messages {
        Messages {
            stage,
            level: if self.quiet { 0 } else { 1 + self.verbose },
        }
    }
}

/// Reads a cloud or mesh from `path` (stdin when `None` or `-`).
pub fn read_input(path: Option<&Path>, select: &Select) -> anyhow::Result<Cloud> {
    let name = display_name(path);
    let result = match path {
        Some(p) if p != Path::new("-") => {
            // `PCSSS_NO_MMAP`: read files as streams, not mapped.
            formats::read_cloud_file_with(p, select, !env_flag("PCSSS_NO_MMAP"))
                .map_err(anyhow::Error::from)
        }
        _ => {
            let stdin = io::stdin();
            if stdin.is_terminal() {
                anyhow::bail!("no input: give an input file, or pipe one in (see --help)");
            }
            grow_pipe(&stdin);
            formats::read_cloud(BufReader::with_capacity(1 << 16, stdin.lock()), select)
                .map_err(Into::into)
        }
    };
    result.with_context(|| name)
}

/// Writes through `body` to `path` atomically, or to stdout when `None`.
pub fn write_output(
    path: Option<&Path>,
    body: impl FnOnce(&mut dyn Write) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    match path {
        None => {
            let stdout = io::stdout();
            grow_pipe(&stdout);
            let mut w = BufWriter::with_capacity(1 << 16, stdout.lock());
            body(&mut w)?;
            w.flush()?;
            Ok(())
        }
        Some(path) => write_atomic(path, body).with_context(|| path.display().to_string()),
    }
}

/// Writes to a temp file beside `path`, then renames it into place: a
/// failure never leaves a partial file at `path`. Devices and FIFOs are
/// written directly.
pub fn write_atomic(
    path: &Path,
    body: impl FnOnce(&mut dyn Write) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    // A device or FIFO (`-o /dev/null`, a named pipe) is written directly.
    if std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
        let f = std::fs::OpenOptions::new().write(true).open(path)?;
        let mut w = BufWriter::with_capacity(1 << 16, f);
        body(&mut w)?;
        w.flush()?;
        return Ok(());
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let tmp = tempfile::Builder::new()
        .prefix(".pcsss-")
        .suffix(".tmp")
        .tempfile_in(dir)?;
    {
        let mut w = BufWriter::with_capacity(1 << 16, tmp.as_file());
        body(&mut w)?;
        w.flush()?;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))?;
    }
    tmp.persist(path)?;
    Ok(())
}

/// Asks the kernel for a 1 MiB pipe buffer when `fd` is a pipe (Linux):
/// with the default 64 KiB, a pipe moves data at a third of the speed
/// (measured in benches/ply_io.rs). Anything else is left alone.
pub fn grow_pipe(fd: &impl std::os::fd::AsRawFd) {
    #[cfg(target_os = "linux")]
    {
        let fd = fd.as_raw_fd();
        // SAFETY: fstat and fcntl on a descriptor we hold; failures ignored.
        unsafe {
            let mut st: libc::stat = std::mem::zeroed();
            if libc::fstat(fd, &mut st) == 0 && (st.st_mode & libc::S_IFMT) == libc::S_IFIFO {
                libc::fcntl(fd, libc::F_SETPIPE_SZ, 1 << 20);
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = fd;
}

/// Reads all of `path` (stdin when `None`) into memory.
pub fn read_bytes(path: Option<&Path>) -> anyhow::Result<Vec<u8>> {
    let mut v = Vec::new();
    match path {
        Some(p) if p != Path::new("-") => {
            File::open(p)?.read_to_end(&mut v)?;
        }
        _ => {
            io::stdin().lock().read_to_end(&mut v)?;
        }
    }
    Ok(v)
}

/// Reads a lights file (`formats/LIGHTS.md`) and keeps the lights the
/// mask selects (an error names the file, or the mask that selects none).
pub fn read_lights(path: &Path, mask: &str) -> anyhow::Result<Vec<crate::lights::Light>> {
    let name = path.display().to_string();
    let text = std::fs::read(path).with_context(|| name.clone())?;
    let text = String::from_utf8(text).map_err(|_| anyhow::anyhow!("{name}: not UTF-8 text"))?;
    let all = crate::lights::parse(&text, &name)?;
    Ok(crate::lights::mask(&all, mask)?
        .into_iter()
        .map(|i| all[i].clone())
        .collect())
}

/// Reads a camera file (`formats/CAMERA.md`).
pub fn read_camera(path: &Path) -> anyhow::Result<crate::stages::render::Camera> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).with_context(|| name.clone())?;
    Ok(crate::stages::render::Camera::parse(&text, &name)?)
}

/// Reads a mesh (a file with faces) as triangles; errors name the file.
pub fn read_mesh(path: &Path) -> anyhow::Result<crate::geom::mesh::TriMesh> {
    let cloud = read_input(Some(path), &Select::only(&["P"]))?;
    crate::geom::mesh::TriMesh::from_cloud(&cloud).map_err(at(&path.display().to_string()))
}

/// Messages to stderr, prefixed with the stage name.
#[derive(Clone, Copy, Debug)]
pub struct Messages {
    stage: &'static str,
    level: u8,
}

impl Messages {
    /// A normal message (silenced by `-q`).
    pub fn info(&self, msg: impl std::fmt::Display) {
        if self.level >= 1 {
            eprintln!("{}: {msg}", self.stage);
        }
    }

    /// A warning (silenced by `-q`).
    pub fn warn(&self, msg: impl std::fmt::Display) {
        if self.level >= 1 {
            eprintln!("{}: warning: {msg}", self.stage);
        }
    }

    /// Detail shown with `-v`.
    pub fn debug(&self, msg: impl std::fmt::Display) {
        if self.level >= 2 {
            eprintln!("{}: {msg}", self.stage);
        }
    }

    /// True when progress may be drawn: not quiet and stderr is a terminal.
    pub fn progress_enabled(&self) -> bool {
        self.level >= 1 && io::stderr().is_terminal()
    }

    /// A progress bar when one may be drawn, else a silent counter; the
    /// stages print their phases' times when `PCSSS_TIMES` is set.
    pub fn progress(&self) -> crate::progress::Progress {
        let p = if self.progress_enabled() {
            crate::progress::Progress::bar(self.stage)
        } else {
            crate::progress::Progress::hidden()
        };
        p.with_phase_times(env_flag("PCSSS_TIMES"))
    }
}

/// True when an error chain holds a broken pipe.
pub fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<io::Error>()
            .is_some_and(|e| e.kind() == io::ErrorKind::BrokenPipe)
            || c.downcast_ref::<crate::Error>()
                .is_some_and(|e| e.is_broken_pipe())
    })
}

/// True when an error chain holds a bad parameter ([`crate::Error::Param`]).
pub fn is_param_error(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<crate::Error>()
            .is_some_and(|e| matches!(e, crate::Error::Param { .. }))
    })
}

/// Runs a stage's body: on error prints `stage: context: error` on one line
/// and returns exit status 2 for a bad parameter (as for a usage error),
/// 1 for anything else (a broken pipe is success).
pub fn main_of(stage: &str, body: impl FnOnce() -> anyhow::Result<()>) -> ExitCode {
    match body() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            let line = format!("{e:#}").replace('\n', " ");
            eprintln!("{stage}: {line}");
            ExitCode::from(if is_param_error(&e) { 2 } else { 1 })
        }
    }
}

/// Prefixes a library error with the file (or `<stdin>`) it is about:
/// `.map_err(cli::at(&name))`.
pub fn at(name: &str) -> impl Fn(crate::Error) -> anyhow::Error + '_ {
    move |e| anyhow::anyhow!("{name}: {e}")
}

/// Parses the command line like `clap::Parser::parse`, with one help
/// layout for every binary (each option's text on the line below it) and
/// `--version` naming the binary; a usage error is one line on stderr,
/// `stage: error: ... (see --help)`, exit status 2.
pub fn parse<T: clap::Parser>(stage: &'static str) -> T {
    let cmd = T::command()
        .name(stage)
        .bin_name(stage)
        .next_line_help(true);
    let parsed = cmd
        .try_get_matches()
        .and_then(|mut m| T::from_arg_matches_mut(&mut m));
    match parsed {
        Ok(t) => t,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                e.exit();
            }
            let text = e.render().to_string();
            let text = text.split("\n\nUsage:").next().unwrap_or(&text);
            let text = text
                .split("\n\nFor more information")
                .next()
                .unwrap_or(text);
            let line: Vec<&str> = text.split_whitespace().collect();
            eprintln!("{stage}: {} (see --help)", line.join(" "));
            std::process::exit(2);
        }
    }
}

/// `ssmulti`'s parameters (also `filter`'s, for lazy evaluation).
#[derive(clap::Args, Debug, Clone)]
pub struct SsArgs {
    /// Diffuse reflectance: R,G,B (or one value for all three).
    #[arg(long, value_name = "R,G,B", default_value = "1,1,1")]
    pub rd: String,
    /// Scattering distance (per channel: Rd * sd).
    #[arg(long)]
    pub sd: Option<f64>,
    /// Bounce attenuation, 0 (off) to 1.
    #[arg(long, default_value_t = 0.0)]
    pub bounce: f64,
    /// Per-channel distances (Houdini's t_rgb): each channel reaches its Rd times sd.
    #[arg(long)]
    pub rgb: bool,
    /// Falloff kernel.
    #[arg(long, value_enum, default_value = "smooth")]
    pub falloff: FalloffKind,
    /// exp: decay rate (default 4); burley: D / d (default 5.625: the
    /// profile's mean radius equals the smooth falloff's).
    #[arg(long)]
    pub sigma: Option<f64>,
    /// Normalisation.
    #[arg(long, value_enum, default_value = "seed")]
    pub norm: Norm,
    /// 0: the exact method; above: the approximate one, which sums a
    /// cluster of sources whole when its radius is at most T times the
    /// kernel's length scale. Measured RMS error against exact (unit
    /// sphere, 200 to 20,000 neighbours, smooth): 5e-5 to 1e-3 at 0.1,
    /// 2e-3 to 8e-3 at 0.3 (README, "Approximate method").
    #[arg(long, default_value_t = 0.0)]
    pub tolerance: f64,
}

/// `sssingle`'s model parameters (also `filter`'s and `render`'s, to
/// compute `ssS` for the points they read); the seed model's Rd, sd and
/// t_rgb are ssmulti's options.
#[derive(clap::Args, Debug, Clone)]
pub struct SingleArgs {
    /// Single scattering: seed, Marengo's (--rd, --sd); physical, Jensen
    /// et al. 2001 (--albedo, --mfp).
    #[arg(long, value_enum, default_value = "seed")]
    pub model: Model,
    /// Physical model: single-scattering albedo R,G,B in [0, 1].
    #[arg(long, value_name = "R,G,B", default_value = "0.8")]
    pub albedo: String,
    /// Physical model: mean free path R,G,B (1 / extinction).
    #[arg(long, value_name = "R,G,B")]
    pub mfp: Option<String>,
    /// Henyey-Greenstein asymmetry in [-1, 1] (used within +-0.998).
    #[arg(long, default_value_t = 0.0)]
    pub g: f64,
    /// Relative index of refraction, inside over outside.
    #[arg(long, default_value_t = 1.3)]
    pub eta: f64,
    /// Depth samples per point (stratified), 1 to 4096.
    #[arg(long, default_value_t = 16)]
    pub samples: u32,
    /// Random seed of the depth samples and area lights' offsets.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// The mesh's normals are smooth across edges up to this angle
    /// (degrees), as facet's.
    #[arg(long, default_value_t = 60.0)]
    pub cusp: f64,
}

impl SingleArgs {
    /// The parameters for the eye `eye`, with the seed model's `rd`, `sd`
    /// and `rgb`; checked. An error names the option at fault.
    pub fn params(
        &self,
        rd: &str,
        sd: Option<f64>,
        rgb: bool,
        eye: [f64; 3],
    ) -> anyhow::Result<sssingle::Params> {
        let (sd, mfp) = match self.model {
            sssingle::Model::Seed => {
                let sd = sd.ok_or_else(|| {
                    crate::Error::param(
                        "--sd",
                        "required by --model seed (the scattering distance)",
                    )
                })?;
                (sd, [1.0; 3])
            }
            sssingle::Model::Physical => {
                let mfp = self.mfp.as_deref().ok_or_else(|| {
                    crate::Error::param(
                        "--mfp",
                        "required by --model physical (the mean free path)",
                    )
                })?;
                (0.0, parse_rgb("--mfp", mfp)?)
            }
        };
        let p = sssingle::Params {
            model: self.model,
            rd: parse_rgb("--rd", rd)?,
            sd,
            albedo: parse_rgb("--albedo", &self.albedo)?,
            mfp,
            g: self.g,
            eta: self.eta,
            samples: self.samples,
            rgb,
            seed: self.seed,
            eye: glam::DVec3::from_array(eye),
            cusp: self.cusp,
        };
        sssingle::validate(&p)?;
        Ok(p)
    }
}

impl SsArgs {
    /// The parameters, `None` without `--sd`; checked. `PCSSS_NO_AVX2`
    /// in the environment forces the baseline pair loop.
    pub fn params(&self) -> anyhow::Result<Option<Params>> {
        let Some(sd) = self.sd else { return Ok(None) };
        let params = Params {
            rd: parse_rgb("--rd", &self.rd)?,
            sd,
            bounce: self.bounce,
            rgb: self.rgb,
            falloff: Falloff::new(self.falloff, self.sigma),
            norm: self.norm,
            tolerance: self.tolerance,
            simd: if env_flag("PCSSS_NO_AVX2") {
                Simd::Baseline
            } else {
                Simd::Auto
            },
        };
        ssmulti::validate(&params)?;
        Ok(Some(params))
    }
}

/// True when the environment variable `name` is set (to anything): the
/// switches the binaries read for the library (`PCSSS_NO_AVX2`,
/// `PCSSS_TIMES`, `PCSSS_NO_MMAP`).
pub fn env_flag(name: &str) -> bool {
    std::env::var_os(name).is_some()
}

/// Numbers separated by commas, the value of option `flag`.
fn parse_list(flag: &str, s: &str) -> anyhow::Result<Vec<f64>> {
    Ok(s.split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| crate::Error::param(flag, format!("'{s}': {e}")))?)
}

/// `X,Y,Z`, the value of option `flag` (named in errors).
pub fn parse_xyz(flag: &str, s: &str) -> anyhow::Result<[f64; 3]> {
    match parse_list(flag, s)?[..] {
        [x, y, z] => Ok([x, y, z]),
        _ => Err(crate::Error::param(flag, format!("'{s}' is not X,Y,Z")).into()),
    }
}

/// `R,G,B` or one value for all three, the value of option `flag`
/// (named in errors).
pub fn parse_rgb(flag: &str, s: &str) -> anyhow::Result<[f64; 3]> {
    match parse_list(flag, s)?[..] {
        [x] => Ok([x; 3]),
        [r, g, b] => Ok([r, g, b]),
        _ => Err(crate::Error::param(flag, format!("'{s}' is not R,G,B or one value")).into()),
    }
}
