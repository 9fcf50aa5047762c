//! `pctile split`: a PLY cloud into tiles with halos, in three streaming
//! passes over the file (the box and a sample; the counts; the tiles), so
//! memory holds a chunk of rows, the sample and one write buffer a tile,
//! whatever the input's size.

use std::cell::RefCell;
use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::Path;
use std::rc::Rc;

use glam::DVec3;
use rayon::prelude::*;
use xxhash_rust::xxh3::Xxh3;

use super::{ElementEntry, ForStage, Manifest, Plan, Tile, D_HALO, D_SPLIT, D_TILE, FORMAT};
use super::{HALO, INDEX, MANIFEST, MAX_TILES};
use crate::cloud::{Attribute, Cloud, DetailValue, Element, POINTS};
use crate::column::Column;
use crate::error::{Error, Result};
use crate::files::Staged;
use crate::formats::ply::header::Header;
use crate::formats::ply::read::PlyChunks;
use crate::formats::ply::write::{header_text_with, write_body};
use crate::formats::Encoding;
use crate::progress::Progress;

/// Rows read at a time.
pub const CHUNK: usize = 1 << 16;
/// The most points the box's quantiles are taken from.
pub const SAMPLE: u64 = 1 << 20;

/// How many tiles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TileCount {
    /// This many.
    Tiles(usize),
    /// As many as hold about this many owned points each.
    Size(u64),
    /// The fewest whose largest tile, halo included, a stage can bake in
    /// `bytes` of memory at `per_point` bytes a point (plus
    /// [`BASE_MEMORY`]), as estimated from the sample; by default, the
    /// measured figure of the stage the halo is for ([`point_bytes`]),
    /// else [`DEFAULT_POINT_BYTES`].
    Memory { bytes: u64, per_point: Option<u64> },
}

/// What a stage's process holds besides its points (the binary, its
/// libraries, buffers), with a margin (benches/results/tiles.txt).
pub const BASE_MEMORY: u64 = 32 << 20;

/// Bytes a point at the peak of `stage` on a tile (its resident memory
/// over its points, measured by `cargo bench --bench tiles`); `None` for
/// a stage not measured.
pub fn point_bytes(stage: super::reach::Stage) -> Option<u64> {
    match stage {
        super::reach::Stage::Ssmulti => Some(SSMULTI_POINT_BYTES),
        _ => None,
    }
}

/// A point's bytes in a stage not measured: more than any measured.
pub const DEFAULT_POINT_BYTES: u64 = 400;

/// ssmulti's resident memory a point, with a margin (measured:
/// benches/results/tiles.txt).
pub const SSMULTI_POINT_BYTES: u64 = 230;

/// Owned and halo points (within `h`) of each tile of `plan` among `pts`.
pub fn tile_counts(plan: &Plan, pts: &[DVec3], h: f64) -> Vec<[u64; 2]> {
    let tiles = plan.boxes.len();
    pts.par_chunks(4096)
        .fold(
            || vec![[0u64; 2]; tiles],
            |mut c, ps| {
                for &p in ps {
                    let o = plan.owner(p);
                    c[o as usize][0] += 1;
                    plan.halo_of(p, o, h, |t| c[t as usize][1] += 1);
                }
                c
            },
        )
        .reduce(
            || vec![[0u64; 2]; tiles],
            |mut a, b| {
                for (x, y) in a.iter_mut().zip(&b) {
                    x[0] += y[0];
                    x[1] += y[1];
                }
                a
            },
        )
}

