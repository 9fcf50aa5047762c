//! Input and output files. Outputs are written atomically (a temp file
//! beside the target, renamed into place when complete), several at once
//! (all or none), checked before any work, created with the user's umask
//! (a file written over keeps its mode), and never left behind
//! half-written when a signal (SIGINT, SIGTERM, SIGHUP) ends the process.
//! An output is never any input: the binaries check their paths before
//! work ([`check_outputs`]), and every input opened through
//! [`open_input`] is remembered, so that no output is renamed over one.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, Once, OnceLock};

use crate::error::{Error, Result};

/// A file's identity: its device and inode (the same file through any
/// link or path).
type Identity = (u64, u64);

fn identity(meta: &std::fs::Metadata) -> Identity {
    (meta.dev(), meta.ino())
}

/// The inputs this process has opened, each with the name it was opened
/// by.
static INPUTS: Mutex<Vec<(Identity, PathBuf)>> = Mutex::new(Vec::new());

/// Opens the input file `path` for reading and remembers it: an output of
/// this process is never renamed over it ([`Staged::commit`]).
pub fn open_input(path: &Path) -> io::Result<File> {
    let f = File::open(path)?;
    if let Ok(meta) = f.metadata() {
        let mut v = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
        v.push((identity(&meta), path.to_path_buf()));
    }
    Ok(f)
}

/// The input (as it was opened) that `path` is, if it is one.
fn opened_input(path: &Path) -> Option<PathBuf> {
    let id = identity(&std::fs::metadata(path).ok()?);
    let v = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
    v.iter().find(|(i, _)| *i == id).map(|(_, p)| p.clone())
}

/// An output a binary will write: a file, or a directory of files (a
/// split's tiles), and the parameter that names it (`output`).
#[derive(Clone, Copy, Debug)]
pub struct Output<'a> {
    pub path: &'a Path,
    pub param: &'a str,
    pub dir: bool,
}

impl<'a> Output<'a> {
    /// The output file `path`, named by the parameter `output`.
    pub fn file(path: &'a Path) -> Output<'a> {
        Output {
            path,
            param: "output",
            dir: false,
        }
    }
}

/// Checks, before any work, the outputs a run will write against its
/// inputs (files or directories named on its command line). An output
/// file must not be any input file (the same file by any path or link),
/// an output directory must not hold an input file (a split would write
/// its tiles over what it reads), and an output file must be creatable:
/// in a directory that exists and can be written. A collision is a bad
/// parameter: the one that names the output.
pub fn check_outputs(outputs: &[Output], inputs: &[&Path]) -> Result<()> {
    let mut ids: Vec<(Identity, &Path)> = inputs
        .iter()
        .filter_map(|p| std::fs::metadata(p).ok().map(|m| (identity(&m), *p)))
        .collect();
    // Standard input redirected from a file (`< cloud.ply`) is an input
    // too, named or not.
    if let Some(m) = std::fs::metadata("/dev/stdin").ok().filter(|m| m.is_file()) {
        ids.push((identity(&m), Path::new("<stdin>")));
    }
    for out in outputs {
        let Ok(meta) = std::fs::metadata(out.path) else {
            if !out.dir {
                check_output(out.path)?;
            }
            continue;
        };
        if !out.dir {
            if let Some((_, input)) = ids.iter().find(|(i, _)| *i == identity(&meta)) {
                return Err(collision(out.param, out.path, input));
            }
            check_output(out.path)?;
            continue;
        }
        for (_, input) in &ids {
            let parent = std::fs::metadata(dir_of(input));
            if parent.is_ok_and(|p| identity(&p) == identity(&meta)) {
                let what = format!(
                    "{}: the directory holds the input {}: write the tiles to another",
                    out.path.display(),
                    input.display()
                );
                return Err(Error::param(out.param, what));
            }
        }
    }
    Ok(())
}

/// The error for an output that is an input, named by `param`.
fn collision(param: &str, output: &Path, input: &Path) -> Error {
    let same = if output == input {
        String::new()
    } else {
        format!(" ({})", input.display())
    };
    let what = format!(
        "{}: is also an input{same}: an output never replaces an input, write it elsewhere",
        output.display()
    );
    Error::param(param, what)
}

/// The temp files being written now: a signal removes them before the
/// process dies.
static IN_FLIGHT: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The directories this process made for its outputs and has not kept
/// yet ([`MadeDir`]): a signal removes them, after the temp files.
static MADE_DIRS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// On SIGINT, SIGTERM or SIGHUP: remove the temp files in flight and the
/// directories made and not yet kept, then die of the signal as if it had
/// no handler (the exit status a shell expects). Installed once, by the
/// binaries (`cli::main_of`).
pub fn remove_temps_on_signals() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
            return;
        };
        std::thread::spawn(move || {
            if let Some(sig) = signals.forever().next() {
                // The lock is held until the process dies: a temp file is
                // created under it (`Staged::create`), so none can appear
                // after this sweep, and none exists unregistered.
                let paths = IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner());
                for p in paths.iter() {
                    let _ = std::fs::remove_file(p);
                }
                let dirs = MADE_DIRS.lock().unwrap_or_else(|e| e.into_inner());
                for d in dirs.iter() {
                    let _ = std::fs::remove_dir_all(d);
                }
                let _ = signal_hook::low_level::emulate_default_handler(sig);
                std::process::exit(128 + sig);
            }
        });
    });
}

