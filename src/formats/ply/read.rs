//! PLY reading: a streaming reader for every encoding and property type.
//!
//! Binary elements without lists (the common case: points) take the fast
//! path: rows are read in 1 MiB chunks and the selected properties decoded
//! while the chunk is hot in cache; the rest stay as raw bytes, decoded only
//! if asked for and otherwise copied through on write. Elements with lists
//! (faces) and ASCII bodies are decoded row by row, but for a mapped ASCII
//! file laid out one row a line, which is parsed in parallel, a chunk of
//! lines a task (`read_ascii_lines`). Nothing is allocated
//! from a header's counts: buffers grow with the bytes that actually arrive,
//! so a header that claims 10^12 vertices over a short body fails as
//! "truncated" with memory bounded by the file.

use std::io::{BufRead, Read};
use std::sync::Arc;

use memmap2::Mmap;

use super::header::{layout, read_header, roles, ElementDef, Encoding, Header, Layout, PropKind};
use crate::cloud::{AttrData, Attribute, Cloud, Element, ListColumn};
use crate::column::{Bytes, Column, RawBlock, RawRef, ScalarType, Values};
use crate::error::{Error, Result};

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

    fn wants(&self, name: &str) -> bool {
        match self {
            Select::All => true,
            Select::Only(v) => v.iter().any(|n| n == name),
        }
    }
}

const CHUNK_BYTES: usize = 1 << 20;

/// An input the reader may slice without copying: a memory-mapped file.
pub trait Source: BufRead {
    /// The mapping and the current offset in it, when there is one.
    fn mapped(&self) -> Option<(&Arc<Mmap>, usize)> {
        None
    }
}

/// A memory-mapped file, read from `pos` on.
pub struct Mapped {
    map: Arc<Mmap>,
    pos: usize,
}

impl Mapped {
    /// Reads `map` from its start.
    pub fn new(map: Arc<Mmap>) -> Self {
        Mapped { map, pos: 0 }
    }
}

impl Read for Mapped {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.fill_buf()?.read(buf)?;
        self.consume(n);
        Ok(n)
    }
}

impl BufRead for Mapped {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        Ok(&self.map[self.pos..])
    }
    fn consume(&mut self, amt: usize) {
        self.pos = (self.pos + amt).min(self.map.len());
    }
}