/// The fewest tiles (at most MAX_TILES) whose largest, halo included,
/// fits `bytes` at `per_point` a point, by the sample (every `stride`-th
/// point); an error when even MAX_TILES do not.
fn tiles_for_memory(
    sample: &[DVec3],
    stride: u64,
    (lo, hi): (DVec3, DVec3),
    h: f64,
    bytes: u64,
    per_point: u64,
) -> Result<usize> {
    if bytes <= BASE_MEMORY {
        return Err(Error::param(
            "tile_memory",
            format!("{bytes} bytes: a stage needs more than {BASE_MEMORY} besides its points"),
        ));
    }
    // The most sample points a tile may hold, halo included (each stands
    // for `stride` points).
    let limit = (bytes - BASE_MEMORY) / (stride * per_point).max(1);
    // Whether `t` tiles fit: the sample is counted a block at a time and
    // the count stops at the first block after which a tile is over the
    // limit, so that a budget the halo outgrows is refused without
    // counting every point into thousands of halos.
    let fits = |t: usize| -> bool {
        let mut s = sample.to_vec();
        let plan = Plan::new(&mut s, lo, hi, t);
        let mut total = vec![[0u64; 2]; t];
        for block in sample.chunks(1 << 16) {
            for (x, y) in total.iter_mut().zip(&tile_counts(&plan, block, h)) {
                x[0] += y[0];
                x[1] += y[1];
            }
            if total.iter().any(|c| c[0] + c[1] > limit) {
                return false;
            }
        }
        true
    };
    let mut t = 1;
    while !fits(t) {
        if t >= MAX_TILES {
            return Err(Error::param(
                "tile_memory",
                format!(
                    "{bytes}: even {MAX_TILES} tiles hold more than {} points each, halo included (the halo alone outgrows the budget: give more memory, or a narrower reach)",
                    limit * stride
                ),
            ));
        }
        t = (t * 2).min(MAX_TILES);
    }
    // The smallest that fits, between the last that did not and t.
    let (mut a, mut b) = (t / 2, t);
    while b - a > 1 {
        let m = (a + b) / 2;
        if fits(m) {
            b = m;
        } else {
            a = m;
        }
    }
    Ok(b.max(1))
}

/// Files a split holds open besides its tiles: the input, the rest file,
/// the manifest, a spool, the standard streams, a margin.
const OTHER_FILES: u64 = 16;

/// Makes sure `tiles` tile files can be open at once: raises the process's
/// soft limit on open files towards its hard limit if need be, and
/// refuses, naming the limit, when even that is too low.
fn ensure_open_files(tiles: usize) -> Result<()> {
    let need = tiles as u64 + OTHER_FILES;
    let mut lim = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit fills the struct it is given.
    if unsafe { libc::getrlimit(libc::RLIMIT_NOFILE, &mut lim) } != 0 {
        return Ok(());
    }
    if lim.rlim_cur >= need {
        return Ok(());
    }
    if lim.rlim_max >= need {
        let raised = libc::rlimit {
            rlim_cur: need,
            rlim_max: lim.rlim_max,
        };
        // SAFETY: setrlimit reads the struct it is given; raising the
        // soft limit up to the hard one is always allowed.
        if unsafe { libc::setrlimit(libc::RLIMIT_NOFILE, &raised) } == 0 {
            return Ok(());
        }
    }
    let most = lim.rlim_max.max(lim.rlim_cur).saturating_sub(OTHER_FILES);
    Err(Error::param(
        "tiles",
        format!(
            "{tiles} tiles need {need} open files, and this process may open {} (ulimit -n): make at most {most} tiles",
            lim.rlim_max.max(lim.rlim_cur)
        ),
    ))
}

/// Refuses, before a byte is written, a split whose tiles the disk under
/// `dir` cannot hold: each tile's rows at the input's bytes a point (plus
/// the two properties a tile adds), and the other elements.
fn check_disk(dir: &Path, m: &Manifest, input_bytes: u64) -> Result<()> {
    match free_bytes(dir) {
        Some(free) => disk_holds(m, input_bytes, free, dir),
        None => Ok(()),
    }
}

/// [`check_disk`] with `free` bytes free under `dir`.
fn disk_holds(m: &Manifest, input_bytes: u64, free: u64, dir: &Path) -> Result<()> {
    let rows: u64 = m.tiles.iter().map(|t| t.owned + t.halo).sum();
    let per_point = input_bytes / m.points.max(1) + 5;
    let need = rows.saturating_mul(per_point).saturating_add(input_bytes);
    if need <= free {
        return Ok(());
    }
    Err(Error::param(
        "halo",
        format!(
            "the {} tiles would take about {} ({rows} rows for {} points: the halos), and {} has {} free: a narrower halo, fewer tiles, or another disk",
            m.tiles.len(),
            size(need),
            m.points,
            dir.display(),
            size(free)
        ),
    ))
}