/// A temp file registered as in flight until dropped.
struct InFlight(PathBuf);

impl Drop for InFlight {
    fn drop(&mut self) {
        let mut v = IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner());
        v.retain(|p| *p != self.0);
    }
}

/// A directory made for a run's outputs (a split's tiles): removed with
/// all it holds when dropped (the run failed) or when a signal ends the
/// process, kept once [`MadeDir::keep`] says the outputs are in place.
pub struct MadeDir {
    path: PathBuf,
    kept: bool,
}

impl MadeDir {
    /// Makes `path` (with its missing parents) when it is missing: `None`
    /// when it was there already (and is left alone whatever happens).
    /// The guard stands for the topmost directory it made.
    pub fn make(path: &Path) -> Result<Option<MadeDir>> {
        let about = |e: io::Error| Error::from(e).about(&path.display().to_string());
        if path.exists() {
            if !path.is_dir() {
                let what = Error::invalid("not a directory");
                return Err(what.about(&path.display().to_string()));
            }
            return Ok(None);
        }
        let mut top = path;
        while let Some(parent) = top.parent().filter(|p| !p.as_os_str().is_empty()) {
            if parent.exists() {
                break;
            }
            top = parent;
        }
        // Registered before it exists, under the lock the signal handler
        // takes: a signal can never leave it behind unregistered.
        let mut v = MADE_DIRS.lock().unwrap_or_else(|e| e.into_inner());
        v.push(top.to_path_buf());
        if let Err(e) = std::fs::create_dir_all(path) {
            v.pop();
            let _ = std::fs::remove_dir_all(top);
            return Err(about(e));
        }
        Ok(Some(MadeDir {
            path: top.to_path_buf(),
            kept: false,
        }))
    }

    /// The run's outputs are in place: the directory stays.
    pub fn keep(mut self) {
        self.kept = true;
    }
}

impl Drop for MadeDir {
    fn drop(&mut self) {
        let mut v = MADE_DIRS.lock().unwrap_or_else(|e| e.into_inner());
        v.retain(|p| *p != self.path);
        if !self.kept {
            let _ = std::fs::remove_dir_all(&self.path);
        }
    }
}

/// An I/O error about the file `path`.
fn io_at(path: &Path) -> impl Fn(io::Error) -> Error + '_ {
    move |e| Error::Io(e).about(&path.display().to_string())
}

