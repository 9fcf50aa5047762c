//! Progress for long loops: a bar on stderr (indicatif) when the binary
//! asks for one, nothing otherwise. The library takes a `&Progress` and
//! counts; whether anything is drawn is the binary's choice (`-q`, or
//! stderr not a terminal, draws nothing). It also carries whether the
//! stages print the time of their phases ([`Phases`]).

use std::io::Write;

use indicatif::{ProgressBar, ProgressStyle};

/// A progress counter, drawn or not.
#[derive(Debug, Default)]
pub struct Progress {
    bar: Option<ProgressBar>,
    times: bool,
}

impl Progress {
    /// Counts nothing, draws nothing.
    pub fn hidden() -> Progress {
        Progress::default()
    }

    /// The same, and the stages print the time of their phases on
    /// stderr when `on` ([`Phases`]).
    pub fn with_phase_times(self, on: bool) -> Progress {
        Progress { times: on, ..self }
    }

    /// A timer of `what`'s phases: prints when this progress asks for
    /// phase times, else nothing.
    pub fn phases(&self, what: &'static str) -> Phases {
        Phases::new(what, self.times)
    }

    /// A bar for `stage` on stderr.
    pub fn bar(stage: &str) -> Progress {
        let bar = ProgressBar::new(0);
        bar.set_style(
            ProgressStyle::with_template(
                "{prefix}: {msg} [{bar:30}] {human_pos}/{human_len} ({per_sec}, {eta})",
            )
            .expect("a valid template")
            .progress_chars("=> "),
        );
        bar.set_prefix(stage.to_string());
        Progress {
            bar: Some(bar),
            times: false,
        }
    }

    /// Starts a phase of `len` steps.
    pub fn start(&self, what: &str, len: u64) {
        if let Some(b) = &self.bar {
            b.set_message(what.to_string());
            b.set_length(len);
            b.set_position(0);
        }
    }

    /// `n` more steps done.
    #[inline]
    pub fn inc(&self, n: u64) {
        if let Some(b) = &self.bar {
            b.inc(n);
        }
    }

    /// Removes the bar.
    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// The process's resident memory now and at its peak, from
/// /proc/self/status (`, rss N MB, peak M MB`; empty where that file is
/// not there): memory first touched costs time (the kernel clears every
/// new page), so a phase's time and the memory it adds go together.
fn resident() -> String {
    let Ok(status) = std::fs::read_to_string("/proc/self/status") else {
        return String::new();
    };
    let kb = |key: &str| {
        status
            .lines()
            .find_map(|l| l.strip_prefix(key))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
    };
    match (kb("VmRSS:"), kb("VmHWM:")) {
        (Some(now), Some(peak)) => format!(", rss {} MB, peak {} MB", now / 1024, peak / 1024),
        _ => String::new(),
    }
}

/// Wall-clock time of a stage's phases on stderr, one line a phase, when
/// asked for (for finding where the time goes; the binaries ask when
/// `PCSSS_TIMES` is set); nothing otherwise.
#[derive(Debug)]
pub struct Phases {
    what: &'static str,
    last: Option<std::time::Instant>,
    /// The process's user and system time (all threads) at `last`.
    cpu: [f64; 2],
}

/// The process's user and system time so far, in seconds (all threads).
fn cpu_seconds() -> [f64; 2] {
    // SAFETY: `rusage` is a plain C struct of integers, valid when zeroed.
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: getrusage writes the struct it is given and nothing else.
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut u) } != 0 {
        return [0.0; 2];
    }
    let t = |v: libc::timeval| v.tv_sec as f64 + v.tv_usec as f64 * 1e-6;
    [t(u.ru_utime), t(u.ru_stime)]
}

impl Phases {
    /// Starts timing `what`'s phases when `on`.
    pub fn new(what: &'static str, on: bool) -> Phases {
        Phases {
            what,
            last: on.then(std::time::Instant::now),
            cpu: if on { cpu_seconds() } else { [0.0; 2] },
        }
    }

    /// Ends phase `name`: prints its time (wall clock, and CPU over all
    /// threads: their ratio is how parallel the phase ran; the system's
    /// part of it is mostly first touches of new memory), starts the
    /// next.
    pub fn mark(&mut self, name: &str) {
        if let Some(t) = self.last {
            let cpu = cpu_seconds();
            // (A stderr that cannot be written loses the line, and no
            // more: `eprintln!` would panic.)
            let _ = writeln!(
                std::io::stderr().lock(),
                "{} {name}: {:.2} ms, cpu {:.0} ms (system {:.0}){}",
                self.what,
                t.elapsed().as_secs_f64() * 1e3,
                (cpu[0] + cpu[1] - self.cpu[0] - self.cpu[1]) * 1e3,
                (cpu[1] - self.cpu[1]) * 1e3,
                resident()
            );
            self.last = Some(std::time::Instant::now());
            self.cpu = cpu;
        }
    }
}
