//! ASCII bodies: one row a line parsed in parallel from a file read whole,
//! or token by token, row by row, with line numbers for the errors.

use std::io::{BufRead, Read};

use super::{assemble, count_value, empty_props, scalar_mut, truncated, PropData, Source};
use crate::cloud::{Element, ListColumn};
use crate::column::{Column, ScalarType, Values};
use crate::error::{Error, Result};
use crate::formats::ply::header::{ElementDef, Layout, PropKind};

/// Bytes of ASCII body parsed by one task of `read_ascii_lines`, about.
const ASCII_TASK_BYTES: usize = 1 << 20;

/// An ASCII element read from a file read whole by `read_ascii_lines`, when
/// the reader stands at the start of a line; `None` leaves the reader
/// where it was.
pub(super) fn ascii_in_parallel<R: Source>(
    r: &mut R,
    tok: &mut Tokens,
    def: &ElementDef,
    lay: &[Layout],
) -> Option<Element> {
    if !tok.line[tok.pos..].trim().is_empty() {
        return None;
    }
    let (el, bytes) = {
        let (map, pos) = r.whole()?;
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
    let end = end_of_lines(body, count)?;
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
    // Joined property by property, each in parallel: a serial join
    // copied (and faulted in) the whole element on one core.
    let mut parts: Vec<std::vec::IntoIter<PropData>> =
        parts.into_iter().map(Vec::into_iter).collect();
    let props: Vec<PropData> = def
        .props
        .iter()
        .map(|pd| {
            let mine: Vec<PropData> = parts
                .iter_mut()
                .map(|p| p.next().expect("a part has every property"))
                .collect();
            match pd.kind {
                PropKind::Scalar(t) => PropData::Values(Values::owned(Column::concat(
                    t,
                    mine.into_iter().map(|p| p.values().into_column()).collect(),
                ))),
                PropKind::List(ct, it) => {
                    let lists: Vec<ListColumn> = mine.into_iter().map(PropData::list).collect();
                    let mut base = 0;
                    let bases: Vec<usize> = lists
                        .iter()
                        .map(|l| {
                            let b = base;
                            base += l.items.len();
                            b
                        })
                        .collect();
                    let mut offsets: Vec<Vec<usize>> = vec![vec![0]];
                    offsets.extend(
                        lists
                            .par_iter()
                            .zip(bases)
                            .map(|(l, b)| l.offsets[1..].iter().map(|o| o + b).collect())
                            .collect::<Vec<Vec<usize>>>(),
                    );
                    let mut out = ListColumn::new(ct, it);
                    out.offsets = crate::disjoint::concat(offsets);
                    out.items = Column::concat(it, lists.into_iter().map(|l| l.items).collect());
                    PropData::List(out)
                }
            }
        })
        .collect();
    let el = assemble(def, lay, props.into_iter().map(Some).collect(), count);
    Some((el, end))
}

/// Just past the `count`-th newline of `body` (`count` at least 1), or
/// `None`: blocks' newlines counted in parallel, a batch at a time (the
/// body may run on far past the element's lines), then the last block's
/// searched: a serial search was a visible part of a large mesh's read.
fn end_of_lines(body: &[u8], count: usize) -> Option<usize> {
    use rayon::prelude::*;
    const BLOCK: usize = 1 << 20;
    const BATCH: usize = 8 * BLOCK;
    let mut seen = 0;
    for (b, batch) in body.chunks(BATCH).enumerate() {
        let counts: Vec<usize> = batch
            .par_chunks(BLOCK)
            .map(|c| memchr::memchr_iter(b'\n', c).count())
            .collect();
        for (k, &c) in counts.iter().enumerate() {
            if seen + c >= count {
                let start = b * BATCH + k * BLOCK;
                let block = &batch[k * BLOCK..((k + 1) * BLOCK).min(batch.len())];
                let i = memchr::memchr_iter(b'\n', block).nth(count - seen - 1)?;
                return Some(start + i + 1);
            }
            seen += c;
        }
    }
    None
}

/// Lines of `def`'s rows, one row each, into columns; `None` at a line
/// that is not exactly one valid row, or at bytes that are not UTF-8
/// (the row-by-row reader then says where). A character that is not
/// ASCII falls inside a token (tokens end at ASCII whitespace only), and
/// no number parses with one.
fn ascii_lines(text: &[u8], def: &ElementDef) -> Option<Vec<PropData>> {
    // Checked once for the chunk: a check per token was a large part of
    // the parse.
    let text = std::str::from_utf8(text).ok()?;
    let mut props = empty_props(def);
    // One pass over the bytes finds the tokens and the lines' ends
    // together (every chunk ends with its last line's newline).
    let mut tokens = LineTokens { text, pos: 0 };
    while tokens.pos < text.len() {
        for (pd, p) in def.props.iter().zip(props.iter_mut()) {
            match pd.kind {
                PropKind::Scalar(_) => {
                    if !scalar_mut(p).push_token(tokens.next()?) {
                        return None;
                    }
                }
                PropKind::List(ct, _) => {
                    let n = list_count(ct, tokens.next()?)?;
                    let PropData::List(l) = p else { unreachable!() };
                    for _ in 0..n {
                        if !l.items.push_token(tokens.next()?) {
                            return None;
                        }
                    }
                    l.offsets.push(l.items.len());
                }
            }
        }
        if !tokens.end_line() {
            return None;
        }
    }
    Some(props)
}

/// ASCII whitespace that separates tokens on a line (all but the
/// newline, which ends the line).
fn blank(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | b'\x0c')
}