/// Bytes for people: `12.3 GB`, `45.6 MB`.
fn size(b: u64) -> String {
    match b {
        b if b >= 1_000_000_000 => format!("{:.1} GB", b as f64 / 1e9),
        b => format!("{:.1} MB", b as f64 / 1e6),
    }
}

/// The bytes free for this user on the file system holding `dir`.
fn free_bytes(dir: &Path) -> Option<u64> {
    use std::os::unix::ffi::OsStrExt;
    let path = std::ffi::CString::new(dir.as_os_str().as_bytes()).ok()?;
    // SAFETY: an all-zero statvfs is a valid value for statvfs to fill.
    let mut st: libc::statvfs = unsafe { std::mem::zeroed() };
    // SAFETY: statvfs reads the NUL-terminated path and fills `st`.
    if unsafe { libc::statvfs(path.as_ptr(), &mut st) } != 0 {
        return None;
    }
    Some((st.f_bavail as u64).saturating_mul(st.f_frsize as u64))
}

/// What `split` is asked for.
#[derive(Clone, Debug, PartialEq)]
pub struct SplitOptions {
    pub tiles: TileCount,
    /// The halo's width: every point within it of a tile's box is in the
    /// tile's file as a halo point.
    pub halo: f64,
    /// The stage the halo was computed for, recorded in the manifest.
    pub for_stage: Option<ForStage>,
}

/// A reader that hashes every byte it passes on (XXH3-128): the split's
/// first pass reads the whole input through it, so the split's id covers
/// the input's bytes.
struct Hashing<R> {
    inner: R,
    hash: Rc<RefCell<Xxh3>>,
}

impl<R: Read> Read for Hashing<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.hash.borrow_mut().update(&buf[..n]);
        Ok(n)
    }
}

fn open(path: &Path) -> Result<PlyChunks<BufReader<File>>> {
    open_through(path, |f| f)
}

/// The PLY file at `path`, its bytes read through `wrap`.
fn open_through<R: Read>(
    path: &Path,
    wrap: impl FnOnce(File) -> R,
) -> Result<PlyChunks<BufReader<R>>> {
    let f = crate::files::open_input(path)?;
    if f.metadata()?.is_dir() {
        return Err(Error::invalid("is a directory"));
    }
    let mut r = BufReader::with_capacity(1 << 20, wrap(f));
    let head = std::io::BufRead::fill_buf(&mut r)?;
    match crate::formats::sniff(head) {
        Some(crate::formats::Kind::Ply) => {}
        Some(_) => {
            let why = "pctile reads PLY only (convert with pcconvert first)";
            return Err(Error::unsupported(why));
        }
        None if head.is_empty() => return Err(Error::truncated("empty file")),
        None => return Err(Error::invalid("not a PLY file (unrecognised first bytes)")),
    }
    PlyChunks::new(r)
}

/// Positions of a chunk of points, checked finite (`base`: the chunk's
/// first row in the file).
fn positions(el: &Element, base: u64) -> Result<Vec<DVec3>> {
    let p = el.vec3_f64("P")?;
    if let Some(i) = p.iter().position(|q| !q.iter().all(|x| x.is_finite())) {
        let what = format!("point {}: P is {:?}, not finite", base + i as u64, p[i]);
        return Err(Error::invalid(what));
    }
    Ok(p.into_iter().map(DVec3::from_array).collect())
}

/// An element with no rows and the attributes of `el`.
fn schema(el: &Element) -> Element {
    el.gather(&[])
}

/// What the first pass finds: the vertex element's index and count, the
/// box, a sample of every `stride`-th position, the points seen, and the
/// hash of every byte.
struct Survey {
    header: Header,
    v: usize,
    count: u64,
    lo: DVec3,
    hi: DVec3,
    sample: Vec<DVec3>,
    stride: u64,
    seen: u64,
    input_hash: String,
}