/// The directory a file at `path` goes in.
fn dir_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Checks, before any work, that `path` can be an output: not a
/// directory, in a directory that exists and that a file can be created
/// in (a temp file is made and removed). A device or FIFO (`/dev/null`)
/// is written as it is.
pub fn check_output(path: &Path) -> Result<()> {
    let name = path.display().to_string();
    let meta = std::fs::metadata(path);
    if meta.as_ref().is_ok_and(|m| m.is_dir()) {
        return Err(Error::invalid("is a directory, not an output file").about(&name));
    }
    if meta.is_ok_and(|m| !m.is_file()) {
        return Ok(());
    }
    let dir = dir_of(path);
    if !dir.is_dir() {
        let what = format!("no such directory: {}", dir.display());
        return Err(Error::invalid(what).about(&name));
    }
    // A temp file made and removed as an output's would be (registered,
    // so that a signal meanwhile removes it too).
    let probe = Staged::create(path).map_err(|e| match e {
        Error::In { inner, .. } => match *inner {
            Error::Io(e) => {
                let what = format!("cannot create a file in {}: {}", dir.display(), e.kind());
                Error::Io(io::Error::new(e.kind(), what)).about(&name)
            }
            other => other.about(&name),
        },
        other => other,
    })?;
    drop(probe);
    Ok(())
}

/// The process's umask, read once (from /proc, which leaves it alone;
/// else by setting and restoring it, before the threads start).
fn umask() -> u32 {
    static MASK: OnceLock<u32> = OnceLock::new();
    *MASK.get_or_init(|| {
        let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
        let proc = status
            .lines()
            .find_map(|l| l.strip_prefix("Umask:"))
            .and_then(|m| u32::from_str_radix(m.trim(), 8).ok());
        proc.unwrap_or_else(|| {
            // SAFETY: umask(2) only swaps the process's mask; the old one
            // is put back at once.
            unsafe {
                let old = libc::umask(0o022);
                libc::umask(old);
                old as u32
            }
        })
    })
}

/// Reads the umask now, while the process has one thread: a stage's
/// outputs are created with it.
pub fn init_umask() {
    umask();
}

/// The mode an output at `path` gets: the mode of the file it replaces,
/// else `0666` less the umask (as a new file a shell redirect makes).
fn output_mode(path: &Path) -> u32 {
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => m.permissions().mode() & 0o777,
        _ => 0o666 & !umask(),
    }
}

/// Whether standard output was closed when the process started: Rust's
/// runtime then puts `/dev/null` opened read-write in its place, where a
/// shell's `> /dev/null` opens it write-only. Writing there would lose
/// the output and succeed.
fn stdout_was_closed() -> bool {
    use std::os::unix::fs::FileTypeExt;
    // SAFETY: F_GETFL on descriptor 1 reads its flags and nothing else.
    let flags = unsafe { libc::fcntl(1, libc::F_GETFL) };
    if flags < 0 || flags & libc::O_ACCMODE != libc::O_RDWR {
        return false;
    }
    let (Ok(out), Ok(null)) = (
        std::fs::metadata("/proc/self/fd/1"),
        std::fs::metadata("/dev/null"),
    ) else {
        return false;
    };
    out.file_type().is_char_device() && out.rdev() == null.rdev()
}

/// Refuses a closed standard output, where what a binary writes would
/// be lost with success: one line naming `<stdout>`.
pub fn check_stdout_open() -> Result<()> {
    if stdout_was_closed() {
        let why = "closed: the output has nowhere to go (give -o FILE, or a pipe)";
        return Err(Error::invalid(why).about("<stdout>"));
    }
    Ok(())
}

/// Writes through `body` to `path` atomically, or to stdout when `None`
/// (refused when stdout was closed: the output would be lost).
pub fn write_output(
    path: Option<&Path>,
    body: impl FnOnce(&mut dyn Write) -> Result<()>,
) -> Result<()> {
    match path {
        None => {
            check_stdout_open()?;
            let stdout = io::stdout();
            grow_pipe(&stdout);
            let mut w = BufWriter::with_capacity(1 << 16, stdout.lock());
            let written = body(&mut w).and_then(|()| Ok(w.flush()?));
            written.map_err(|e| e.about("<stdout>"))
        }
        Some(path) => write_atomic(path, body),
    }
}