/// The tokens of a chunk's lines, a line at a time: `next` gives the
/// current line's tokens, then `None` at its newline, where `end_line`
/// moves on to the next line.
struct LineTokens<'a> {
    text: &'a str,
    pos: usize,
}

impl<'a> LineTokens<'a> {
    fn next(&mut self) -> Option<&'a str> {
        let b = self.text.as_bytes();
        let mut i = self.pos;
        while i < b.len() && blank(b[i]) {
            i += 1;
        }
        let start = i;
        while i < b.len() && !blank(b[i]) && b[i] != b'\n' {
            i += 1;
        }
        self.pos = i;
        // ASCII whitespace ends a character: both cuts fall between
        // characters.
        (i > start).then(|| &self.text[start..i])
    }

    /// Past the current line's newline (or the end of the text): false
    /// when a token is left on the line.
    fn end_line(&mut self) -> bool {
        let b = self.text.as_bytes();
        let mut i = self.pos;
        while i < b.len() && blank(b[i]) {
            i += 1;
        }
        if i < b.len() && b[i] != b'\n' {
            return false;
        }
        self.pos = i + 1;
        true
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
        if let Some(n) = crate::column::plain_int(s) {
            return (0..=max as i64).contains(&n).then_some(n as usize);
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
pub(super) struct Tokens {
    line: String,
    pos: usize,
    pub(super) lineno: usize,
    raw: Vec<u8>,
}

impl Tokens {
    pub(super) fn new() -> Self {
        Tokens {
            line: String::new(),
            pos: 0,
            lineno: 0,
            raw: Vec::new(),
        }
    }

    /// The next token, `None` at the end of input.
    pub(super) fn next<R: BufRead>(&mut self, r: &mut R) -> Result<Option<&str>> {
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

pub(super) fn read_ascii<R: BufRead>(
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
                // (A float's only invalid number is one past its range.)
                let past = if ty.is_float() && t.parse::<f64>().is_ok() {
                    " (past its range)"
                } else {
                    ""
                };
                Error::invalid(format!(
                    "body line {line}: element '{}' row {row} property '{}': '{t}' is not a valid {}{past}",
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
                    let Some(n) = list_count(ct, s) else {
                        let s = s.to_string();
                        if s.parse::<i64>().is_ok_and(|n| n < 0) {
                            return Err(Error::invalid(format!(
                                "body line {}: element '{}' row {row}: list '{}' has negative count {s}",
                                tok.lineno, def.name, pd.name
                            )));
                        }
                        return Err(bad(&s, ct, tok.lineno));
                    };
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
    use crate::cloud::AttrData;
    use crate::formats::ply::header::{layout, read_header, roles};

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
    fn line_ends_counted_in_parallel_match_a_serial_search() {
        // Lines of 1 to 40 bytes over two batches of blocks and more.
        let mut body = Vec::new();
        let mut x = 7u32;
        while body.len() < 17 << 20 {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            body.extend(std::iter::repeat_n(b'a', (x >> 27) as usize));
            body.push(b'\n');
        }
        body.extend(b"no newline after");
        let ends: Vec<usize> = memchr::memchr_iter(b'\n', &body).map(|i| i + 1).collect();
        let n = ends.len();
        // Lines ending on each side of the first block and batch bounds.
        let at = |b: usize| ends.partition_point(|&e| e <= b);
        for count in [
            1,
            2,
            n / 3,
            at(1 << 20),
            at(1 << 20) + 1,
            at(8 << 20),
            at(8 << 20) + 1,
            n - 1,
            n,
        ] {
            assert_eq!(
                end_of_lines(&body, count),
                Some(ends[count - 1]),
                "line {count}"
            );
        }
        assert_eq!(end_of_lines(&body, n + 1), None);
        assert_eq!(end_of_lines(b"", 1), None);
        assert_eq!(end_of_lines(b"\n", 1), Some(1));
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
