//! Shared by the benchmark programs: timing, the machine's description,
//! the Python interpreter, the result table.

#![allow(dead_code)]

use std::path::PathBuf;
use std::time::Instant;

/// Best wall time in seconds of `reps` runs of `f`.
pub fn best<T>(reps: usize, mut f: impl FnMut() -> T) -> f64 {
    (0..reps)
        .map(|_| {
            let t = Instant::now();
            std::hint::black_box(f());
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Best wall time of a shell command (whole process), or None if it failed.
pub fn best_cmd(reps: usize, cmd: &str) -> Option<f64> {
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        let out = std::process::Command::new("bash")
            .args(["-o", "pipefail", "-c", cmd])
            .output()
            .ok()?;
        let dt = t.elapsed().as_secs_f64();
        if !out.status.success() {
            eprintln!("failed: {cmd}: {}", String::from_utf8_lossy(&out.stderr));
            return None;
        }
        best = best.min(dt);
    }
    Some(best)
}

/// CPU model and core count.
pub fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("{cpu}, {cores} cores")
}

/// The Python with the benchmark's packages: $PCSSS_PYTHON, else the
/// project's venv (made by `make bench`), else python3.
pub fn python() -> String {
    if let Ok(p) = std::env::var("PCSSS_PYTHON") {
        return p;
    }
    let venv = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/pyenv/bin/python");
    if venv.exists() {
        return venv.display().to_string();
    }
    "python3".into()
}

/// Where benchmark inputs and results go.
pub fn bench_dir() -> PathBuf {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/bench");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A results table, printed and saved.
pub struct Table {
    pub title: String,
    pub rows: Vec<String>,
}

impl Table {
    pub fn new(title: &str, header: &str) -> Self {
        println!("{title}\n{header}");
        Table {
            title: title.into(),
            rows: vec![header.into()],
        }
    }

    pub fn row(&mut self, r: String) {
        println!("{r}");
        self.rows.push(r);
    }

    pub fn save(&self, name: &str) {
        let p = bench_dir().join(name);
        let text = format!("{}\n{}\n", self.title, self.rows.join("\n"));
        std::fs::write(&p, text).unwrap();
        println!("saved {}", p.display());
    }
}
