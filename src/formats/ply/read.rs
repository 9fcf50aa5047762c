//! PLY reading: a streaming reader for every encoding and property type.
//!
//! Binary elements without lists (the common case: points) take the fast
//! path: rows are read in 1 MiB chunks and the selected properties decoded
//! while the chunk is hot in cache; the rest stay as raw bytes, decoded only
//! if asked for and otherwise copied through on write. Elements with lists
//! (faces) and ASCII bodies are decoded row by row, but for an ASCII file
//! read whole and laid out one row a line, which is parsed in parallel, a chunk of
//! lines a task (`read_ascii_lines`). Nothing is allocated
//! from a header's counts: buffers grow with the bytes that actually arrive,
//! so a header that claims 10^12 vertices over a short body fails as
//! "truncated" with memory bounded by the file.

use std::io::{BufRead, Read};
use std::sync::Arc;

use super::header::{layout, read_header, roles, ElementDef, Encoding, Header, Layout, PropKind};
use crate::cloud::{AttrData, Attribute, Cloud, Element, ListColumn};
use crate::column::{Bytes, Column, RawBlock, RawRef, Values};
use crate::error::{Error, Result};

mod ascii;
use ascii::{ascii_in_parallel, read_ascii, Tokens};

/// Which attributes to decode while reading.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Select {
    /// Decode everything now.
    #[default]
    All,
    /// Decode only these attributes now (of any element); the others stay
    /// undecoded until used, and pass through to the output unchanged.
    Only(Vec<String>),
}

impl Select {
    /// Select only the given attribute names.
    pub fn only(names: &[&str]) -> Self {
        Select::Only(names.iter().map(|s| s.to_string()).collect())
    }

    /// True when `name` is selected.
    pub fn wants(&self, name: &str) -> bool {
        match self {
            Select::All => true,
            Select::Only(v) => v.iter().any(|n| n == name),
        }
    }
}

const CHUNK_BYTES: usize = 1 << 20;

/// An input the reader may slice without copying: a whole file read into
/// one shared buffer.
pub trait Source: BufRead {
    /// The buffer and the current offset in it, when there is one.
    fn whole(&self) -> Option<(&Arc<Vec<u8>>, usize)> {
        None
    }
}

/// A whole file in memory, read from `pos` on: properties a stage does
/// not decode keep a range of it, with no copy.
pub struct Whole {
    buf: Arc<Vec<u8>>,
    pos: usize,
}

impl Whole {
    /// Reads `buf` from its start.
    pub fn new(buf: Arc<Vec<u8>>) -> Self {
        Whole { buf, pos: 0 }
    }
}

impl Read for Whole {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.fill_buf()?.read(buf)?;
        self.consume(n);
        Ok(n)
    }
}

impl BufRead for Whole {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        Ok(&self.buf[self.pos..])
    }
    fn consume(&mut self, amt: usize) {
        self.pos = (self.pos + amt).min(self.buf.len());
    }
}

impl Source for Whole {
    fn whole(&self) -> Option<(&Arc<Vec<u8>>, usize)> {
        Some((&self.buf, self.pos))
    }
}

/// Any buffered reader, read as a stream.
pub struct Stream<R>(pub R);

impl<R: Read> Read for Stream<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.0.read(buf)
    }
}

impl<R: BufRead> BufRead for Stream<R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        self.0.fill_buf()
    }
    fn consume(&mut self, amt: usize) {
        self.0.consume(amt)
    }
}

impl<R: BufRead> Source for Stream<R> {}

/// The most rows an element without properties may declare.
pub const MAX_EMPTY_ROWS: u64 = 1 << 20;

/// Reads a whole PLY file from a stream.
pub fn read_ply<R: BufRead>(r: R, select: &Select) -> Result<Cloud> {
    read_ply_from(Stream(r), select)
}

