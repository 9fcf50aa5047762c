//! What every binary shares: input and output, formats, messages, errors.
//!
//! - The positional argument is the main input; absent or `-` means stdin.
//!   A terminal on stdin with no input is an error, not a hang.
//! - `-o FILE` writes a file atomically (a temp file beside it, renamed
//!   into place when complete); absent or `-` writes stdout.
//! - The output format comes from `--format`, else the output's extension,
//!   else binary little-endian PLY.
//! - Messages go to stderr; `-q` silences them, `-v` adds detail.
//! - Errors are one line, `stage: file: what is wrong`; exit status 2 for
//!   a usage error or a bad parameter, 1 otherwise; a broken pipe (`| head`)
//!   is success.
//!
//! Output files and signals are the library's ([`crate::files`]); the
//! stages' shared options are in [`args`], `pctile split --for`'s stage
//! arguments in [`stage_args`].

pub mod args;
mod memory;
pub mod stage_args;
pub mod stages;

pub use args::{
    parse_bytes, parse_rgb, parse_xyz, GatherArgs, IllumArgs, LazyWalkArgs, MaterialArgs,
    PerPointArgs, SingleArgs, SsArgs, SssingleArgs, WalkArgs,
};

use std::io::{self, BufReader, IsTerminal, Read};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::OnceLock;

use anyhow::Context;