/// Splits the PLY file at `input` (called `input_name` in messages and the
/// manifest) into tiles in `dir` (made if missing): `tile_NNNN.ply` and
/// `manifest.json`, and `rest.ply` for elements other than `vertex`. All
/// files are written to temp files and renamed into place together at
/// the end.
pub fn split(
    input: &Path,
    input_name: &str,
    dir: &Path,
    opt: &SplitOptions,
    progress: &Progress,
) -> Result<Manifest> {
    if !(opt.halo.is_finite() && opt.halo >= 0.0) {
        let what = format!("{:?}: must be a finite width >= 0", opt.halo);
        return Err(Error::param("halo", what));
    }
    let at = |e: Error| e.about(input_name);
    // Pass 1: the box and the sample, and the hash of every byte.
    let mut survey = survey(input, progress).map_err(at)?;
    let mut tiles = tile_count(opt, survey.count)?;
    if let TileCount::Memory { bytes, per_point } = opt.tiles {
        let per_point = per_point
            .or_else(|| {
                opt.for_stage
                    .as_ref()
                    .and_then(|f| point_bytes(super::reach::Stage::from_name(&f.stage)?))
            })
            .unwrap_or(DEFAULT_POINT_BYTES);
        let (lo, hi) = (survey.lo, survey.hi);
        tiles = tiles_for_memory(
            &survey.sample,
            survey.stride,
            (lo, hi),
            opt.halo,
            bytes,
            per_point,
        )?;
    }
    ensure_open_files(tiles)?;
    let plan = Plan::new(&mut survey.sample, survey.lo, survey.hi, tiles);
    survey.sample = Vec::new();
    // Pass 2: the counts, for the headers and the manifest.
    let counts = count(input, &survey, &plan, opt.halo, progress).map_err(at)?;
    let manifest = manifest_of(input_name, &survey, &plan, &counts, opt);
    // Pass 3: the tiles, when the disk holds them.
    std::fs::create_dir_all(dir).map_err(|e| Error::from(e).about(&dir.display().to_string()))?;
    let input_bytes = std::fs::metadata(input).map_or(0, |m| m.len());
    check_disk(dir, &manifest, input_bytes)?;
    let staged = write_tiles(input, input_name, dir, &survey, &plan, &manifest, progress)?;
    let text = serde_json::to_string_pretty(&manifest).expect("a manifest serialises") + "\n";
    let m = Staged::write(&dir.join(MANIFEST), |w| Ok(w.write_all(text.as_bytes())?))?;
    for s in staged.into_iter().chain([m]) {
        s.commit()?;
    }
    Ok(manifest)
}

/// The first pass: the header checked (a `vertex` element, not a tile
/// already, at most `u32::MAX` points), the box, the sample and the hash.
fn survey(input: &Path, progress: &Progress) -> Result<Survey> {
    let hash = Rc::new(RefCell::new(Xxh3::new()));
    let hashing = |f| Hashing {
        inner: f,
        hash: hash.clone(),
    };
    let mut r = open_through(input, hashing)?;
    let header = r.header().clone();
    let Some(v) = header.elements.iter().position(|e| e.name == POINTS) else {
        let what = format!("no '{POINTS}' element: nothing to tile");
        return Err(Error::invalid(what));
    };
    let count = header.elements[v].count;
    if count > u32::MAX as u64 {
        let what = format!(
            "{count} points; a split holds at most {} (its index is a uint)",
            u32::MAX
        );
        return Err(Error::unsupported(what));
    }
    if let Some(p) = header.elements[v]
        .props
        .iter()
        .find(|p| p.name == HALO || p.name == INDEX)
    {
        let what = format!("already a tile (it has '{}'): merge it first", p.name);
        return Err(Error::invalid(what));
    }
    let only_p = crate::formats::Select::only(&["P"]);
    let stride = count.div_ceil(SAMPLE).max(1);
    let mut sample = Vec::new();
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    let mut seen = 0u64;
    progress.start("split: the box", count);
    while let Some((el, chunk)) = r.next_chunk_with(CHUNK, &only_p)? {
        if el != v {
            continue;
        }
        let pos = positions(&chunk, seen)?;
        for (k, p) in pos.iter().enumerate() {
            lo = lo.min(*p);
            hi = hi.max(*p);
            if (seen + k as u64).is_multiple_of(stride) {
                sample.push(*p);
            }
        }
        seen += pos.len() as u64;
        progress.inc(pos.len() as u64);
    }
    progress.finish();
    drop(r);
    let input_hash = format!("{:032x}", hash.borrow().digest128());
    if seen == 0 {
        (lo, hi) = (DVec3::ZERO, DVec3::ZERO);
    }
    Ok(Survey {
        header,
        v,
        count,
        lo,
        hi,
        sample,
        stride,
        seen,
        input_hash,
    })
}