/// Reads a whole PLY file from any [`Source`]; a [`Whole`] one keeps
/// undecoded properties in the mapping instead of copying them.
pub fn read_ply_from<R: Source>(mut r: R, select: &Select) -> Result<Cloud> {
    let h = read_header(&mut r)?;
    let mut cloud = Cloud {
        elements: Vec::with_capacity(h.elements.len()),
        detail: h.detail.clone(),
        comments: h.comments.clone(),
        obj_info: h.obj_info.clone(),
    };
    let mut tokens = Tokens::new();
    let roles = roles(&h);
    for def in &h.elements {
        if def.props.is_empty() {
            // Rows without properties hold nothing to read: a count
            // beyond the cap can only be a lie (and would cost a loop, or
            // an ASCII writer a line, for each).
            if def.count > MAX_EMPTY_ROWS {
                return Err(Error::invalid(format!(
                    "element '{}' declares {} rows but no properties (at most {MAX_EMPTY_ROWS})",
                    def.name, def.count
                )));
            }
            cloud
                .elements
                .push(Element::new(&def.name, def.count as usize));
            continue;
        }
        let lay = layout(def, &roles);
        let el = match (h.encoding, def.fixed_stride()) {
            (Encoding::Ascii, _) => match ascii_in_parallel(&mut r, &mut tokens, def, &lay) {
                Some(el) => el,
                None => read_ascii(&mut r, &mut tokens, def, 0..def.count, &lay)?,
            },
            (enc, Some(stride)) if stride > 0 => read_fixed(
                &mut r,
                def,
                0..def.count,
                &lay,
                stride,
                enc == Encoding::BinaryBe,
                select,
            )?,
            (enc, _) => read_rows(&mut r, def, 0..def.count, &lay, enc == Encoding::BinaryBe)?,
        };
        cloud.elements.push(el);
    }
    check_end(&mut r, &h, &mut tokens)?;
    Ok(cloud)
}

fn check_end<R: BufRead>(r: &mut R, h: &Header, tokens: &mut Tokens) -> Result<()> {
    if h.encoding == Encoding::Ascii {
        if tokens.next(r)?.is_some() {
            return Err(Error::invalid(format!(
                "unexpected data after the last element (line {})",
                tokens.lineno
            )));
        }
    } else if !r.fill_buf()?.is_empty() {
        let mut n = 0u64;
        loop {
            let k = r.fill_buf()?.len();
            if k == 0 || n > (1 << 30) {
                break;
            }
            r.consume(k);
            n += k as u64;
        }
        return Err(Error::invalid(format!(
            "{n} unexpected bytes after the last element"
        )));
    }
    Ok(())
}

/// Builds an element from its layout and one [`Values`]/list per property.
fn assemble(
    def: &ElementDef,
    lay: &[Layout],
    mut props: Vec<Option<PropData>>,
    len: usize,
) -> Element {
    let mut el = Element::new(&def.name, len);
    let mut take = |i: usize| props[i].take().expect("each property used once");
    for l in lay {
        let data = match l {
            Layout::Scalar { prop, .. } => AttrData::Scalar(take(*prop).values()),
            Layout::Vec3 { role, props: p, .. } => AttrData::Vec3(
                *role,
                Box::new([
                    take(p[0]).values(),
                    take(p[1]).values(),
                    take(p[2]).values(),
                ]),
            ),
            Layout::List { prop, .. } => AttrData::List(take(*prop).list()),
        };
        // (The header's names are unique and the layout's groups never
        // clash with them.)
        el.push_unique(Attribute {
            name: l.name().to_string(),
            data,
        })
        .expect("lengths agree by construction");
    }
    el
}

enum PropData {
    Values(Values),
    List(ListColumn),
}

impl PropData {
    fn values(self) -> Values {
        match self {
            PropData::Values(v) => v,
            PropData::List(_) => unreachable!("layout groups only scalars"),
        }
    }
    fn list(self) -> ListColumn {
        match self {
            PropData::List(l) => l,
            PropData::Values(_) => unreachable!("layout lists only lists"),
        }
    }
}

fn truncated(def: &ElementDef, row: u64) -> Error {
    Error::truncated(format!(
        "element '{}' ends at row {row} of {}",
        def.name, def.count
    ))
}

