//! PLY and OpenEXR read and write speed: 2,000,000 points x 10 float
//! properties (80 MB), from a file in the page cache and from a pipe
//! (and from the same values as ASCII text), in
//! process and whole-process, beside Python's plyfile and OpenEXR and the
//! Rust crate ply-rs-bw. MB/s are of the 80 MB of values.
//!
//! `make bench` (or `cargo bench --bench ply_io`); BENCH_POINTS sets the
//! point count. Results: target/bench/ply_io.txt.
//!
//! Also the growth of the work a header sets (target/bench/header_growth.txt):
//! `pcconvert` to OpenEXR and `pcdiff` over headers with n and 10 n
//! properties, elements or detail attributes. Linear work takes about 10
//! times as long at 10 n, quadratic work 100 times.

mod common;

// The allocator the stages' binaries use, so in-process timings match.
pcsss::global_allocator!();

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};

use common::*;
use pcsss::formats::exr::{Compression, ExrOptions};
use pcsss::formats::{self, Format, Select};
use pcsss::{Cloud, Role};

fn make_cloud(n: usize) -> Cloud {
    let mut c = Cloud::with_points(n);
    let v = |k: usize| -> Vec<[f32; 3]> {
        (0..n)
            .map(|i| {
                let t = (i * 7 + k) as f32 * 1e-3;
                [t.sin(), t.cos(), t * 0.5]
            })
            .collect()
    };
    let pts = c.points_mut();
    pts.set_vec3("P", Role::Point, &v(0)).unwrap();
    pts.set_vec3("N", Role::Normal, &v(1)).unwrap();
    pts.set_vec3("illum", Role::Color, &v(2)).unwrap();
    pts.set_scalar("ptarea", (0..n).map(|i| 1e-6 * (i % 97) as f32).collect())
        .unwrap();
    c
}

fn read_pipe(bytes: &[u8], select: &Select) -> Cloud {
    let (r, mut w) = std::io::pipe().unwrap();
    pcsss::files::grow_pipe(&r);
    std::thread::scope(|s| {
        s.spawn(move || {
            for chunk in bytes.chunks(1 << 20) {
                w.write_all(chunk).unwrap();
            }
        });
        formats::read_cloud(BufReader::with_capacity(1 << 16, r), select).unwrap()
    })
}

fn write_pipe(c: &Cloud) {
    let (mut r, w) = std::io::pipe().unwrap();
    pcsss::files::grow_pipe(&w);
    std::thread::scope(|s| {
        s.spawn(move || {
            let mut buf = vec![0u8; 1 << 20];
            while r.read(&mut buf).unwrap() > 0 {}
        });
        let mut w = BufWriter::with_capacity(1 << 16, w);
        formats::write_cloud(&mut w, c, Format::DEFAULT).unwrap();
        w.flush().unwrap();
    });
}