/// How many tiles `opt` asks for of `count` points (1 for a memory
/// budget, decided from the sample later); checked.
fn tile_count(opt: &SplitOptions, count: u64) -> Result<usize> {
    let tiles = match opt.tiles {
        TileCount::Tiles(n) => n,
        TileCount::Size(0) => return Err(Error::param("tile_size", "must be at least 1 point")),
        TileCount::Size(s) => count.div_ceil(s).max(1) as usize,
        TileCount::Memory {
            per_point: Some(0), ..
        } => return Err(Error::param("point_bytes", "must be at least 1")),
        TileCount::Memory { .. } => 1,
    };
    if !(1..=MAX_TILES).contains(&tiles) {
        let name = match opt.tiles {
            TileCount::Tiles(_) => "tiles",
            _ => "tile_size",
        };
        let what = format!("{tiles} tiles: must make 1 to {MAX_TILES}");
        return Err(Error::param(name, what));
    }
    Ok(tiles)
}

/// The points no longer as many as the first pass saw: the file changed.
fn changed(seen: u64, now: u64) -> Result<()> {
    if now == seen {
        return Ok(());
    }
    let what = format!("changed while it was split ({seen} points, then {now})");
    Err(Error::invalid(what))
}

/// The second pass: each tile's owned and halo points within `h`.
fn count(
    input: &Path,
    survey: &Survey,
    plan: &Plan,
    h: f64,
    progress: &Progress,
) -> Result<Vec<[u64; 2]>> {
    let only_p = crate::formats::Select::only(&["P"]);
    let mut r = open(input)?;
    let mut counts = vec![[0u64; 2]; plan.boxes.len()];
    let mut base = 0u64;
    progress.start("split: counting", survey.count);
    while let Some((el, chunk)) = r.next_chunk_with(CHUNK, &only_p)? {
        if el != survey.v {
            continue;
        }
        let pos = positions(&chunk, base)?;
        let part = tile_counts(plan, &pos, h);
        for (x, y) in counts.iter_mut().zip(&part) {
            x[0] += y[0];
            x[1] += y[1];
        }
        base += pos.len() as u64;
        progress.inc(pos.len() as u64);
    }
    progress.finish();
    changed(survey.seen, base)?;
    Ok(counts)
}

/// The manifest of the split: the input, the plan's tiles and their
/// counts, the elements kept aside, its checksum.
fn manifest_of(
    input_name: &str,
    survey: &Survey,
    plan: &Plan,
    counts: &[[u64; 2]],
    opt: &SplitOptions,
) -> Manifest {
    let header = &survey.header;
    let others = header.elements.len() > 1;
    let mut manifest = Manifest {
        format: FORMAT.to_string(),
        split: String::new(),
        input: input_name.to_string(),
        input_hash: survey.input_hash.clone(),
        points: survey.count,
        halo: opt.halo,
        for_stage: opt.for_stage.clone(),
        lo: survey.lo.to_array(),
        hi: survey.hi.to_array(),
        elements: header
            .elements
            .iter()
            .map(|e| ElementEntry {
                name: e.name.clone(),
                count: e.count,
            })
            .collect(),
        rest: others.then(|| super::REST.to_string()),
        tiles: plan
            .boxes
            .iter()
            .enumerate()
            .map(|(i, (a, b))| Tile {
                index: i as u32,
                file: format!("tile_{i:04}.ply"),
                lo: a.to_array(),
                hi: b.to_array(),
                owned: counts[i][0],
                halo: counts[i][1],
            })
            .collect(),
    };
    manifest.split = manifest.checksum();
    manifest
}

