//! `pctile merge`: the owned points of every tile back in the input's
//! order, streaming: each tile's owned points come in increasing input
//! index (the split wrote them so and the stages keep the order), so the
//! output is a k-way merge that holds one chunk of each tile at a time.

use std::fs::File;
use std::io::{BufReader, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::split::CHUNK;
use super::{Manifest, D_HALO, D_SPLIT, D_TILE, HALO, INDEX};
use crate::cloud::{Cloud, Detail, DetailValue, Element, POINTS};
use crate::error::{Error, Result};
use crate::formats::ply::read::PlyChunks;
use crate::formats::ply::write::{header_text_with, write_body};
use crate::formats::Encoding;
use crate::progress::Progress;

type Reader = PlyChunks<BufReader<File>>;

/// An invalid input, about the file `name`.
fn bad(name: &str, what: String) -> Error {
    Error::invalid(what).about(name)
}

fn open(path: &Path) -> Result<Reader> {
    let f = crate::files::open_input(path)?;
    PlyChunks::new(BufReader::with_capacity(1 << 18, f))
}

/// A tile being read: its current chunk and where in it.
struct Cursor {
    name: String,
    r: Reader,
    chunk: Option<Arc<Element>>,
    halo: Vec<u8>,
    index: Vec<u32>,
    at: usize,
    /// The last owned index taken (each must be larger).
    last: Option<u32>,
}

impl Cursor {
    /// The next row's (halo, index), reading a chunk when needed; `None`
    /// at the tile's end.
    fn peek(&mut self) -> Result<Option<(bool, u32)>> {
        while self.chunk.as_ref().is_none_or(|c| self.at >= c.len()) {
            match self.r.next_chunk(CHUNK).map_err(|e| e.about(&self.name))? {
                None => {
                    self.chunk = None;
                    return Ok(None);
                }
                Some((_, el)) => {
                    self.halo = el
                        .scalar_column(HALO)?
                        .column()
                        .as_slice::<u8>()
                        .expect("checked uchar")
                        .to_vec();
                    self.index = el
                        .scalar_column(INDEX)?
                        .column()
                        .as_slice::<u32>()
                        .expect("checked uint")
                        .to_vec();
                    self.chunk = Some(Arc::new(el));
                    self.at = 0;
                }
            }
        }
        Ok(Some((self.halo[self.at] != 0, self.index[self.at])))
    }
}

fn tile_details(cloud_detail: &[Detail]) -> Vec<Detail> {
    cloud_detail
        .iter()
        .filter(|d| ![D_SPLIT, D_TILE, D_HALO].contains(&d.name.as_str()))
        .cloned()
        .collect()
}

/// Merges the tiles of the split in `dir` (its manifest) into `out` as PLY
/// of encoding `enc`: the tile files `files` (each says which tile it is),
/// or, when empty, those the manifest lists in `dir`. Refuses a tile
/// missing, given twice, from another split, or not matching the
/// manifest, and tiles that disagree on their attributes or details.
pub fn merge(
    dir: &Path,
    files: &[PathBuf],
    out: &mut dyn Write,
    enc: Encoding,
    progress: &Progress,
) -> Result<Manifest> {
    let m = Manifest::read(dir)?;
    let files: Vec<PathBuf> = if files.is_empty() {
        m.tile_files(dir)
    } else {
        files.to_vec()
    };
    let mut tiles = open_tiles(&m, &files)?;
    let (schema0, details0) = agreed(&mut tiles)?;
    // The output's header: the elements in the input's order.
    let mut vschema = schema0.clone();
    vschema.remove(HALO);
    vschema.remove(INDEX);
    let mut rest = match &m.rest {
        Some(f) => {
            let path = dir.join(f);
            Some(open(&path).map_err(|e| e.about(&path.display().to_string()))?)
        }
        None => None,
    };
    let elements = out_elements(&m, dir, &vschema, rest.as_ref())?;
    let cloud = Cloud {
        elements,
        detail: details0,
        comments: tiles[0].r.header().comments.clone(),
        obj_info: tiles[0].r.header().obj_info.clone(),
    };
    let counts: Vec<u64> = m.elements.iter().map(|e| e.count).collect();
    out.write_all(header_text_with(&cloud, enc, |i, _| counts[i])?.as_bytes())?;

    progress.start("merge", m.points);
    for e in &m.elements {
        if e.name != POINTS {
            let r = rest.as_mut().expect("checked above");
            copy_rest(r, &m, e, out, enc)?;
            continue;
        }
        let mut next = 0u64;
        while next < m.points {
            let end = (next + CHUNK as u64).min(m.points);
            let el = owned_rows(&mut tiles, next, end)?;
            write_body(out, &el, enc)?;
            progress.inc(el.len() as u64);
            next = end;
        }
        for c in tiles.iter_mut() {
            while let Some((halo, idx)) = c.peek()? {
                if !halo {
                    return Err(bad(
                        &c.name,
                        format!("point index {idx}, but the input had {} points", m.points),
                    ));
                }
                c.at += 1;
            }
        }
    }
    progress.finish();
    if let Some(r) = rest.as_mut() {
        if r.next_chunk(CHUNK)?.is_some() {
            return Err(bad(
                m.rest.as_deref().unwrap_or(""),
                "more rows than the manifest says".to_string(),
            ));
        }
    }
    Ok(m)
}

/// The tile files opened, each checked against the manifest `m` (its
/// split, its tile, its points), in the manifest's order; a tile missing
/// or given twice is an error.
fn open_tiles(m: &Manifest, files: &[PathBuf]) -> Result<Vec<Cursor>> {
    let mut by_tile: Vec<Option<Cursor>> = (0..m.tiles.len()).map(|_| None).collect();
    for path in files {
        let name = path.display().to_string();
        let r = open(path).map_err(|e| e.about(&name))?;
        let h = r.header();
        let detail = |n: &str| {
            h.detail
                .iter()
                .find(|d| d.name == n)
                .map(|d| d.value.clone())
        };
        let Some(DetailValue::Str(id)) = detail(D_SPLIT) else {
            return Err(bad(&name, format!("not a tile (no detail '{D_SPLIT}')")));
        };
        if id != m.split {
            return Err(bad(
                &name,
                format!(
                    "a tile of another split ({id}; the manifest's is {})",
                    m.split
                ),
            ));
        }
        let t = match detail(D_TILE) {
            Some(DetailValue::I32(t)) if t >= 0 && (t as usize) < m.tiles.len() => t as usize,
            other => {
                return Err(bad(
                    &name,
                    format!("detail '{D_TILE}' is {other:?}, not a tile of the manifest"),
                ))
            }
        };
        if let Some(c) = &by_tile[t] {
            return Err(bad(&name, format!("tile {t} again (also {})", c.name)));
        }
        let Some(v) = h.elements.iter().position(|e| e.name == POINTS) else {
            return Err(bad(&name, format!("no '{POINTS}' element")));
        };
        if let Some(e) = h.elements.iter().find(|e| e.name != POINTS) {
            return Err(bad(
                &name,
                format!("element '{}' in a tile (tiles hold points only)", e.name),
            ));
        }
        let want = m.tiles[t].owned.saturating_add(m.tiles[t].halo);
        if h.elements[v].count != want {
            return Err(bad(
                &name,
                format!(
                    "{} points, but the manifest's tile {t} has {want} ({} owned, {} halo)",
                    h.elements[v].count, m.tiles[t].owned, m.tiles[t].halo
                ),
            ));
        }
        by_tile[t] = Some(Cursor {
            name,
            r,
            chunk: None,
            halo: Vec::new(),
            index: Vec::new(),
            at: 0,
            last: None,
        });
    }
    if let Some(t) = by_tile.iter().position(|c| c.is_none()) {
        return Err(Error::invalid(format!(
            "tile {t} is missing ({} in the manifest): {} of {} tiles given",
            m.tiles[t].file,
            by_tile.iter().flatten().count(),
            m.tiles.len()
        )));
    }
    Ok(by_tile.into_iter().flatten().collect())
}

/// The tiles' one schema and one set of details (a tile that differs is
/// named), with the halo flag and index checked.
fn agreed(tiles: &mut [Cursor]) -> Result<(Element, Vec<Detail>)> {
    let schema0 = tiles[0].r.schema_of(0)?;
    for (a, ty) in [(HALO, "uchar"), (INDEX, "uint")] {
        match schema0.attr(a) {
            Some(x) if x.type_name() == ty => {}
            Some(x) => {
                return Err(bad(
                    &tiles[0].name,
                    format!("'{a}' is {}, not {ty}", x.type_name()),
                ))
            }
            None => {
                return Err(bad(
                    &tiles[0].name,
                    format!("no '{a}' (a stage dropped it?)"),
                ))
            }
        }
    }
    let details0 = tile_details(&tiles[0].r.header().detail);
    for c in &tiles[1..] {
        let s = c.r.schema_of(0)?;
        if s.schema() != schema0.schema() {
            let diff = s
                .schema()
                .into_iter()
                .zip(schema0.schema())
                .find(|(a, b)| a != b)
                .map(|(a, b)| {
                    format!(
                        "'{}' ({}) where {} has '{}' ({})",
                        a.0, a.1, tiles[0].name, b.0, b.1
                    )
                })
                .unwrap_or_else(|| {
                    format!(
                        "{} attributes where {} has {}",
                        s.attrs().len(),
                        tiles[0].name,
                        schema0.attrs().len()
                    )
                });
            return Err(bad(&c.name, diff));
        }
        let d = tile_details(&c.r.header().detail);
        if d != details0 {
            let what = d
                .iter()
                .find(|x| !details0.contains(x))
                .or_else(|| details0.iter().find(|x| !d.contains(x)))
                .map_or("order".to_string(), |x| format!("'{}'", x.name));
            return Err(bad(
                &c.name,
                format!(
                    "detail {what} differs from {}'s: tiles of one bake agree on their details",
                    tiles[0].name
                ),
            ));
        }
    }

    Ok((schema0, details0))
}

/// The output's elements in the input's order: the vertices' schema
/// `vschema`, the others' from the rest file, checked against the
/// manifest.
fn out_elements(
    m: &Manifest,
    dir: &Path,
    vschema: &Element,
    rest: Option<&Reader>,
) -> Result<Vec<Element>> {
    let mut elements = Vec::with_capacity(m.elements.len());
    let mut rest_k = 0;
    for e in &m.elements {
        if e.name == POINTS {
            elements.push(vschema.gather(&[]));
            continue;
        }
        let Some(r) = rest else {
            return Err(bad(
                &dir.join(super::MANIFEST).display().to_string(),
                format!("element '{}' but no rest file", e.name),
            ));
        };
        let def = r.header().elements.get(rest_k);
        if def.is_none_or(|d| d.name != e.name || d.count != e.count) {
            return Err(bad(
                m.rest.as_deref().unwrap_or(""),
                format!("does not hold element '{}' of {} rows", e.name, e.count),
            ));
        }
        elements.push(r.schema_of(rest_k)?);
        rest_k += 1;
    }
    Ok(elements)
}

/// Element `e`'s rows copied from the rest file `r` to `out`.
fn copy_rest(
    r: &mut Reader,
    m: &Manifest,
    e: &super::ElementEntry,
    out: &mut dyn Write,
    enc: Encoding,
) -> Result<()> {
    let mut done = 0;
    while done < e.count {
        let Some((_, el)) = r.next_chunk(CHUNK)? else {
            return Err(bad(
                m.rest.as_deref().unwrap_or(""),
                format!("ends inside element '{}'", e.name),
            ));
        };
        done += el.len() as u64;
        write_body(out, &el, enc)?;
    }
    Ok(())
}

/// The output's rows `next..end`: each input point from the tile that owns
/// it, without the halo flag and index.
fn owned_rows(tiles: &mut [Cursor], next: u64, end: u64) -> Result<Element> {
    let mut parts: Vec<Arc<Element>> = Vec::new();
    // Row k of the output is input point next + k: each owned
    // point goes straight to its slot, and a slot filled twice or
    // left empty is a tile that does not match the manifest.
    const EMPTY: (u32, u32) = (u32::MAX, u32::MAX);
    let mut slots = vec![EMPTY; (end - next) as usize];
    for c in tiles.iter_mut() {
        // The part (in `parts`) of the tile's current chunk.
        let mut part: Option<(*const Element, u32)> = None;
        while let Some((halo, idx)) = c.peek()? {
            if !halo {
                if (idx as u64) >= end {
                    break;
                }
                if c.last.is_some_and(|l| idx <= l) {
                    return Err(bad(&c.name, format!("point index {idx} after {}: a tile's points must stay in the order the split wrote them", c.last.expect("checked"))));
                }
                c.last = Some(idx);
                let chunk = c.chunk.as_ref().expect("peeked");
                let p = match part {
                    Some((ptr, p)) if ptr == Arc::as_ptr(chunk) => p,
                    _ => {
                        parts.push(chunk.clone());
                        let p = parts.len() as u32 - 1;
                        part = Some((Arc::as_ptr(chunk), p));
                        p
                    }
                };
                let slot = &mut slots[(idx as u64 - next) as usize];
                if *slot != EMPTY {
                    return Err(bad(&c.name, format!("point {idx} is owned by two tiles")));
                }
                *slot = (p, c.at as u32);
            }
            c.at += 1;
        }
    }
    if let Some(k) = slots.iter().position(|s| *s == EMPTY) {
        return Err(Error::invalid(format!(
            "point {} is in no tile: the tiles do not match their manifest",
            next + k as u64
        )));
    }
    let refs: Vec<&Element> = parts.iter().map(|p| p.as_ref()).collect();
    let mut el = Element::gather_from(&refs, &slots);
    el.remove(HALO);
    el.remove(INDEX);
    Ok(el)
}