use crate::cloud::Cloud;
use crate::files::{self, grow_pipe};
use crate::formats::exr::{Compression, ExrOptions};
use crate::formats::{self, Format, Select};
pub use memory::{Memory, MemoryIo};

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
    /// A USD stage input: read the meshes at or under this prim alone
    /// (the same as IN:/prim).
    #[arg(long, value_name = "/PRIM/PATH")]
    pub prim: Option<String>,
    /// USD stages (the input, and any a file option names) read at this
    /// time code: the frame of an animation, its time samples
    /// interpolated as Pixar's library does [default: the stage's
    /// default values; an attribute with many samples is refused].
    #[arg(long, value_name = "TIME")]
    pub frame: Option<f64>,
    /// Output file; standard output when absent or '-'.
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Output format: ply, ply-ascii, ply-be, exr, usda, usdc, usdz
    /// [default: from the output file's extension, else ply (binary
    /// little-endian)].
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
    /// The input and output in memory, not in files (the Python module's
    /// way to run a stage on a cloud it holds); not an option.
    #[arg(skip)]
    pub memory: Option<Memory>,
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
        // (From Python, the cloud a stage was given.)
        if self.memory.is_some() {
            return "the input cloud".into();
        }
        display_name(self.input.as_deref())
    }

    /// Reads the main input, decoding `select`ed attributes now (the
    /// output was checked before, by [`main`]).
    pub fn read(&self, select: &Select) -> anyhow::Result<Cloud> {
        if let Some(m) = &self.memory {
            let cloud = m
                .take_input()
                .ok_or_else(|| anyhow::anyhow!("no input cloud (it was read already)"))?;
            // What a file's reader decodes as it reads, decoded now.
            let names: Vec<&str> = cloud
                .points()
                .attrs()
                .iter()
                .map(|a| a.name.as_str())
                .filter(|n| select.wants(n))
                .collect();
            cloud.points().decode(&names);
            return Ok(cloud);
        }
        match &self.prim {
            None => read_input(self.input.as_deref(), select),
            Some(prim) => {
                let input = self.input.as_deref().filter(|p| *p != Path::new("-"));
                let stage = input.and_then(formats::usd::stage_file);
                let (Some(stage), true) = (stage, prim.starts_with('/')) else {
                    let why = "names a prim of a USD stage: give the stage's file as the input, and the prim's path from /";
                    return Err(crate::Error::param("prim", why).into());
                };
                let path = PathBuf::from(format!("{}:{prim}", stage.display()));
                read_input(Some(&path), select)
            }
        }
    }

    /// The output format in force.
    pub fn output_format(&self) -> Format {
        self.format
            .or_else(|| self.output.as_deref().and_then(Format::from_path))
            .unwrap_or(Format::DEFAULT)
    }

    /// Writes `cloud`, which the stage is done with: in memory it is
    /// handed over, not copied.
    pub fn write_owned(&self, cloud: Cloud) -> anyhow::Result<()> {
        if let Some(m) = &self.memory {
            if let Ok(mut io) = m.0.lock() {
                io.output = Some(cloud);
            }
            return Ok(());
        }
        self.write(&cloud)
    }

    /// Writes `cloud` to the output in the chosen format.
    pub fn write(&self, cloud: &Cloud) -> anyhow::Result<()> {
        if let Some(m) = &self.memory {
            if let Ok(mut io) = m.0.lock() {
                io.output = Some(cloud.clone());
            }
            return Ok(());
        }
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
        Ok(files::write_output(out, |w| {
            formats::write_cloud_with(w, cloud, format, &opt)
        })?)
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
            // `PCSSS_STREAM`: read files as streams, not whole.
            formats::read_cloud_file_noting(p, select, !env_flag("PCSSS_STREAM"), &mut |w| {
                say(format_args!("{name}: warning: {w}"))
            })
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

/// Reads all of `path` (stdin when `None`) into memory.
pub fn read_bytes(path: Option<&Path>) -> anyhow::Result<Vec<u8>> {
    let mut v = Vec::new();
    match path {
        Some(p) if p != Path::new("-") => {
            files::open_input(p)?.read_to_end(&mut v)?;
        }
        _ => {
            io::stdin().lock().read_to_end(&mut v)?;
        }
    }
    Ok(v)
}

/// The largest lights or camera file read (`formats/LIGHTS.md`): a file
/// that goes on (`/dev/zero`) is refused, not read until memory runs out.
pub const MAX_JSON_BYTES: u64 = 16 << 20;

/// A JSON file's text, at most [`MAX_JSON_BYTES`]; errors name the file.
fn read_json_text(path: &Path) -> anyhow::Result<String> {
    let name = path.display().to_string();
    let f = files::open_input(path).with_context(|| name.clone())?;
    let mut bytes = Vec::new();
    f.take(MAX_JSON_BYTES + 1)
        .read_to_end(&mut bytes)
        .with_context(|| name.clone())?;
    if bytes.len() as u64 > MAX_JSON_BYTES {
        anyhow::bail!(
            "{name}: larger than {} MiB: not a lights or camera file",
            MAX_JSON_BYTES >> 20
        );
    }
    String::from_utf8(bytes).map_err(|_| anyhow::anyhow!("{name}: not UTF-8 text"))
}

/// Reads a lights file (`formats/LIGHTS.md`) and keeps the lights the
/// mask selects (an error names the file, or the mask that selects none);
/// [`crate::lights::LightsFile::in_frame`] then moves them into a cloud's
/// frame.
pub fn read_lights(path: &Path, mask: &str) -> anyhow::Result<crate::lights::LightsFile> {
    let name = path.display().to_string();
    let text = match formats::usd::stage_file(path) {
        Some(_) => formats::usd::lights_json(path).with_context(|| name.clone())?,
        None => read_json_text(path)?,
    };
    let path = formats::usd::stage_file(path).unwrap_or(path);
    // A dome's map is read beside the lights file.
    let dir = path.parent().map(|d| {
        if d.as_os_str().is_empty() {
            Path::new(".")
        } else {
            d
        }
    });
    let mut file = crate::lights::parse_file_in(&text, &name, dir)?;
    file.lights = crate::lights::mask(&file.lights, mask)?
        .into_iter()
        .map(|i| file.lights[i].clone())
        .collect();
    Ok(file)
}

/// The height in pixels of a picture through a USD camera (its width
/// follows the apertures): USD keeps resolution in render settings, not
/// on the camera.
pub const USD_CAMERA_HEIGHT: u32 = 512;

/// Reads a camera file (`formats/CAMERA.md`), or a USD stage's camera.
pub fn read_camera(path: &Path) -> anyhow::Result<crate::stages::render::Camera> {
    let name = path.display().to_string();
    let text = match formats::usd::stage_file(path) {
        Some(_) => {
            formats::usd::camera_json(path, USD_CAMERA_HEIGHT).with_context(|| name.clone())?
        }
        None => read_json_text(path)?,
    };
    Ok(crate::stages::render::Camera::parse(&text, &name)?)
}

/// Reads a mesh (a file with faces) as triangles; errors name the file.
/// A mesh whose every face has zero area is refused: light cannot enter
/// it nor be blocked by it, and that is a wrong file, not a scene.
pub fn read_mesh(path: &Path) -> anyhow::Result<crate::geom::mesh::TriMesh> {
    Ok(read_mesh_timed(path)?.0)
}

/// [`read_mesh`], and the USD time code the mesh was read at (its
/// `usd_time`, when it has one: a frame of an animated stage).
pub fn read_mesh_timed(path: &Path) -> anyhow::Result<(crate::geom::mesh::TriMesh, Option<f64>)> {
    let name = path.display().to_string();
    let cloud = read_input(Some(path), &Select::only(&["P"]))?;
    let mesh = crate::geom::mesh::TriMesh::from_cloud(&cloud).map_err(at(&name))?;
    mesh.require_area().map_err(at(&name))?;
    let time = cloud
        .detail(crate::names::D_USD_TIME)
        .and_then(|d| d.as_f64());
    Ok((mesh, time))
}

/// One line on stderr. A stderr that cannot be written (closed, a
/// broken pipe) loses the line; it never ends the stage.
pub fn say(line: std::fmt::Arguments) {
    use std::io::Write;
    let mut e = io::stderr().lock();
    let _ = e.write_fmt(line).and_then(|()| e.write_all(b"\n"));
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
            say(format_args!("{}: {msg}", self.stage));
        }
    }

    /// A warning (silenced by `-q`).
    pub fn warn(&self, msg: impl std::fmt::Display) {
        if self.level >= 1 {
            say(format_args!("{}: warning: {msg}", self.stage));
        }
    }

    /// Detail shown with `-v`.
    pub fn debug(&self, msg: impl std::fmt::Display) {
        if self.level >= 2 {
            say(format_args!("{}: {msg}", self.stage));
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

/// The command line with each option's value that is a negative number
/// joined to the option (`--halo -1e-300` as `--halo=-1e-300`): clap
/// takes a negative number with a signed exponent for short flags.
fn join_negative_numbers(
    cmd: &clap::Command,
    argv: Vec<std::ffi::OsString>,
) -> Vec<std::ffi::OsString> {
    fn options(cmd: &clap::Command, out: &mut Vec<String>) {
        for a in cmd.get_arguments() {
            if a.get_action().takes_values() {
                out.extend(a.get_long().map(|l| format!("--{l}")));
                out.extend(a.get_short().map(|c| format!("-{c}")));
            }
        }
        for sub in cmd.get_subcommands() {
            options(sub, out);
        }
    }
    let mut takes = Vec::new();
    options(cmd, &mut takes);
    let mut out = Vec::with_capacity(argv.len());
    let mut it = argv.into_iter().peekable();
    while let Some(a) = it.next() {
        let joined = match (a.to_str(), it.peek().and_then(|v| v.to_str())) {
            (Some(opt), Some(v))
                if takes.iter().any(|t| t == opt)
                    && v.starts_with('-')
                    && v.parse::<f64>().is_ok() =>
            {
                Some(format!("{opt}={v}"))
            }
            _ => None,
        };
        match joined {
            Some(j) => {
                it.next();
                out.push(j.into());
            }
            None => out.push(a),
        }
    }
    out
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
            .is_some_and(crate::Error::is_param)
    })
}

