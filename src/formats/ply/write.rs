//! PLY writing: binary little-endian by default, big-endian and ASCII on
//! request.
//!
//! Elements without list attributes are written column by column into
//! 1 MiB row chunks (undecoded properties are copied from the input's bytes
//! when the byte order matches); elements with lists and ASCII bodies row
//! by row.

use std::io::Write;

use super::header::{
    ascii_json, component_names, default_role, detail_comment, is_tag_comment, Encoding, TAG,
};
use crate::cloud::{AttrData, Cloud, Element};
use crate::column::{Column, RawBlock, ScalarType, Values};
use crate::error::{Error, Result};

/// Writes `cloud` as PLY with body encoding `enc`.
pub fn write_ply<W: Write + ?Sized>(w: &mut W, cloud: &Cloud, enc: Encoding) -> Result<()> {
    w.write_all(header_text(cloud, enc)?.as_bytes())?;
    for el in &cloud.elements {
        write_body(w, el, enc)?;
    }
    Ok(())
}

/// Writes the rows of `el` in encoding `enc`: a whole element's body, or
/// (called again with the next rows) part of one, for a writer that
/// streams rows under a header written with [`header_text_with`].
pub fn write_body<W: Write + ?Sized>(w: &mut W, el: &Element, enc: Encoding) -> Result<()> {
    let big = enc == Encoding::BinaryBe;
    let has_lists = el
        .attrs()
        .iter()
        .any(|a| matches!(a.data, AttrData::List(_)));
    match enc {
        Encoding::Ascii => write_rows(w, el, None),
        _ if has_lists => write_rows(w, el, Some(big)),
        _ => write_fixed(w, el, big),
    }
}

fn check_name(what: &str, s: &str) -> Result<()> {
    if s.is_empty() || s.chars().any(|c| c.is_whitespace() || c.is_control()) {
        return Err(Error::invalid(format!(
            "{what} name '{s}' cannot be written to PLY (empty or contains whitespace)"
        )));
    }
    Ok(())
}

fn check_line(what: &str, s: &str) -> Result<()> {
    if s.contains(['\n', '\r']) {
        return Err(Error::invalid(format!(
            "{what} '{s}' contains a line break"
        )));
    }
    Ok(())
}

/// The header text, `ply` to `end_header\n` inclusive.
pub fn header_text(cloud: &Cloud, enc: Encoding) -> Result<String> {
    header_text_with(cloud, enc, |_, el| el.len() as u64)
}

/// The header text, element `i`'s row count `rows(i, element)`: for a
/// writer that streams the rows afterwards (the cloud's elements then
/// hold no rows, only the attributes' names and types).
pub fn header_text_with(
    cloud: &Cloud,
    enc: Encoding,
    rows: impl Fn(usize, &Element) -> u64,
) -> Result<String> {
    let mut h = format!("ply\nformat {} 1.0\n", enc.keyword());
    for c in &cloud.comments {
        check_line("comment", c)?;
        if is_tag_comment(c) {
            // Would read back as the toolkit's own line: carried quoted.
            h += &format!("comment {TAG} comment {}\n", ascii_json(c));
        } else {
            h += &format!("comment {c}\n");
        }
    }
    for c in &cloud.obj_info {
        check_line("obj_info", c)?;
        h += &format!("obj_info {c}\n");
    }
    for el in &cloud.elements {
        for a in el.attrs() {
            if let Some(role) = a.role() {
                if default_role(&a.name, role) != role {
                    h += &format!(
                        "comment {TAG} role {} {} {}\n",
                        el.name,
                        a.name,
                        role.name()
                    );
                }
            }
        }
    }
    for d in &cloud.detail {
        check_name("detail attribute", &d.name)?;
        h += &format!("comment {}\n", detail_comment(d));
    }
    for (i, el) in cloud.elements.iter().enumerate() {
        check_name("element", &el.name)?;
        h += &format!("element {} {}\n", el.name, rows(i, el));
        for a in el.attrs() {
            check_name("attribute", &a.name)?;
            match &a.data {
                AttrData::Scalar(v) => h += &format!("property {} {}\n", v.ty().ply_name(), a.name),
                AttrData::Vec3(role, c) => {
                    for (v, n) in c.iter().zip(component_names(&a.name, *role)) {
                        h += &format!("property {} {n}\n", v.ty().ply_name());
                    }
                }
                AttrData::List(l) => {
                    h += &format!(
                        "property list {} {} {}\n",
                        l.count_ty.ply_name(),
                        l.items.ty().ply_name(),
                        a.name
                    )
                }
            }
        }
    }
    h += "end_header\n";
    Ok(h)
}

const CHUNK_BYTES: usize = 1 << 20;

/// Bytes copied from one raw block into every row: consecutive in the
/// input's record and in the output's row (neighbouring properties
/// merged).
struct Span<'a> {
    block: &'a RawBlock,
    /// Offset in the input's record, offset in the output's row, length.
    ro: usize,
    off: usize,
    size: usize,
}