/// Writes to a temp file beside `path`, then renames it into place: a
/// failure never leaves a partial file at `path`. Devices and FIFOs are
/// written directly.
pub fn write_atomic(path: &Path, body: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    // A device or FIFO (`-o /dev/null`, a named pipe) is written directly.
    if std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
        let direct = || -> Result<()> {
            let f = std::fs::OpenOptions::new().write(true).open(path)?;
            let mut w = BufWriter::with_capacity(1 << 16, f);
            body(&mut w)?;
            w.flush()?;
            Ok(())
        };
        return direct().map_err(|e| e.about(&path.display().to_string()));
    }
    Staged::write(path, body)?.commit()
}

/// A file written completely to a temp file beside its target, not yet
/// in place: [`Staged::commit`] renames it there. Several staged files
/// are written first and committed together, so a failure leaves none of
/// them (all or none); dropped uncommitted, the temp file is removed.
pub struct Staged {
    tmp: tempfile::NamedTempFile,
    path: PathBuf,
    _in_flight: InFlight,
}

impl Staged {
    /// Writes `body` to a temp file beside `path`.
    pub fn write(path: &Path, body: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<Staged> {
        let staged = Staged::create(path)?;
        {
            let mut w = BufWriter::with_capacity(1 << 16, staged.file());
            body(&mut w)
                .and_then(|()| Ok(w.flush()?))
                .map_err(|e| e.about(&path.display().to_string()))?;
        }
        Ok(staged)
    }

    /// An empty temp file beside `path`, written through
    /// [`Staged::file`] (by a writer that keeps many files open, such as
    /// `pctile split`'s one a tile).
    pub fn create(path: &Path) -> Result<Staged> {
        // Created and registered under the lock the signal handler takes:
        // a signal between the two would otherwise leave the file behind.
        let (tmp, in_flight) = {
            let mut v = IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner());
            let tmp = tempfile::Builder::new()
                .prefix(".pcsss-")
                .suffix(".tmp")
                .tempfile_in(dir_of(path))
                .map_err(io_at(path))?;
            v.push(tmp.path().to_path_buf());
            let in_flight = InFlight(tmp.path().to_path_buf());
            (tmp, in_flight)
        };
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(output_mode(path)))
            .map_err(io_at(path))?;
        Ok(Staged {
            tmp,
            path: path.to_path_buf(),
            _in_flight: in_flight,
        })
    }

    /// The temp file.
    pub fn file(&self) -> &std::fs::File {
        self.tmp.as_file()
    }

    /// The temp file's path (for a spool: a staged file read back and
    /// never committed, removed when dropped or by a signal).
    pub fn temp_path(&self) -> &Path {
        self.tmp.path()
    }

    /// Renames the temp file into place; refused (and the temp file
    /// removed) when the target is an input this process opened.
    pub fn commit(self) -> Result<()> {
        if let Some(input) = opened_input(&self.path) {
            return Err(collision("output", &self.path, &input));
        }
        let path = self.path;
        self.tmp
            .persist(&path)
            .map_err(|e| e.error)
            .map_err(io_at(&path))?;
        Ok(())
    }
}

/// Asks the kernel for a 1 MiB pipe buffer when `fd` is a pipe (Linux):
/// with the default 64 KiB, a pipe moves data several times slower
/// (benches/ply_io.rs). Anything else is left alone.
pub fn grow_pipe(fd: &impl std::os::fd::AsRawFd) {
    #[cfg(target_os = "linux")]
    {
        let fd = fd.as_raw_fd();
        // SAFETY: fstat and fcntl on a descriptor the caller holds open;
        // `st` is a plain C struct that fstat fills, and failures are
        // ignored (the pipe keeps its size).
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_is_never_renamed_over_an_input_this_process_opened() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.ply");
        std::fs::write(&input, b"the input").unwrap();
        // Opened through a link: the same file.
        let link = dir.path().join("link.ply");
        std::os::unix::fs::symlink(&input, &link).unwrap();
        drop(open_input(&link).unwrap());
        let staged = Staged::write(&input, |w| Ok(w.write_all(b"an output")?)).unwrap();
        let e = staged.commit().unwrap_err();
        assert!(
            e.is_param() && e.to_string().contains("is also an input"),
            "{e}"
        );
        assert_eq!(std::fs::read(&input).unwrap(), b"the input");
        // Nothing left behind: the temp file went with the refusal.
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(left.len(), 2);
    }
}