/// A binary's `main`: parses `T` from the command line ([`parse`]), runs
/// `run` with it, and reports its error ([`main_of`]).
pub fn main<T: clap::Parser>(
    stage: &'static str,
    run: impl FnOnce(T) -> anyhow::Result<()>,
) -> ExitCode {
    let (args, matches) = parse_matches::<T>(stage);
    let cmd = T::command();
    main_of(stage, &|name| flag_of(&cmd, name), || {
        let time = frame_of(&matches)?;
        check_named_paths(&cmd, &matches, &[])?;
        formats::usd::at_time(time, || run(args))
    })
}

/// The time code `--frame` gives (a stage without the option: none),
/// finite.
fn frame_of(m: &clap::ArgMatches) -> anyhow::Result<Option<f64>> {
    let Ok(Some(t)) = m.try_get_one::<f64>("frame") else {
        return Ok(None);
    };
    if !t.is_finite() {
        return Err(crate::Error::param("frame", format!("{t}: not a time code (finite)")).into());
    }
    Ok(Some(*t))
}

/// A stage's parser as its binary runs it.
fn command_of<T: clap::Parser>(stage: &'static str) -> clap::Command {
    // A negative number is a value (`--cusp -1` reaches the parameter's
    // own check, not "unexpected argument"), and so is a vector that
    // starts with one (`--eye -3,2,4`).
    T::command()
        .name(stage)
        .bin_name(stage)
        .next_line_help(true)
        .mut_args(|a| {
            let vector = a
                .get_value_names()
                .is_some_and(|v| v.iter().any(|n| n.as_str().contains(',')));
            if vector {
                a.allow_hyphen_values(true)
            } else if a.get_action().takes_values() {
                a.allow_negative_numbers(true)
            } else {
                a
            }
        })
}