/// Fixed-size rows: columns scattered into row chunks. Undecoded
/// properties are copied as spans of neighbouring properties, a span of a
/// common size as a fixed-size copy (a `memmove` call per property and
/// row dominated the write of a stage that passes most attributes
/// through), a span that is the whole row as one copy.
fn write_fixed<W: Write + ?Sized>(w: &mut W, el: &Element, big: bool) -> Result<()> {
    let comps: Vec<&Values> = el.attrs().iter().flat_map(|a| a.components()).collect();
    let mut stride = 0;
    let mut spans: Vec<Span> = Vec::new();
    let mut decoded: Vec<(&Values, usize)> = Vec::new();
    for v in &comps {
        let (off, size) = (stride, v.ty().size());
        stride += size;
        match v.raw() {
            Some(raw) if raw.block.big_endian == big => {
                if let Some(last) = spans.last_mut() {
                    if std::ptr::eq(last.block, &*raw.block)
                        && last.ro + last.size == raw.offset
                        && last.off + last.size == off
                    {
                        last.size += size;
                        continue;
                    }
                }
                spans.push(Span {
                    block: &raw.block,
                    ro: raw.offset,
                    off,
                    size,
                });
            }
            _ => decoded.push((v, off)),
        }
    }
    if stride == 0 {
        return Ok(());
    }
    let chunk = (CHUNK_BYTES / stride).max(1);
    let mut buf = vec![0u8; chunk.min(el.len()) * stride];
    let mut start = 0;
    while start < el.len() {
        let n = chunk.min(el.len() - start);
        let out = &mut buf[..n * stride];
        for sp in &spans {
            let rs = sp.block.stride;
            let src = &sp.block.bytes[start * rs..(start + n) * rs];
            copy_span(src, rs, sp.ro, out, stride, sp.off, sp.size);
        }
        for &(v, off) in &decoded {
            v.column()
                .scatter_into(start..start + n, out, stride, off, big);
        }
        w.write_all(out)?;
        start += n;
    }
    Ok(())
}

/// Copies bytes `ro..ro + size` of each record of `src` (records of `rs`
/// bytes) to bytes `off..off + size` of each row of `out` (rows of
/// `stride` bytes).
fn copy_span(
    src: &[u8],
    rs: usize,
    ro: usize,
    out: &mut [u8],
    stride: usize,
    off: usize,
    size: usize,
) {
    if size == rs && size == stride {
        out.copy_from_slice(src);
        return;
    }
    macro_rules! rows {
        ($k:expr) => {
            for (s, d) in src.chunks_exact(rs).zip(out.chunks_exact_mut(stride)) {
                d[off..off + $k].copy_from_slice(&s[ro..ro + $k]);
            }
        };
    }
    // (A constant length is copied inline; a variable one calls memmove.)
    match size {
        1 => rows!(1),
        2 => rows!(2),
        4 => rows!(4),
        8 => rows!(8),
        12 => rows!(12),
        16 => rows!(16),
        24 => rows!(24),
        _ => rows!(size),
    }
}

/// Encodes a list length as the list's count type.
fn count_column(n: usize, ct: ScalarType, list: &str) -> Result<Column> {
    let max = match ct {
        ScalarType::I8 => i8::MAX as u64,
        ScalarType::U8 => u8::MAX as u64,
        ScalarType::I16 => i16::MAX as u64,
        ScalarType::U16 => u16::MAX as u64,
        ScalarType::I32 => i32::MAX as u64,
        _ => u32::MAX as u64,
    };
    if n as u64 > max {
        return Err(Error::invalid(format!(
            "list '{list}' has a row of {n} items, more than its count type {} holds",
            ct.ply_name()
        )));
    }
    let mut c = Column::empty(ct);
    c.push_token(&n.to_string());
    Ok(c)
}

/// Row by row: ASCII when `big` is `None`, else binary.
fn write_rows<W: Write + ?Sized>(w: &mut W, el: &Element, big: Option<bool>) -> Result<()> {
    enum Part<'a> {
        Col(&'a Column),
        List(&'a crate::cloud::ListColumn, &'a str),
    }
    let parts: Vec<Part> = el
        .attrs()
        .iter()
        .flat_map(|a| match &a.data {
            AttrData::List(l) => vec![Part::List(l, &a.name)],
            _ => a
                .components()
                .iter()
                .map(|v| Part::Col(v.column()))
                .collect(),
        })
        .collect();
    let mut text = String::new();
    let mut bin: Vec<u8> = Vec::new();
    let mut tmp = [0u8; 8];
    let mut put = |c: &Column, i: usize, text: &mut String, bin: &mut Vec<u8>| match big {
        None => {
            if !text.is_empty() {
                text.push(' ');
            }
            c.fmt_ascii(i, text);
        }
        Some(big) => {
            let n = c.ty().size();
            c.write_bin(i, &mut tmp[..n], big);
            bin.extend_from_slice(&tmp[..n]);
        }
    };
    for row in 0..el.len() {
        for p in &parts {
            match p {
                Part::Col(c) => put(c, row, &mut text, &mut bin),
                Part::List(l, name) => {
                    let r = l.range(row);
                    let count = count_column(r.len(), l.count_ty, name)?;
                    put(&count, 0, &mut text, &mut bin);
                    for i in r {
                        put(&l.items, i, &mut text, &mut bin);
                    }
                }
            }
        }
        if big.is_none() {
            text.push('\n');
            w.write_all(text.as_bytes())?;
            text.clear();
        } else if bin.len() >= CHUNK_BYTES {
            w.write_all(&bin)?;
            bin.clear();
        }
    }
    w.write_all(&bin)?;
    Ok(())
}
