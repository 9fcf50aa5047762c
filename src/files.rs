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
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, Once, OnceLock};

use crate::error::{Error, Result};

/// A file's identity: its device and inode (the same file through any
/// link or path).
type Identity = (u64, u64);

fn identity(meta: &std::fs::Metadata) -> Identity {
    (meta.dev(), meta.ino())
}

/// The inputs this run has opened, each with the name it was opened by.
static INPUTS: Mutex<Vec<(Identity, PathBuf)>> = Mutex::new(Vec::new());

/// The outputs this run will write that exist already (standard output
/// among them when it is a file), each with its name and the parameter
/// that names it: no input is read from one of them.
static OUTPUTS: Mutex<Vec<(Identity, PathBuf, String)>> = Mutex::new(Vec::new());

/// Starts a run: forgets the inputs and outputs of the one before (a
/// process that runs several stages, the Python module's).
pub fn begin_run() {
    INPUTS.lock().unwrap_or_else(|e| e.into_inner()).clear();
    OUTPUTS.lock().unwrap_or_else(|e| e.into_inner()).clear();
}

/// Opens the input file `path` for reading and remembers it: an output of
/// this run is never renamed over it ([`Staged::commit`]), and an input
/// that is one of the run's outputs (through any path or link, or as
/// standard output) is refused here, before the work, naming the output's
/// parameter. Every file a stage reads is opened through this or
/// [`read_input`]: a file named on the command line, and the files those
/// name (a lights file's dome map, a USD stage's layers, a texture, a
/// material file).
pub fn open_input(path: &Path) -> Result<File> {
    let f = File::open(path)?;
    if let Ok(meta) = f.metadata() {
        note_input(&meta, path)?;
    }
    Ok(f)
}

/// Remembers the input `path` (its metadata `meta`) that a reader opened,
/// refusing it when it is one of the run's outputs.
pub fn note_input(meta: &std::fs::Metadata, path: &Path) -> Result<()> {
    let id = identity(meta);
    let outs = OUTPUTS.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, out, param)) = outs.iter().find(|(i, _, _)| *i == id) {
        return Err(collision(param, out, path));
    }
    drop(outs);
    let mut v = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
    v.push((id, path.to_path_buf()));
    Ok(())
}

/// Reads the whole input file `path` ([`open_input`]), at most `cap`
/// bytes: a longer file (or a device that never ends, `/dev/zero`) is
/// refused as `what` past the cap, after reading `cap + 1` bytes and no
/// more, into memory asked for as it grows (a request the machine
/// refuses is an error, not an abort).
pub fn read_input(path: &Path, cap: u64, what: &str) -> Result<Vec<u8>> {
    read_input_of(path, cap, what, &[])
}

/// [`read_input`] of a file that starts with one of `magics` (none: any
/// start): another start is refused as not `what` from its first bytes,
/// before the rest is read.
pub fn read_input_of(path: &Path, cap: u64, what: &str, magics: &[&[u8]]) -> Result<Vec<u8>> {
    use std::io::Read;
    let name = path.display().to_string();
    let mut f = open_input(path)?.take(cap.saturating_add(1));
    let mut v: Vec<u8> = Vec::new();
    if let Some(longest) = magics.iter().map(|m| m.len()).max() {
        (&mut f)
            .take(longest as u64)
            .read_to_end(&mut v)
            .map_err(|e| Error::Io(e).about(&name))?;
        if !magics.iter().any(|m| v.starts_with(m)) {
            let why = format!("not {what} (its first bytes are no such file's)");
            return Err(Error::unsupported(why).about(&name));
        }
    }
    let mut chunk = vec![0u8; 1 << 16];
    loop {
        let n = match f.read(&mut chunk) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(Error::Io(e).about(&name)),
        };
        if v.len() + n > v.capacity() {
            v.try_reserve(v.len().max(n)).map_err(|_| {
                Error::invalid(format!(
                    "{} bytes read and more to come: more than this machine holds",
                    v.len()
                ))
                .about(&name)
            })?;
        }
        v.extend_from_slice(&chunk[..n]);
    }
    if v.len() as u64 > cap {
        let why = format!("larger than {cap} bytes: not {what}");
        return Err(Error::invalid(why).about(&name));
    }
    Ok(v)
}

/// The input (as it was opened) that `path` is, if it is one.
fn opened_input(path: &Path) -> Option<PathBuf> {
    let id = identity(&std::fs::metadata(path).ok()?);
    let v = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
    v.iter().find(|(i, _)| *i == id).map(|(_, p)| p.clone())
}