/// A usage error as one line.
fn usage_line(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let text = text.split("\n\nUsage:").next().unwrap_or(&text);
    let text = text
        .split("\n\nFor more information")
        .next()
        .unwrap_or(text);
    let line: Vec<&str> = text.split_whitespace().collect();
    format!("{} (see --help)", line.join(" "))
}

/// Why a stage called by [`call`] failed: its one-line message, as the
/// binary prints it after `stage: `, and whether a parameter is at fault
/// (the binary's exit status 2) rather than a file (1).
#[derive(Debug)]
pub struct Failure {
    pub line: String,
    pub param: bool,
}

/// Runs a stage as its binary would, on the command line `argv` (without
/// the program's name), in this process: the Python module's way in. The
/// command line is parsed by the binary's own parser (a usage error is a
/// parameter's failure), outputs are checked against inputs before any
/// work, and an error is the line the binary prints.
pub fn call<T: clap::Parser>(
    stage: &'static str,
    argv: &[String],
    run: impl FnOnce(T) -> anyhow::Result<()>,
) -> Result<(), Failure> {
    let cmd = command_of::<T>(stage);
    let args = std::iter::once(stage.into())
        .chain(argv.iter().map(Into::into))
        .collect();
    let args = join_negative_numbers(&cmd, args);
    let usage = |e: clap::Error| Failure {
        line: usage_line(&e),
        param: true,
    };
    let matches = cmd.clone().try_get_matches_from(args).map_err(usage)?;
    let args = T::from_arg_matches(&matches).map_err(usage)?;
    let result = check_environment()
        .map_err(anyhow::Error::from)
        .and_then(|()| frame_of(&matches))
        .and_then(|time| {
            check_paths(&cmd, &matches, &[], false)?;
            formats::usd::at_time(time, || run(args))
        });
    result.map_err(|mut e| {
        if let Some(lib) = e.downcast_mut::<crate::Error>() {
            lib.rename_params(&|name| flag_of(&cmd, name));
        }
        Failure {
            line: format!("{e:#}").replace('\n', " "),
            param: is_param_error(&e),
        }
    })
}