/// The third pass: every tile and the rest file written to staged files
/// (returned, to be committed with the manifest).
fn write_tiles(
    input: &Path,
    input_name: &str,
    dir: &Path,
    survey: &Survey,
    plan: &Plan,
    manifest: &Manifest,
    progress: &Progress,
) -> Result<Vec<Staged>> {
    let at = |e: Error| e.about(input_name);
    let (header, v) = (&survey.header, survey.v);
    let tiles = manifest.tiles.len();
    let mut r = open(input).map_err(at)?;
    let buf = ((64 << 20) / tiles).clamp(8 << 10, 1 << 20);
    let mut staged = tile_files(&mut r, dir, survey, manifest, buf, &at)?;
    let mut writers: Vec<BufWriter<&File>> = staged
        .iter()
        .map(|s| BufWriter::with_capacity(buf, s.file()))
        .collect();
    let rest_staged = match &manifest.rest {
        Some(name) => Some(rest_file(&mut r, &dir.join(name), header, v, &at)?),
        None => None,
    };
    let mut rest_w = rest_staged
        .as_ref()
        .map(|s| BufWriter::with_capacity(1 << 20, s.file()));
    let mut base = 0u64;
    progress.start("split: writing tiles", survey.count);
    while let Some((el, chunk)) = r.next_chunk(CHUNK).map_err(at)? {
        if el != v {
            let w = rest_w.as_mut().expect("a rest file for other elements");
            write_body(w, &chunk, Encoding::BinaryLe)?;
            continue;
        }
        let n = write_chunk(&chunk, base, plan, manifest.halo, &mut writers).map_err(at)?;
        base += n as u64;
        progress.inc(n as u64);
    }
    progress.finish();
    changed(survey.seen, base).map_err(at)?;
    for w in writers.iter_mut() {
        w.flush()?;
    }
    drop(writers);
    if let Some(w) = rest_w.as_mut() {
        w.flush()?;
    }
    drop(rest_w);
    staged.extend(rest_staged);
    Ok(staged)
}

/// Each tile's staged file with its header written: the input's vertex
/// schema plus the halo flag and the input index, its detail, and the
/// split, tile and halo it belongs to (`at`: an error about the input).
fn tile_files(
    r: &mut PlyChunks<BufReader<File>>,
    dir: &Path,
    survey: &Survey,
    manifest: &Manifest,
    buf: usize,
    at: &dyn Fn(Error) -> Error,
) -> Result<Vec<Staged>> {
    let header = &survey.header;
    let vschema = {
        let mut el = r.schema_of(survey.v).map_err(at)?;
        el.set(Attribute::scalar(HALO, Column::U8(Vec::new())))?;
        el.set(Attribute::scalar(INDEX, Column::U32(Vec::new())))?;
        el
    };
    let mut staged = Vec::with_capacity(manifest.tiles.len() + 2);
    for (i, t) in manifest.tiles.iter().enumerate() {
        let s = Staged::create(&dir.join(&t.file))?;
        let mut cloud = Cloud {
            elements: vec![schema(&vschema)],
            detail: header.detail.clone(),
            comments: header.comments.clone(),
            obj_info: header.obj_info.clone(),
        };
        cloud.set_detail(D_SPLIT, DetailValue::Str(manifest.split.clone()));
        cloud.set_detail(D_TILE, DetailValue::I32(i as i32));
        cloud.set_detail(D_HALO, DetailValue::F64(manifest.halo));
        let text = header_text_with(&cloud, Encoding::BinaryLe, |_, _| t.owned + t.halo)?;
        let mut w = BufWriter::with_capacity(buf, s.file());
        w.write_all(text.as_bytes())?;
        w.flush()?;
        drop(w);
        staged.push(s);
    }
    Ok(staged)
}