/// Standard output's identity when it is a regular file (`> out.ply`,
/// `1<> in.ply`).
fn stdout_file() -> Option<Identity> {
    use std::os::fd::AsRawFd;
    let fd = io::stdout().as_raw_fd();
    // SAFETY: fstat on descriptor 1, which stays open; `st` is a plain C
    // struct fstat fills, read only when it succeeded.
    unsafe {
        let mut st: libc::stat = std::mem::zeroed();
        (libc::fstat(fd, &mut st) == 0 && (st.st_mode & libc::S_IFMT) == libc::S_IFREG)
            .then_some((st.st_dev as u64, st.st_ino as u64))
    }
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
    check_outputs_to(outputs, inputs, false)
}

/// [`check_outputs`], and when `stdout` (the run writes standard output)
/// standard output too when it is a file: it must be no input, and no
/// input opened later may be it. The outputs that exist are remembered
/// for [`open_input`]'s check.
pub fn check_outputs_to(outputs: &[Output], inputs: &[&Path], stdout: bool) -> Result<()> {
    let mut ids: Vec<(Identity, &Path)> = inputs
        .iter()
        .filter_map(|p| std::fs::metadata(p).ok().map(|m| (identity(&m), *p)))
        .collect();
    // Standard input redirected from a file (`< cloud.ply`) is an input
    // too, named or not.
    if let Some(m) = std::fs::metadata("/dev/stdin").ok().filter(|m| m.is_file()) {
        ids.push((identity(&m), Path::new("<stdin>")));
    }
    let mut declared = OUTPUTS.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(id) = stdout.then(stdout_file).flatten() {
        if let Some((_, input)) = ids.iter().find(|(i, _)| *i == id) {
            return Err(collision("output", Path::new("<stdout>"), input));
        }
        declared.push((id, PathBuf::from("<stdout>"), "output".into()));
    }
    for out in outputs {
        if let Some(m) = std::fs::metadata(out.path).ok().filter(|m| m.is_file()) {
            declared.push((identity(&m), out.path.to_path_buf(), out.param.into()));
        }
    }
    drop(declared);
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

/// Where an output named by a path goes (`docs/GUIDE.md#conventions`).
#[derive(Clone, Debug, PartialEq)]
enum Target {
    /// A regular file (or none yet): written atomically, a temp file
    /// beside it renamed onto it. A symbolic link names the file it leads
    /// to, which is written; the link stays a link.
    File(PathBuf),
    /// A device, FIFO or socket: written in place, opened by its path.
    Direct(PathBuf),
    /// An open descriptor of this process (`/dev/stdout`, `/dev/fd/3`,
    /// `/proc/self/fd/3`): written through it, as it is open (a shell's
    /// `>>` appends), never renamed over.
    Descriptor(i32),
}

impl Target {
    /// The target opened for writing in place: a device or a descriptor;
    /// `None` for a file, which is written atomically instead.
    fn open_direct(&self) -> Option<io::Result<File>> {
        match self {
            Target::File(_) => None,
            Target::Direct(p) => Some(std::fs::OpenOptions::new().write(true).open(p)),
            Target::Descriptor(fd) => Some(duplicate(*fd)),
        }
    }
}

/// The most symbolic links followed from an output's path (Linux's).
const MAX_LINKS: usize = 40;

/// Where the output `path` goes: its chain of symbolic links followed to
/// a descriptor of this process, a file that is not a regular one, or a
/// regular file (or a path with nothing there yet).
fn target(path: &Path) -> Target {
    let mut p = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        if let Some(fd) = descriptor(&p) {
            return Target::Descriptor(fd);
        }
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => match std::fs::read_link(&p) {
                Ok(t) if t.is_absolute() => p = t,
                Ok(t) => p = dir_of(&p).join(t),
                Err(_) => break,
            },
            Ok(m) if !m.is_file() && !m.is_dir() => return Target::Direct(p),
            _ => break,
        }
    }
    Target::File(p)
}

/// The descriptor a path names directly: `/dev/fd/N`, `/proc/self/fd/N`
/// or `/proc/PID/fd/N` of this process.
fn descriptor(p: &Path) -> Option<i32> {
    let s = p.to_str()?;
    let own = format!("/proc/{}/fd/", std::process::id());
    let n = ["/dev/fd/", "/proc/self/fd/", own.as_str()]
        .iter()
        .find_map(|pre| s.strip_prefix(pre))?;
    n.parse().ok().filter(|&n: &i32| n >= 0)
}

/// A writable duplicate of this process's descriptor `fd`.
fn duplicate(fd: i32) -> io::Result<File> {
    use std::os::fd::FromRawFd;
    // SAFETY: dup makes a new descriptor this process then owns alone;
    // on failure it returns -1, checked before it is used.
    let d = unsafe { libc::dup(fd) };
    if d < 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: `d` was just made and nothing else holds it.
    Ok(unsafe { File::from_raw_fd(d) })
}

