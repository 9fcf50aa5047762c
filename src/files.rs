//! Output files: written atomically (a temp file beside the target,
//! renamed into place when complete), several at once (all or none),
//! checked before any work, and never left behind half-written when a
//! signal (SIGINT, SIGTERM, SIGHUP) ends the process.

use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, Once};

use crate::error::{Error, Result};

/// The temp files being written now: a signal removes them before the
/// process dies.
static IN_FLIGHT: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// On SIGINT, SIGTERM or SIGHUP: remove the temp files in flight, then die
/// of the signal as if it had no handler (the exit status a shell
/// expects). Installed once, by the binaries (`cli::main_of`).
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
/// directory, in a directory that exists.
pub fn check_output(path: &Path) -> Result<()> {
    let name = path.display().to_string();
    if path.is_dir() {
        return Err(Error::invalid("is a directory, not an output file").about(&name));
    }
    let dir = dir_of(path);
    if !dir.is_dir() {
        let what = format!("no such directory: {}", dir.display());
        return Err(Error::invalid(what).about(&name));
    }
    Ok(())
}

/// Writes through `body` to `path` atomically, or to stdout when `None`.
pub fn write_output(
    path: Option<&Path>,
    body: impl FnOnce(&mut dyn Write) -> Result<()>,
) -> Result<()> {
    match path {
        None => {
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
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            tmp.as_file()
                .set_permissions(std::fs::Permissions::from_mode(0o644))
                .map_err(io_at(path))?;
        }
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

    /// Renames the temp file into place.
    pub fn commit(self) -> Result<()> {
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