fn main() {
    let n: usize = std::env::var("BENCH_POINTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2_000_000);
    let dir = bench_dir();
    let path = dir.join(format!("ply_io_{n}.ply"));
    let cloud = make_cloud(n);
    let mut f = BufWriter::new(File::create(&path).unwrap());
    formats::write_cloud(&mut f, &cloud, Format::DEFAULT).unwrap();
    f.flush().unwrap();
    drop(f);
    let bytes = std::fs::read(&path).unwrap();
    let mb = bytes.len() as f64 / 1e6;
    let p = path.display().to_string();
    let mut t = Table::new(
        &format!(
            "PLY I/O: {n} points x 10 float properties, {mb:.1} MB binary little-endian; {}; best of 3",
            machine()
        ),
        "| case | seconds | MB/s |\n|---|---|---|",
    );
    let mut row = |name: &str, s: Option<f64>| match s {
        Some(s) => t.row(format!("| {name} | {s:.3} | {:.0} |", mb / s)),
        None => t.row(format!("| {name} | failed | - |")),
    };
    let read_file = |sel: &Select| formats::read_cloud_file(&path, sel).unwrap();
    let stream_file = |sel: &Select| {
        let f = File::open(&path).unwrap();
        formats::read_cloud(BufReader::with_capacity(1 << 16, f), sel).unwrap()
    };
    row(
        "pcsss read, file (whole), all 10 properties decoded",
        Some(best(3, || read_file(&Select::All))),
    );
    row(
        "pcsss read, file (whole), only P and N decoded (rest lazy)",
        Some(best(3, || read_file(&Select::only(&["P", "N"])))),
    );
    row(
        "pcsss read, file (streamed), all decoded",
        Some(best(3, || stream_file(&Select::All))),
    );
    row(
        "pcsss read, pipe, all decoded",
        Some(best(3, || read_pipe(&bytes, &Select::All))),
    );
    row(
        "pcsss read, pipe, only P and N decoded",
        Some(best(3, || read_pipe(&bytes, &Select::only(&["P", "N"])))),
    );
    // The same values as ASCII text: a file's rows are parsed in
    // parallel, a stream's row by row.
    let ascii = dir.join(format!("ply_io_{n}_ascii.ply"));
    let mut f = BufWriter::new(File::create(&ascii).unwrap());
    formats::write_cloud(&mut f, &cloud, Format::Ply(formats::Encoding::Ascii)).unwrap();
    f.flush().unwrap();
    drop(f);
    row(
        "pcsss read, ASCII file (whole: rows in parallel), all decoded",
        Some(best(3, || {
            formats::read_cloud_file(&ascii, &Select::All).unwrap()
        })),
    );
    row(
        "pcsss read, ASCII file (streamed: row by row), all decoded",
        Some(best(3, || {
            let f = File::open(&ascii).unwrap();
            formats::read_cloud(BufReader::with_capacity(1 << 16, f), &Select::All).unwrap()
        })),
    );
    std::fs::remove_file(&ascii).unwrap();
    let out = dir.join("ply_io_out.ply");
    row(
        "pcsss write, file",
        Some(best(3, || {
            let mut w = BufWriter::new(File::create(&out).unwrap());
            formats::write_cloud(&mut w, &cloud, Format::DEFAULT).unwrap();
            w.flush().unwrap();
        })),
    );
    row("pcsss write, pipe", Some(best(3, || write_pipe(&cloud))));
    let lazy = read_file(&Select::only(&[]));
    row(
        "pcsss write, file, pass-through of undecoded input",
        Some(best(3, || {
            let mut w = BufWriter::new(File::create(&out).unwrap());
            formats::write_cloud(&mut w, &lazy, Format::DEFAULT).unwrap();
            w.flush().unwrap();
        })),
    );
    row(
        "ply-rs-bw 4 read, file, generic DefaultElement (1 run)",
        Some(best(1, || {
            let mut f = BufReader::new(File::open(&path).unwrap());
            let parser = ply_rs_bw::parser::Parser::<ply_rs_bw::ply::DefaultElement>::new();
            parser.read_ply(&mut f).unwrap()
        })),
    );
    let pcinfo = env!("CARGO_BIN_EXE_pcinfo");
    let pcconvert = env!("CARGO_BIN_EXE_pcconvert");
    row(
        "whole process: pcinfo FILE (read + min/max/mean of every property)",
        best_cmd(3, &format!("{pcinfo} {p} > /dev/null")),
    );
    row(
        "whole process: cat FILE | pcinfo",
        best_cmd(3, &format!("cat {p} | {pcinfo} > /dev/null")),
    );
    row(
        "whole process: cat FILE | pcconvert | cat (read, write to a pipe)",
        best_cmd(3, &format!("cat {p} | {pcconvert} | cat > /dev/null")),
    );
    // OpenEXR, uncompressed and zip: the same 80 MB of values.
    for comp in [Compression::None, Compression::Zip] {
        let opt = ExrOptions {
            compression: comp,
            half: vec![],
        };
        let exr = dir.join(format!("ply_io_{n}_{comp:?}.exr"));
        let write = || {
            let mut w = BufWriter::new(File::create(&exr).unwrap());
            formats::write_cloud_with(&mut w, &cloud, Format::Exr, &opt).unwrap();
            w.flush().unwrap();
        };
        let s = best(3, write);
        let size = std::fs::metadata(&exr).unwrap().len() as f64 / 1e6;
        row(
            &format!("pcsss EXR write, file, {comp:?} ({size:.1} MB file)"),
            Some(s),
        );
        row(
            &format!("pcsss EXR read, file, {comp:?}"),
            Some(best(3, || {
                formats::read_cloud_file(&exr, &Select::All).unwrap()
            })),
        );
        let e = exr.display().to_string();
        row(
            &format!("whole process: python OpenEXR read, {comp:?} (1 run)"),
            best_cmd(
                1,
                &format!(
                    "{} -c 'import OpenEXR,sys; f=OpenEXR.File(sys.argv[1]); [c.pixels.sum() for c in f.channels().values()]' {e}",
                    python()
                ),
            ),
        );
        let _ = std::fs::remove_file(&exr);
    }
    let py = python();
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/py/plyfile_read.py");
    row(
        "whole process: python plyfile FILE (memory-mapped; + min/max/mean)",
        best_cmd(3, &format!("{py} {script} {p} > /dev/null")),
    );
    row(
        "whole process: cat FILE | python plyfile (1 run)",
        best_cmd(1, &format!("cat {p} | {py} {script} - > /dev/null")),
    );
    t.save("ply_io.txt");
    let _ = std::fs::remove_file(&out);
    header_growth(&dir);
}

/// A one-row ASCII PLY with `n` of what `kind` names in its header.
fn big_header(kind: &str, n: usize) -> String {
    match kind {
        "properties" => {
            let props: String = (0..n).map(|i| format!("property float p{i}\n")).collect();
            let zeros = vec!["0"; n].join(" ");
            format!("ply\nformat ascii 1.0\nelement vertex 1\n{props}end_header\n{zeros}\n")
        }
        "elements" => {
            let els: String = (0..n).map(|i| format!("element e{i} 0\n")).collect();
            format!(
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n{els}end_header\n0\n"
            )
        }
        _ => {
            let det: String = (0..n)
                .map(|i| format!("comment pcsss detail d{i} f64 1\n"))
                .collect();
            format!(
                "ply\nformat ascii 1.0\n{det}element vertex 1\nproperty float x\nend_header\n0\n"
            )
        }
    }
}

/// `pcconvert` to OpenEXR then `pcdiff` against it, whole processes, on
/// headers of n and 10 n entries: the ratio of the two times tells
/// linear work (about 10) from quadratic (about 100).
fn header_growth(dir: &std::path::Path) {
    let pcconvert = env!("CARGO_BIN_EXE_pcconvert");
    let pcdiff = env!("CARGO_BIN_EXE_pcdiff");
    let mut t = Table::new(
        &format!(
            "Header growth: pcconvert FILE -o FILE.exr, then pcdiff FILE FILE.exr; {}; best of 3",
            machine()
        ),
        "| header | n | seconds at n | seconds at 10 n | ratio |\n|---|---|---|---|---|",
    );
    for (kind, n) in [
        ("properties", 4_000),
        ("elements", 20_000),
        ("details", 10_000),
    ] {
        let time = |n: usize| {
            let f = dir.join(format!("header_{kind}_{n}.ply"));
            std::fs::write(&f, big_header(kind, n)).unwrap();
            let f = f.display().to_string();
            let cmd = format!(
                "{pcconvert} -q {f} -o {f}.exr && {{ {pcdiff} -q {f} {f}.exr; test $? -le 1; }}"
            );
            let s = best_cmd(3, &cmd);
            let _ = std::fs::remove_file(&f);
            let _ = std::fs::remove_file(format!("{f}.exr"));
            s
        };
        match (time(n), time(10 * n)) {
            (Some(a), Some(b)) => {
                t.row(format!("| {kind} | {n} | {a:.3} | {b:.3} | {:.1} |", b / a))
            }
            _ => t.row(format!("| {kind} | {n} | failed | failed | - |")),
        }
    }
    t.save("header_growth.txt");
}
