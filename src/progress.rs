//! Progress for long loops: a bar on stderr (indicatif) when the binary
//! asks for one, nothing otherwise. The library takes a `&Progress` and
//! counts; whether anything is drawn is the binary's choice (`-q`, or
//! stderr not a terminal, draws nothing).

use indicatif::{ProgressBar, ProgressStyle};

/// A progress counter, drawn or not.
#[derive(Debug, Default)]
pub struct Progress {
    bar: Option<ProgressBar>,
}

impl Progress {
    /// Counts nothing, draws nothing.
    pub fn hidden() -> Progress {
        Progress { bar: None }
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
        Progress { bar: Some(bar) }
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

/// Wall-clock time of a stage's phases on stderr, one line a phase, when
/// `PCSSS_TIMES` is set (for finding where the time goes; nothing
/// otherwise).
#[derive(Debug)]
pub struct Phases {
    what: &'static str,
    last: Option<std::time::Instant>,
}

impl Phases {
    /// Starts timing `what`'s phases (if `PCSSS_TIMES` is set).
    pub fn new(what: &'static str) -> Phases {
        let on = std::env::var_os("PCSSS_TIMES").is_some();
        Phases {
            what,
            last: on.then(std::time::Instant::now),
        }
    }

    /// Ends phase `name`: prints its time, starts the next.
    pub fn mark(&mut self, name: &str) {
        if let Some(t) = self.last {
            eprintln!(
                "{} {name}: {:.2} ms",
                self.what,
                t.elapsed().as_secs_f64() * 1e3
            );
            self.last = Some(std::time::Instant::now());
        }
    }
}