/// The outputs and the inputs a command line names: the values of the
/// options `output` (a directory when its value is named `DIR`) and `png`
/// are outputs (`-` is standard output); every other value that names an
/// existing file or directory is an input (values that are not paths name
/// none).
pub fn named_paths(
    cmd: &clap::Command,
    m: &clap::ArgMatches,
) -> (Vec<(PathBuf, &'static str, bool)>, Vec<PathBuf>) {
    let (mut outputs, mut inputs) = (Vec::new(), Vec::new());
    for a in cmd.get_arguments() {
        if !a.get_action().takes_values() {
            continue;
        }
        let id = a.get_id().as_str();
        let Ok(Some(values)) = m.try_get_raw(id) else {
            continue;
        };
        for v in values {
            let path = PathBuf::from(v);
            if let Some(param) = ["output", "png"].into_iter().find(|o| *o == id) {
                if path != Path::new("-") {
                    let dir = a
                        .get_value_names()
                        .is_some_and(|n| n.iter().any(|n| n.as_str() == "DIR"));
                    outputs.push((path, param, dir));
                }
            } else if path.exists() {
                inputs.push(path);
            } else if let (file, Some(_)) = formats::usd::split_prim(&path) {
                // `scene.usda:/prim` reads scene.usda.
                if file.exists() {
                    inputs.push(file.to_path_buf());
                }
            }
        }
    }
    if let Some((name, sub)) = m.subcommand() {
        if let Some(c) = cmd.find_subcommand(name) {
            let (o, i) = named_paths(c, sub);
            outputs.extend(o);
            inputs.extend(i);
        }
    }
    (outputs, inputs)
}

/// Checks the outputs a command line names against its inputs and
/// `more_inputs` (ones a binary reads without naming them: a split's
/// tiles), before any work ([`files::check_outputs`]).
pub fn check_named_paths(
    cmd: &clap::Command,
    m: &clap::ArgMatches,
    more_inputs: &[&Path],
) -> anyhow::Result<()> {
    check_paths(cmd, m, more_inputs, true)
}

/// [`check_named_paths`]; `stdout`: the run may write standard output (a
/// binary's; not a run in memory, the Python module's). Starts the run's
/// record of what it opens ([`files::begin_run`]).
fn check_paths(
    cmd: &clap::Command,
    m: &clap::ArgMatches,
    more_inputs: &[&Path],
    stdout: bool,
) -> anyhow::Result<()> {
    files::begin_run();
    let (outputs, inputs) = named_paths(cmd, m);
    // No output file named where a stage can name one: the output is
    // stdout, which must be open. A binary that names none writes its
    // report there (pcinfo, pcdiff).
    let has_output = cmd.get_arguments().any(|a| a.get_id() == "output");
    if stdout && has_output && outputs.is_empty() {
        files::check_stdout_open()?;
    }
    let stdout = stdout && outputs.is_empty();
    let outs: Vec<files::Output> = outputs
        .iter()
        .map(|&(ref path, param, dir)| files::Output { path, param, dir })
        .collect();
    let mut ins: Vec<&Path> = inputs.iter().map(|p| p.as_path()).collect();
    ins.extend_from_slice(more_inputs);
    // (An output that is an input first: that one would lose data.)
    files::check_outputs_to(&outs, &ins, stdout)?;
    Ok(check_output_formats(cmd, m)?)
}

/// A cloud output whose name has an extension the writers do not know
/// (`x.usdc`, `x.bgeo`) is refused before any work, unless `--format`
/// says what to write under it: written as PLY, the file would lie about
/// what it holds. A name without an extension is PLY.
/// (A subcommand's output, `pctile merge -o`, is its own to check.)
fn check_output_formats(cmd: &clap::Command, m: &clap::ArgMatches) -> crate::Result<()> {
    let has_format = cmd.get_arguments().any(|a| a.get_id() == "format");
    if !has_format || matches!(m.try_get_raw("format"), Ok(Some(_))) {
        return Ok(());
    }
    let Ok(Some(values)) = m.try_get_raw("output") else {
        return Ok(());
    };
    for path in values.map(Path::new).filter(|p| *p != Path::new("-")) {
        Format::for_output(path).map_err(|why| crate::Error::param("output", why))?;
    }
    Ok(())
}

/// Runs a stage's body: on error prints `stage: context: error` on one line
/// and returns exit status 2 for a bad parameter (as for a usage error),
/// 1 for anything else (a broken pipe is success). A library error names
/// a parameter as the library does (`sd`); the line names the option
/// `flag` gives for it (`--sd`; [`flag_of`] the binary's command).
pub fn main_of(
    stage: &str,
    flag: &dyn Fn(&str) -> Option<String>,
    body: impl FnOnce() -> anyhow::Result<()>,
) -> ExitCode {
    crate::alloc::keep_freed_memory();
    files::init_umask();
    files::remove_temps_on_signals();
    match check_environment()
        .map_err(anyhow::Error::from)
        .and_then(|()| body())
    {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(mut e) => {
            if let Some(lib) = e.downcast_mut::<crate::Error>() {
                lib.rename_params(flag);
            }
            let line = format!("{e:#}").replace('\n', " ");
            say(format_args!("{stage}: {line}"));
            ExitCode::from(if is_param_error(&e) { 2 } else { 1 })
        }
    }
}

/// The option of `cmd` (or of its subcommands) that sets the parameter
/// `name`: the argument whose id is `name` (clap's derive names an
/// argument after its field), else whose long name is `name` with
/// hyphens for underscores.
pub fn flag_of(cmd: &clap::Command, name: &str) -> Option<String> {
    let long = name.replace('_', "-");
    let own = cmd
        .get_arguments()
        .find(|a| a.get_id() == name)
        .or_else(|| cmd.get_arguments().find(|a| a.get_long() == Some(&long)));
    if let Some(a) = own {
        return match (a.get_long(), a.get_short()) {
            (Some(long), _) => Some(format!("--{long}")),
            (None, Some(short)) => Some(format!("-{short}")),
            (None, None) => None,
        };
    }
    cmd.get_subcommands().find_map(|c| flag_of(c, name))
}

/// `e`, about parameter `name` when it is a bad parameter: for an option
/// passed on as another's (render's `--single-lmask` as the lights' mask).
pub fn as_param(mut e: anyhow::Error, name: &str) -> anyhow::Error {
    if let Some(lib) = e.downcast_mut::<crate::Error>() {
        lib.rename_params(&|_| Some(name.to_string()));
    }
    e
}

/// Prefixes a library error with the file (or `<stdin>`) it is about:
/// `.map_err(cli::at(&name))`; an error that already names its input
/// ([`crate::Error::In`]) keeps that name.
pub fn at(name: &str) -> impl Fn(crate::Error) -> anyhow::Error + '_ {
    move |e| match e {
        // (A parameter is not about a file, and keeps its exit status 2.)
        crate::Error::In { .. } | crate::Error::Param { .. } => anyhow::Error::from(e),
        e => anyhow::anyhow!("{name}: {e}"),
    }
}