/// The rest file (at `path`), staged with its header: every element but
/// the vertices (`v`), whose rows the third pass copies in.
fn rest_file(
    r: &mut PlyChunks<BufReader<File>>,
    path: &Path,
    header: &Header,
    v: usize,
    at: &dyn Fn(Error) -> Error,
) -> Result<Staged> {
    let others: Vec<usize> = (0..header.elements.len()).filter(|&i| i != v).collect();
    let s = Staged::create(path)?;
    let mut cloud = Cloud {
        elements: Vec::new(),
        detail: Vec::new(),
        comments: Vec::new(),
        obj_info: Vec::new(),
    };
    for &i in &others {
        cloud.elements.push(r.schema_of(i).map_err(at)?);
    }
    let counts: Vec<u64> = others.iter().map(|&i| header.elements[i].count).collect();
    let text = header_text_with(&cloud, Encoding::BinaryLe, |k, _| counts[k])?;
    let mut w = BufWriter::new(s.file());
    w.write_all(text.as_bytes())?;
    w.flush()?;
    drop(w);
    Ok(s)
}

/// A chunk of vertices (its first row the input's `base`) written to the
/// tiles that own or hold them in their halo (within `h`), each tile's
/// rows in the input's order. Returns the rows.
fn write_chunk(
    chunk: &Element,
    base: u64,
    plan: &Plan,
    h: f64,
    writers: &mut [BufWriter<&File>],
) -> Result<usize> {
    let pos = positions(chunk, base)?;
    // Each point's owner, and its halo tiles as (row, tile) in row
    // order; then each tile's rows in the input's order.
    let owner: Vec<u32> = pos.par_iter().map(|&p| plan.owner(p)).collect();
    let halos: Vec<(u32, u32)> = pos
        .par_iter()
        .enumerate()
        .flat_map_iter(|(k, &p)| {
            let mut hs = Vec::new();
            plan.halo_of(p, owner[k], h, |t| hs.push((k as u32, t)));
            hs.sort_unstable();
            hs
        })
        .collect();
    let mut rows: Vec<Vec<(usize, bool)>> = vec![Vec::new(); writers.len()];
    let mut hi = 0;
    for (k, &o) in owner.iter().enumerate() {
        rows[o as usize].push((k, false));
        while hi < halos.len() && halos[hi].0 as usize == k {
            rows[halos[hi].1 as usize].push((k, true));
            hi += 1;
        }
    }
    for (t, rs) in rows.iter().enumerate().filter(|(_, rs)| !rs.is_empty()) {
        let idx: Vec<usize> = rs.iter().map(|&(k, _)| k).collect();
        let mut part = chunk.gather(&idx);
        part.set(Attribute::scalar(
            HALO,
            Column::U8(rs.iter().map(|&(_, halo)| halo as u8).collect()),
        ))?;
        part.set(Attribute::scalar(
            INDEX,
            Column::U32(idx.iter().map(|&k| (base + k as u64) as u32).collect()),
        ))?;
        write_body(&mut writers[t], &part, Encoding::BinaryLe)?;
    }
    Ok(pos.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn manifest(points: u64, tiles: &[(u64, u64)]) -> Manifest {
        Manifest {
            format: super::super::FORMAT.into(),
            split: String::new(),
            input: "in.ply".into(),
            input_hash: String::new(),
            points,
            halo: 1.0,
            for_stage: None,
            lo: [0.0; 3],
            hi: [1.0; 3],
            elements: Vec::new(),
            rest: None,
            tiles: tiles
                .iter()
                .enumerate()
                .map(|(i, &(owned, halo))| Tile {
                    index: i as u32,
                    file: format!("tile_{i:04}.ply"),
                    lo: [0.0; 3],
                    hi: [1.0; 3],
                    owned,
                    halo,
                })
                .collect(),
        }
    }

    #[test]
    fn a_split_the_disk_cannot_hold_is_refused_before_writing() {
        // 1,000 points of 40 bytes, two tiles whose halos hold every
        // point again: 3,000 rows of 45 bytes and the input, 175,000.
        let m = manifest(1000, &[(500, 1000), (500, 1000)]);
        let dir = Path::new("T");
        assert!(disk_holds(&m, 40_000, 175_000, dir).is_ok());
        let e = disk_holds(&m, 40_000, 174_999, dir).unwrap_err();
        assert!(e.is_param(), "{e}");
        let text = e.to_string();
        assert!(
            text.contains("0.2 MB") && text.contains("3000 rows"),
            "{text}"
        );
    }
}