/// The fast path: rows `rows` of a binary element of fixed-size rows.
fn read_fixed<R: Source>(
    r: &mut R,
    def: &ElementDef,
    rows: std::ops::Range<u64>,
    lay: &[Layout],
    stride: usize,
    big: bool,
    select: &Select,
) -> Result<Element> {
    let mut offsets = Vec::with_capacity(def.props.len());
    let mut off = 0;
    for p in &def.props {
        offsets.push(off);
        if let PropKind::Scalar(t) = p.kind {
            off += t.size();
        }
    }
    let mut wanted = vec![false; def.props.len()];
    for l in lay.iter().filter(|l| select.wants(l.name())) {
        match l {
            Layout::Scalar { prop, .. } => wanted[*prop] = true,
            Layout::Vec3 { props, .. } => props.iter().for_each(|&p| wanted[p] = true),
            Layout::List { .. } => {}
        }
    }
    let keep_raw = wanted.iter().any(|w| !w);
    let ty = |i: usize| match def.props[i].kind {
        PropKind::Scalar(t) => t,
        PropKind::List(..) => unreachable!("fixed rows have no lists"),
    };
    let mut cols: Vec<Option<Column>> = (0..def.props.len())
        .map(|i| wanted[i].then(|| Column::empty(ty(i))))
        .collect();
    let count = rows.end - rows.start;
    let total = count.checked_mul(stride as u64).ok_or_else(|| {
        Error::invalid(format!(
            "element '{}': {} rows overflow",
            def.name, def.count
        ))
    })?;
    let chunk_rows = (CHUNK_BYTES / stride).max(1) as u64;
    let decode = |cols: &mut [Option<Column>], rows: &[u8]| {
        for (i, c) in cols.iter_mut().enumerate() {
            if let Some(c) = c {
                c.extend_from_records(rows, stride, offsets[i], big);
            }
        }
    };
    let bytes = if let Some((map, pos)) = r.whole().map(|(m, p)| (m.clone(), p)) {
        // In memory: check the length, decode in place, keep a range.
        let avail = (map.len() - pos) as u64;
        if avail < total {
            return Err(truncated(def, rows.start + avail / stride as u64));
        }
        let total = total as usize;
        // The bytes are there: the count can be trusted now.
        for c in cols.iter_mut().flatten() {
            c.reserve(count as usize);
        }
        for rows in map[pos..pos + total].chunks(chunk_rows as usize * stride) {
            decode(&mut cols, rows);
        }
        r.consume(total);
        Bytes::Shared {
            buf: map,
            start: pos,
            len: total,
        }
    } else {
        // Streamed: read 1 MiB chunks, growing only with what arrives.
        let mut raw: Vec<u8> = Vec::new();
        let mut done = 0u64;
        while done < count {
            let n = chunk_rows.min(count - done);
            let want = n as usize * stride;
            if !keep_raw {
                raw.clear();
            }
            let start = raw.len();
            raw.reserve(want);
            let got = r.by_ref().take(want as u64).read_to_end(&mut raw)?;
            if got < want {
                return Err(truncated(def, rows.start + done + (got / stride) as u64));
            }
            decode(&mut cols, &raw[start..]);
            done += n;
        }
        Bytes::Owned(raw)
    };
    let block = keep_raw.then(|| {
        Arc::new(RawBlock {
            bytes,
            stride,
            big_endian: big,
        })
    });
    let props = cols
        .into_iter()
        .enumerate()
        .map(|(i, c)| {
            Some(PropData::Values(match c {
                Some(c) => Values::owned(c),
                None => Values::lazy(
                    ty(i),
                    RawRef {
                        block: block.clone().expect("raw kept for undecoded properties"),
                        offset: offsets[i],
                    },
                ),
            }))
        })
        .collect();
    Ok(assemble(def, lay, props, count as usize))
}

fn empty_props(def: &ElementDef) -> Vec<PropData> {
    def.props
        .iter()
        .map(|p| match p.kind {
            PropKind::Scalar(t) => PropData::Values(Values::owned(Column::empty(t))),
            PropKind::List(c, i) => PropData::List(ListColumn::new(c, i)),
        })
        .collect()
}

fn scalar_mut(p: &mut PropData) -> &mut Column {
    match p {
        PropData::Values(v) => v.column_mut(),
        PropData::List(_) => unreachable!("scalar property"),
    }
}

/// A list count as a signed integer.
fn count_value(c: &Column) -> i64 {
    c.get_f64(0) as i64
}