/// Parses the command line like `clap::Parser::parse`, with one help
/// layout for every binary (each option's text on the line below it) and
/// `--version` naming the binary; a usage error is one line on stderr,
/// `stage: error: ... (see --help)`, exit status 2.
pub fn parse<T: clap::Parser>(stage: &'static str) -> T {
    parse_matches(stage).0
}

/// [`parse`], with clap's matches (what [`named_paths`] reads).
pub fn parse_matches<T: clap::Parser>(stage: &'static str) -> (T, clap::ArgMatches) {
    let cmd = command_of::<T>(stage);
    let argv = join_negative_numbers(&cmd, std::env::args_os().collect());
    let parsed = cmd
        .try_get_matches_from(argv)
        .and_then(|m| T::from_arg_matches(&m).map(|t| (t, m)));
    match parsed {
        Ok(t) => t,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                e.exit();
            }
            say(format_args!("{stage}: {}", usage_line(&e)));
            std::process::exit(2);
        }
    }
}

/// The switches the binaries read from the environment: `PCSSS_NO_AVX2`
/// (ssmulti's baseline pair loop), `PCSSS_TIMES` (each phase's time on
/// stderr), `PCSSS_STREAM` (input files streamed, not read whole).
pub const SWITCHES: [&str; 3] = ["PCSSS_NO_AVX2", "PCSSS_TIMES", "PCSSS_STREAM"];

/// The most worker threads `RAYON_NUM_THREADS` may ask for.
pub const MAX_THREADS: usize = 1024;