/// Checks, before any work, that `path` can be an output: not a
/// directory, in a directory that exists and that a file can be created
/// in (a temp file is made and removed). A device or FIFO (`/dev/null`)
/// or a descriptor (`/dev/stdout`) is written as it is; a symbolic link,
/// the file it leads to.
pub fn check_output(path: &Path) -> Result<()> {
    let name = path.display().to_string();
    let meta = std::fs::metadata(path);
    if meta.as_ref().is_ok_and(|m| m.is_dir()) {
        return Err(Error::invalid("is a directory, not an output file").about(&name));
    }
    let path = match target(path) {
        Target::File(t) => t,
        Target::Direct(_) | Target::Descriptor(_) => return Ok(()),
    };
    let path = path.as_path();
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

/// Whether descriptor 1 was closed when the process started, as seen
/// before Rust's runtime ran: the runtime then puts `/dev/null` opened
/// read-write in its place, the very file a parent's `/dev/null` opened
/// read-write on purpose is (Python's `subprocess.DEVNULL`), so only a
/// look before it can tell them apart. Set by [`SEE_STDOUT`].
static STDOUT_CLOSED_AT_START: AtomicBool = AtomicBool::new(false);

/// Runs as the program is loaded (an `.init_array` entry, before `main`
/// and before Rust's runtime opens `/dev/null` over closed descriptors):
/// records whether descriptor 1 was open.
#[used]
#[link_section = ".init_array"]
static SEE_STDOUT: extern "C" fn() = {
    extern "C" fn see_stdout() {
        // SAFETY: F_GETFD on descriptor 1 only reads its flags (-1 and
        // EBADF when it is not open).
        if unsafe { libc::fcntl(1, libc::F_GETFD) } < 0 {
            STDOUT_CLOSED_AT_START.store(true, Ordering::Relaxed);
        }
    }
    see_stdout
};

/// Whether standard output was closed when the process started: writing
/// there would lose the output and succeed.
fn stdout_was_closed() -> bool {
    // (Named, so that the object that holds the entry is linked in.)
    std::hint::black_box(SEE_STDOUT);
    STDOUT_CLOSED_AT_START.load(Ordering::Relaxed)
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
    // A device or FIFO (`-o /dev/null`, a named pipe) or a descriptor
    // (`-o /dev/stdout`) is written directly.
    let Some(open) = target(path).open_direct() else {
        return Staged::write(path, body)?.commit();
    };
    let direct = || -> Result<()> {
        let f = open?;
        grow_pipe(&f);
        let mut w = BufWriter::with_capacity(1 << 16, f);
        body(&mut w)?;
        w.flush()?;
        Ok(())
    };
    direct().map_err(|e| e.about(&path.display().to_string()))
}

/// A file written completely to a temp file beside its target, not yet
/// in place: [`Staged::commit`] renames it there. Several staged files
/// are written first and committed together, so a failure leaves none of
/// them (all or none); dropped uncommitted, the temp file is removed.
pub struct Staged {
    tmp: tempfile::NamedTempFile,
    /// The path the output was named by, for messages.
    path: PathBuf,
    /// Where it goes ([`target`]).
    target: Target,
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
        // A file's temp file is beside the file (the rename stays on its
        // file system); one for a device or a descriptor, which is copied
        // there when committed, in the temp directory.
        let target = target(path);
        let (place, mode) = match &target {
            Target::File(t) => (dir_of(t).to_path_buf(), output_mode(t)),
            _ => (std::env::temp_dir(), 0o600),
        };
        // Created and registered under the lock the signal handler takes:
        // a signal between the two would otherwise leave the file behind.
        let (tmp, in_flight) = {
            let mut v = IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner());
            let tmp = tempfile::Builder::new()
                .prefix(".pcsss-")
                .suffix(".tmp")
                .tempfile_in(&place)
                .map_err(io_at(path))?;
            v.push(tmp.path().to_path_buf());
            let in_flight = InFlight(tmp.path().to_path_buf());
            (tmp, in_flight)
        };
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(mode))
            .map_err(io_at(path))?;
        Ok(Staged {
            tmp,
            path: path.to_path_buf(),
            target,
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
        let path = self.path;
        if let Target::File(t) = &self.target {
            if let Some(input) = opened_input(t) {
                return Err(collision("output", &path, &input));
            }
            self.tmp
                .persist(t)
                .map_err(|e| e.error)
                .map_err(io_at(&path))?;
            return Ok(());
        }
        // A device or a descriptor: the temp file copied into it.
        let copy = || -> Result<()> {
            use std::io::Seek;
            let mut tmp = self.tmp.reopen()?;
            tmp.rewind()?;
            let mut out = self.target.open_direct().expect("not a file")?;
            io::copy(&mut tmp, &mut out)?;
            out.flush()?;
            Ok(())
        };
        copy().map_err(|e| e.about(&path.display().to_string()))
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