/// Binary elements with list properties, row by row.
fn read_rows<R: BufRead>(
    r: &mut R,
    def: &ElementDef,
    rows: std::ops::Range<u64>,
    lay: &[Layout],
    big: bool,
) -> Result<Element> {
    let mut props = empty_props(def);
    let mut buf = [0u8; 8];
    let mut items = Vec::new();
    let eof = |e: std::io::Error, row: u64| {
        if e.kind() == std::io::ErrorKind::UnexpectedEof {
            truncated(def, row)
        } else {
            Error::Io(e)
        }
    };
    for row in rows.clone() {
        for (pd, p) in def.props.iter().zip(props.iter_mut()) {
            match pd.kind {
                PropKind::Scalar(t) => {
                    r.read_exact(&mut buf[..t.size()])
                        .map_err(|e| eof(e, row))?;
                    scalar_mut(p).push_bytes(&buf, big);
                }
                PropKind::List(ct, it) => {
                    r.read_exact(&mut buf[..ct.size()])
                        .map_err(|e| eof(e, row))?;
                    let mut c = Column::empty(ct);
                    c.push_bytes(&buf, big);
                    let n = count_value(&c);
                    if n < 0 {
                        return Err(Error::invalid(format!(
                            "element '{}' row {row}: list '{}' has negative count {n}",
                            def.name, pd.name
                        )));
                    }
                    let bytes = n as u64 * it.size() as u64;
                    items.clear();
                    let got = r.by_ref().take(bytes).read_to_end(&mut items)?;
                    if (got as u64) < bytes {
                        return Err(truncated(def, row));
                    }
                    let PropData::List(l) = p else { unreachable!() };
                    for b in items.chunks_exact(it.size()) {
                        l.items.push_bytes(b, big);
                    }
                    l.offsets.push(l.items.len());
                }
            }
        }
    }
    let len = (rows.end - rows.start) as usize;
    Ok(assemble(
        def,
        lay,
        props.into_iter().map(Some).collect(),
        len,
    ))
}

/// A PLY file read a chunk of rows at a time, every property decoded:
/// memory is bounded by the chunk whatever the file's size (`pctile`
/// splits and merges clouds larger than memory this way). The checks are
/// those of [`read_ply`]: a short body is "truncated" at its row, and
/// bytes after the last element are refused when the end is reached.
pub struct PlyChunks<R: BufRead> {
    r: Stream<R>,
    header: Header,
    roles: super::header::Roles,
    tokens: Tokens,
    /// The element being read, and how many of its rows have been.
    el: usize,
    row: u64,
    ended: bool,
}

impl<R: BufRead> PlyChunks<R> {
    /// Reads the header of `r`.
    pub fn new(r: R) -> Result<Self> {
        let mut r = Stream(r);
        let header = read_header(&mut r)?;
        let roles = roles(&header);
        Ok(PlyChunks {
            r,
            header,
            roles,
            tokens: Tokens::new(),
            el: 0,
            row: 0,
            ended: false,
        })
    }

    /// The file's header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// Element `i` of the header with no rows: its attributes' names and
    /// types, as reading would group them.
    pub fn schema_of(&self, i: usize) -> Result<Element> {
        let def = &self.header.elements[i];
        let lay = layout(def, &self.roles);
        read_rows(&mut &[][..], def, 0..0, &lay, false)
    }

    /// The next rows, at most `max` (at least 1), of the first element
    /// with rows left: its index in the header and the rows. `None` once
    /// every element has been read and nothing follows.
    pub fn next_chunk(&mut self, max: usize) -> Result<Option<(usize, Element)>> {
        self.next_chunk_with(max, &Select::All)
    }

    /// [`PlyChunks::next_chunk`], decoding only the `select`ed attributes
    /// of binary rows (the others stay as the chunk's bytes).
    pub fn next_chunk_with(
        &mut self,
        max: usize,
        select: &Select,
    ) -> Result<Option<(usize, Element)>> {
        let max = max.max(1) as u64;
        loop {
            let Some(def) = self.header.elements.get(self.el) else {
                if !self.ended {
                    check_end(&mut self.r, &self.header, &mut self.tokens)?;
                    self.ended = true;
                }
                return Ok(None);
            };
            if self.row >= def.count {
                self.el += 1;
                self.row = 0;
                continue;
            }
            let el = self.el;
            if def.props.is_empty() {
                if def.count > MAX_EMPTY_ROWS {
                    return Err(Error::invalid(format!(
                        "element '{}' declares {} rows but no properties (at most {MAX_EMPTY_ROWS})",
                        def.name, def.count
                    )));
                }
                self.row = def.count;
                return Ok(Some((el, Element::new(&def.name, def.count as usize))));
            }
            let rows = self.row..(self.row + max).min(def.count);
            let lay = layout(def, &self.roles);
            let r = &mut self.r;
            let part = match (self.header.encoding, def.fixed_stride()) {
                (Encoding::Ascii, _) => read_ascii(r, &mut self.tokens, def, rows.clone(), &lay)?,
                (enc, Some(stride)) if stride > 0 => read_fixed(
                    r,
                    def,
                    rows.clone(),
                    &lay,
                    stride,
                    enc == Encoding::BinaryBe,
                    select,
                )?,
                (enc, _) => read_rows(r, def, rows.clone(), &lay, enc == Encoding::BinaryBe)?,
            };
            self.row = rows.end;
            return Ok(Some((el, part)));
        }
    }
}