/// A switch's value: off when unset, empty, `0`, `false`, `no` or `off`;
/// on when `1`, `true`, `yes` or `on`; anything else is not a switch.
fn switch_value(name: &str) -> Result<bool, String> {
    let Some(v) = std::env::var_os(name) else {
        return Ok(false);
    };
    match v.to_string_lossy().trim().to_ascii_lowercase().as_str() {
        "" | "0" | "false" | "no" | "off" => Ok(false),
        "1" | "true" | "yes" | "on" => Ok(true),
        other => Err(format!("'{other}' is not 0 or 1 (off or on)")),
    }
}

/// True when the switch `name` ([`SWITCHES`]) is on.
pub fn env_flag(name: &str) -> bool {
    switch_value(name).unwrap_or(false)
}

/// Checks, before any work, what the binaries read from the environment:
/// every switch is 0 or 1, and `RAYON_NUM_THREADS` (the thread pool's
/// size) is empty, 0 (a thread a core) or a count up to [`MAX_THREADS`];
/// the pool is built with it. A bad value is a bad parameter named by the
/// variable.
pub fn check_environment() -> crate::Result<()> {
    for name in SWITCHES {
        switch_value(name).map_err(|why| crate::Error::param(name, why))?;
    }
    const THREADS: &str = "RAYON_NUM_THREADS";
    let Some(v) = std::env::var_os(THREADS) else {
        return Ok(());
    };
    let v = v.to_string_lossy();
    let n = match v.trim() {
        "" => 0,
        t => t
            .parse::<usize>()
            .map_err(|_| crate::Error::param(THREADS, format!("'{t}' is not a thread count")))?,
    };
    if n > MAX_THREADS {
        let why = format!("{n} threads: at most {MAX_THREADS} (0 for one a core)");
        return Err(crate::Error::param(THREADS, why));
    }
    // (Built here, with the count, so that rayon never reads the
    // variable itself.)
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    let n = if n == 0 { cores } else { n };
    start_threads(n);
    Ok(())
}

/// The address space a worker thread takes: its stack (Rust's default, 2
/// MiB) and what the allocator and the thread's own data take beside it.
const THREAD_SPACE: u64 = 4 << 20;

/// The process's address-space limit (`ulimit -v`), if it has one.
fn address_limit() -> Option<u64> {
    let mut r = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit fills the struct it is given, and nothing else.
    let ok = unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut r) } == 0;
    (ok && r.rlim_cur != libc::RLIM_INFINITY).then_some(r.rlim_cur)
}

/// The pool the stages run in when the global one could not start: the
/// machine refused `RAYON_NUM_THREADS` threads (an address-space limit),
/// and rayon builds its global pool once, so a failed start would make
/// the first parallel loop panic. The thread that starts it is one of
/// its workers, so every parallel loop it runs runs there.
static FALLBACK_POOL: OnceLock<rayon::ThreadPool> = OnceLock::new();

/// Starts `n` worker threads as rayon's global pool; when the machine
/// refuses them, as many as it gives (halving the count) in a pool the
/// calling thread joins, with one line saying so.
fn start_threads(n: usize) {
    // Under an address-space limit, threads whose stacks would take more
    // than an eighth of it are not asked for: past that the machine gives
    // the threads and then refuses the memory they need (glibc aborts),
    // and the allocators' per-thread reservations (glibc's arenas,
    // mimalloc's) take much of the rest (at a quarter, one run in many
    // under load still ended without a word).
    let most = address_limit().map_or(usize::MAX, |a| (a / 8 / THREAD_SPACE).max(1) as usize);
    let n = if n > most {
        say(format_args!(
            "RAYON_NUM_THREADS: {n} threads would take more than an eighth of the address space this process may use; running on {most}"
        ));
        most
    } else {
        n
    };
    let Err(e) = rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build_global()
    else {
        return;
    };
    // Built already (an earlier run in this process) is no failure.
    if FALLBACK_POOL.get().is_some() || e.to_string().contains("already") {
        return;
    }
    let mut k = n / 2;
    while k >= 1 {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(k)
            .use_current_thread()
            .build();
        if let Ok(pool) = pool {
            say(format_args!(
                "RAYON_NUM_THREADS: {n} threads could not be started ({e}); running on {k}"
            ));
            let _ = FALLBACK_POOL.set(pool);
            return;
        }
        k /= 2;
    }
}