impl Source for Mapped {
    fn mapped(&self) -> Option<(&Arc<Mmap>, usize)> {
        Some((&self.map, self.pos))
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

/// Reads a whole PLY file from any [`Source`]; a [`Mapped`] one keeps
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
    let bytes = if let Some((map, pos)) = r.mapped().map(|(m, p)| (m.clone(), p)) {
        // Mapped: check the length, decode in place, keep a range.
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
        Bytes::Mapped {
            map,
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

/// Bytes of ASCII body parsed by one task of `read_ascii_lines`, about.
const ASCII_TASK_BYTES: usize = 1 << 20;

/// An ASCII element read from a mapped file by `read_ascii_lines`, when
/// the reader stands at the start of a line; `None` leaves the reader
/// where it was.
fn ascii_in_parallel<R: Source>(
    r: &mut R,
    tok: &mut Tokens,
    def: &ElementDef,
    lay: &[Layout],
) -> Option<Element> {
    if !tok.line[tok.pos..].trim().is_empty() {
        return None;
    }
    let (el, bytes) = {
        let (map, pos) = r.mapped()?;
        read_ascii_lines(&map[pos..], def, lay)?
    };
    r.consume(bytes);
    tok.lineno += el.len();
    tok.line.clear();
    tok.pos = 0;
    Some(el)
}

/// The `def.count` rows of an ASCII element at the start of `body`, one
/// row a line (as PLY writers lay them out), parsed in parallel: chunks
/// of whole lines, each into columns of its own, joined in order; with
/// the element's length in bytes. `None` when the rows are laid
/// out otherwise (a row over two lines, two on one, a blank line) or
/// anything is wrong (a bad token, a short body): the row-by-row reader
/// then reads the element, or reports what is wrong at its line. Nothing
/// is allocated before the lines are found in `body`.
fn read_ascii_lines(body: &[u8], def: &ElementDef, lay: &[Layout]) -> Option<(Element, usize)> {
    use rayon::prelude::*;
    let count = usize::try_from(def.count).ok()?;
    if count == 0 {
        return None;
    }
    let end = memchr::memchr_iter(b'\n', body).nth(count - 1)? + 1;
    // Chunks end after a newline: the first at or after each step.
    let mut cuts = vec![0];
    let mut last = 0;
    while last + ASCII_TASK_BYTES < end {
        let want = last + ASCII_TASK_BYTES;
        last = want + memchr::memchr(b'\n', &body[want..end])? + 1;
        cuts.push(last);
    }
    if last < end {
        cuts.push(end);
    }
    let parts: Vec<Vec<PropData>> = cuts
        .par_windows(2)
        .map(|w| ascii_lines(&body[w[0]..w[1]], def))
        .collect::<Option<_>>()?;
    let mut props = empty_props(def);
    for (i, p) in props.iter_mut().enumerate() {
        match p {
            PropData::Values(v) => {
                let c = v.column_mut();
                for part in &parts {
                    let PropData::Values(pv) = &part[i] else {
                        unreachable!("one layout")
                    };
                    c.append(pv.column());
                }
            }
            PropData::List(l) => {
                for part in &parts {
                    let PropData::List(pl) = &part[i] else {
                        unreachable!("one layout")
                    };
                    let base = l.items.len();
                    l.items.append(&pl.items);
                    l.offsets.extend(pl.offsets[1..].iter().map(|o| o + base));
                }
            }
        }
    }
    let el = assemble(def, lay, props.into_iter().map(Some).collect(), count);
    Some((el, end))
}

/// Lines of `def`'s rows, one row each, into columns; `None` at a line
/// that is not exactly one valid row, or at a byte that is not ASCII
/// (the row-by-row reader then says where).
fn ascii_lines(text: &[u8], def: &ElementDef) -> Option<Vec<PropData>> {
    if !text.is_ascii() {
        return None;
    }
    let mut props = empty_props(def);
    // (Every chunk ends with its last line's newline.)
    for line in text
        .strip_suffix(b"\n")
        .unwrap_or(text)
        .split(|&b| b == b'\n')
    {
        let mut tokens = AsciiTokens(line);
        let mut next = || tokens.next();
        for (pd, p) in def.props.iter().zip(props.iter_mut()) {
            match pd.kind {
                PropKind::Scalar(_) => {
                    if !scalar_mut(p).push_token(next()?) {
                        return None;
                    }
                }
                PropKind::List(ct, _) => {
                    let n = list_count(ct, next()?)?;
                    let PropData::List(l) = p else { unreachable!() };
                    for _ in 0..n {
                        if !l.items.push_token(next()?) {
                            return None;
                        }
                    }
                    l.offsets.push(l.items.len());
                }
            }
        }
        if next().is_some() {
            return None;
        }
    }
    Some(props)
}

/// The whitespace-separated tokens of a line of ASCII bytes.
struct AsciiTokens<'a>(&'a [u8]);

impl<'a> Iterator for AsciiTokens<'a> {
    type Item = &'a str;

    fn next(&mut self) -> Option<&'a str> {
        let rest = self.0;
        let start = rest.iter().position(|b| !b.is_ascii_whitespace())?;
        let len = rest[start..]
            .iter()
            .position(|b| b.is_ascii_whitespace())
            .unwrap_or(rest.len() - start);
        self.0 = &rest[start + len..];
        // ASCII (checked by the caller) is UTF-8.
        std::str::from_utf8(&rest[start..start + len]).ok()
    }
}

/// A list's length token `s` read as the count type `ct`: `None` when it
/// is not a count of that type (negative, too large, not a number).
fn list_count(ct: ScalarType, s: &str) -> Option<usize> {
    let max: u64 = match ct {
        ScalarType::U8 => u8::MAX as u64,
        ScalarType::I8 => i8::MAX as u64,
        ScalarType::U16 => u16::MAX as u64,
        ScalarType::I16 => i16::MAX as u64,
        ScalarType::U32 => u32::MAX as u64,
        ScalarType::I32 => i32::MAX as u64,
        ScalarType::F32 | ScalarType::F64 => 0,
    };
    // Plain digits, the common case, without a column per row.
    if max > 0 {
        if let Ok(n) = s.parse::<u64>() {
            return (n <= max).then_some(n as usize);
        }
    }
    // Any other spelling the count type reads ("3.0", a float type).
    if s.parse::<i64>().is_ok_and(|n| n < 0) {
        return None;
    }
    let mut c = Column::empty(ct);
    c.push_token(s).then(|| count_value(&c) as usize)
}

/// Whitespace-separated tokens of an ASCII body, with line numbers.
struct Tokens {
    line: String,
    pos: usize,
    lineno: usize,
    raw: Vec<u8>,
}

impl Tokens {
    fn new() -> Self {
        Tokens {
            line: String::new(),
            pos: 0,
            lineno: 0,
            raw: Vec::new(),
        }
    }

    /// The next token, `None` at the end of input.
    fn next<R: BufRead>(&mut self, r: &mut R) -> Result<Option<&str>> {
        loop {
            let rest = &self.line[self.pos..];
            let trimmed = rest.trim_start();
            if !trimmed.is_empty() {
                let start = self.pos + (rest.len() - trimmed.len());
                let end = trimmed
                    .find(|c: char| c.is_ascii_whitespace())
                    .map_or(self.line.len(), |k| start + k);
                self.pos = end;
                return Ok(Some(&self.line[start..end]));
            }
            self.raw.clear();
            if r.by_ref().take(1 << 24).read_until(b'\n', &mut self.raw)? == 0 {
                return Ok(None);
            }
            self.lineno += 1;
            self.line.clear();
            match std::str::from_utf8(&self.raw) {
                Ok(s) => self.line.push_str(s),
                Err(_) => {
                    return Err(Error::invalid(format!(
                        "body line {} is not valid UTF-8 text",
                        self.lineno
                    )))
                }
            }
            self.pos = 0;
        }
    }
}

fn read_ascii<R: BufRead>(
    r: &mut R,
    tok: &mut Tokens,
    def: &ElementDef,
    rows: std::ops::Range<u64>,
    lay: &[Layout],
) -> Result<Element> {
    let mut props = empty_props(def);
    for row in rows.clone() {
        for (pd, p) in def.props.iter().zip(props.iter_mut()) {
            let bad = |t: &str, ty: ScalarType, line: usize| {
                Error::invalid(format!(
                    "body line {line}: element '{}' row {row} property '{}': '{t}' is not a valid {}",
                    def.name,
                    pd.name,
                    ty.ply_name()
                ))
            };
            match pd.kind {
                PropKind::Scalar(t) => {
                    let line = tok.lineno;
                    let s = tok.next(r)?.ok_or_else(|| truncated(def, row))?;
                    if !scalar_mut(p).push_token(s) {
                        let s = s.to_string();
                        return Err(bad(&s, t, line.max(tok.lineno)));
                    }
                }
                PropKind::List(ct, it) => {
                    let s = tok.next(r)?.ok_or_else(|| truncated(def, row))?;
                    if s.parse::<i64>().is_ok_and(|n| n < 0) {
                        let s = s.to_string();
                        return Err(Error::invalid(format!(
                            "body line {}: element '{}' row {row}: list '{}' has negative count {s}",
                            tok.lineno, def.name, pd.name
                        )));
                    }
                    let mut c = Column::empty(ct);
                    if !c.push_token(s) {
                        let s = s.to_string();
                        return Err(bad(&s, ct, tok.lineno));
                    }
                    let n = count_value(&c);
                    let PropData::List(l) = p else { unreachable!() };
                    for _ in 0..n {
                        let s = tok.next(r)?.ok_or_else(|| truncated(def, row))?;
                        if !l.items.push_token(s) {
                            let s = s.to_string();
                            return Err(bad(&s, it, tok.lineno));
                        }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// `read_ascii_lines` on `text` (a header and its body), for its
    /// first element.
    fn lines_of(text: &str) -> Option<(Element, usize)> {
        let mut r = std::io::Cursor::new(text.as_bytes());
        let h = read_header(&mut r).expect("a header");
        let lay = layout(&h.elements[0], &roles(&h));
        let body = &text.as_bytes()[r.position() as usize..];
        read_ascii_lines(body, &h.elements[0], &lay)
    }

    #[test]
    fn rows_one_a_line_are_read_in_chunks_and_others_left_to_the_row_reader() {
        let head = |n: usize| {
            format!("ply\nformat ascii 1.0\nelement face {n}\nproperty list uchar int v\nproperty float x\nend_header\n")
        };
        // Rows of 0 to 3 items over several chunks, then bytes that are
        // not the element's.
        let n = 300_000;
        let mut text = head(n);
        for i in 0..n {
            let items: Vec<String> = (0..i % 4).map(|k| (i + k).to_string()).collect();
            text += &format!("{} {} {}.5\n", i % 4, items.join(" "), i);
        }
        assert!(text.len() > 4 * ASCII_TASK_BYTES);
        let rows = text.len();
        text += "after\n";
        let (el, bytes) = lines_of(&text).expect("one row a line");
        assert_eq!((bytes, el.len()), (rows - head(n).len(), n));
        let AttrData::List(l) = &el.attr("v").expect("the list").data else {
            panic!("a list")
        };
        assert_eq!(l.offsets.len(), n + 1);
        for i in [0, 1, 2, 3, n / 2 + 1, n - 1] {
            let got: Vec<f64> = (l.offsets[i]..l.offsets[i + 1])
                .map(|k| l.items.get_f64(k))
                .collect();
            let want: Vec<f64> = (0..i % 4).map(|k| (i + k) as f64).collect();
            assert_eq!(got, want, "row {i}");
        }
        let x = el.attr("x").expect("x").components()[0]
            .column()
            .get_f64(n - 1);
        assert_eq!(x, (n - 1) as f64 + 0.5);
        // Laid out otherwise, or wrong: not here.
        for body in [
            "1 7 1\n2 7\n8 2\n",
            "1 7 1 2 7 8 2\n\n",
            "1 7 1\n\n2 7 8 2\n",
            "1 7 1\n2 7 8 x\n",
            "1 7 1\n2 7 8\n",
            "1 7 1\n-1 2\n",
            "1 7 1\n2 7 8 2",
        ] {
            assert!(lines_of(&(head(2) + body)).is_none(), "{body:?}");
        }
        assert!(lines_of(&(head(2) + "1 7 1\r\n2 7 8 2 \n")).is_some());
        // A count spelled as a float reads as the count type reads it; a
        // count too large for it, or a byte that is not ASCII, is left to
        // the row reader.
        let (el, _) = lines_of(&(head(2) + "1 7 1\n2.0 7 8 2\n")).expect("2.0 is 2");
        let AttrData::List(l) = &el.attr("v").expect("the list").data else {
            panic!("a list")
        };
        assert_eq!(l.offsets, [0, 1, 3]);
        let big: String = (0..300).map(|_| " 1").collect();
        assert!(lines_of(&(head(2) + &format!("300{big} 1\n0 1\n"))).is_none());
        assert!(lines_of(&(head(2) + "1 7 1\n2 7 8 2\u{a0}\n")).is_none());
    }

    #[test]
    fn list_counts_read_as_the_count_type_reads_them() {
        use crate::column::ScalarType::*;
        for ct in [I8, U8, I16, U16, I32, U32, F32, F64] {
            for s in [
                "0",
                "3",
                "+3",
                "-0",
                "-1",
                "127",
                "128",
                "255",
                "256",
                "32767",
                "65535",
                "65536",
                "2147483647",
                "4294967295",
                "4294967296",
                "3.0",
                "3.5",
                "1e2",
                "x",
                "",
            ] {
                let mut c = Column::empty(ct);
                let want = if s.parse::<i64>().is_ok_and(|n| n < 0) || !c.push_token(s) {
                    None
                } else {
                    Some(count_value(&c) as usize)
                };
                assert_eq!(list_count(ct, s), want, "{ct:?} {s:?}");
            }
        }
    }
}
