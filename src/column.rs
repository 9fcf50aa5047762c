//! Typed columns: the scalar types a point-cloud file can hold, a column of
//! one of them, and lazily decoded columns that still sit in a file's bytes.
//!
//! The scalar types are PLY's eight (`char` .. `double`); every on-disk
//! format maps into them. A [`Values`] is a column that may not be decoded
//! yet: a reader keeps the raw rows of an element and decodes a property
//! only when somebody asks for it, so a stage that needs `P` and `N` does
//! not pay for fifty other attributes, which still pass through to the
//! output byte for byte.

use std::fmt::Write as _;
use std::sync::{Arc, OnceLock};

/// One of PLY's scalar types.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ScalarType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl ScalarType {
    /// Size in bytes of one value.
    pub fn size(self) -> usize {
        match self {
            ScalarType::I8 | ScalarType::U8 => 1,
            ScalarType::I16 | ScalarType::U16 => 2,
            ScalarType::I32 | ScalarType::U32 | ScalarType::F32 => 4,
            ScalarType::F64 => 8,
        }
    }

    /// The PLY name written in headers (`float`, `uchar`, ...).
    pub fn ply_name(self) -> &'static str {
        match self {
            ScalarType::I8 => "char",
            ScalarType::U8 => "uchar",
            ScalarType::I16 => "short",
            ScalarType::U16 => "ushort",
            ScalarType::I32 => "int",
            ScalarType::U32 => "uint",
            ScalarType::F32 => "float",
            ScalarType::F64 => "double",
        }
    }

    /// Parses a PLY type name, both the classic (`float`) and the sized
    /// (`float32`) spellings.
    pub fn from_ply_name(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => ScalarType::I8,
            "uchar" | "uint8" => ScalarType::U8,
            "short" | "int16" => ScalarType::I16,
            "ushort" | "uint16" => ScalarType::U16,
            "int" | "int32" => ScalarType::I32,
            "uint" | "uint32" => ScalarType::U32,
            "float" | "float32" => ScalarType::F32,
            "double" | "float64" => ScalarType::F64,
            _ => return None,
        })
    }

    /// True for `float` and `double`.
    pub fn is_float(self) -> bool {
        matches!(self, ScalarType::F32 | ScalarType::F64)
    }

    /// All eight types, in PLY's order.
    pub const ALL: [ScalarType; 8] = [
        ScalarType::I8,
        ScalarType::U8,
        ScalarType::I16,
        ScalarType::U16,
        ScalarType::I32,
        ScalarType::U32,
        ScalarType::F32,
        ScalarType::F64,
    ];
}

/// A Rust type standing for one [`ScalarType`].
pub trait Scalar: Copy + Default + PartialEq + std::fmt::Debug + Send + Sync + 'static {
    /// The matching scalar type.
    const TY: ScalarType;
    /// Reads one value from the first `size` bytes of `b`.
    fn read(b: &[u8], big_endian: bool) -> Self;
    /// Writes one value into the first `size` bytes of `out`.
    fn write(self, out: &mut [u8], big_endian: bool);
    /// The value as f64 (exact for every type but none).
    fn to_f64(self) -> f64;
    /// Parses an ASCII token; `None` when it is not a valid value of the type.
    fn parse(s: &str) -> Option<Self>;
    /// Appends the shortest text that parses back to the same value.
    fn fmt_ascii(self, out: &mut String);
    /// Wraps a vector in a [`Column`].
    fn wrap(v: Vec<Self>) -> Column;
    /// The column's vector when it has this type.
    fn slice(c: &Column) -> Option<&[Self]>;
    /// The column's vector, taken, when it has this type.
    fn take(c: Column) -> Option<Vec<Self>>;
}

/// A token of plain decimal digits (at most 18, with an optional sign)
/// as a number: the common spelling of an integer in ASCII PLY, read
/// without `str::parse`'s generality (a quarter of the time of the
/// dragon's faces went to it); `None` for any other spelling.
pub(crate) fn plain_int(s: &str) -> Option<i64> {
    let b = s.as_bytes();
    let (neg, digits) = match b.first() {
        Some(b'-') => (true, &b[1..]),
        Some(b'+') => (false, &b[1..]),
        _ => (false, b),
    };
    if digits.is_empty() || digits.len() > 18 {
        return None;
    }
    let mut v = 0i64;
    for &c in digits {
        let d = c.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        v = v * 10 + d as i64;
    }
    Some(if neg { -v } else { v })
}

/// A token of plain decimal digits with at most one point and an
/// optional sign (no exponent): the sign, the digits as one integer and
/// how many of them follow the point; `None` for any other spelling or
/// more than 19 digits.
fn plain_decimal(s: &str) -> Option<(bool, u64, usize)> {
    let b = s.as_bytes();
    let (neg, rest) = match b.first() {
        Some(b'-') => (true, &b[1..]),
        Some(b'+') => (false, &b[1..]),
        _ => (false, b),
    };
    let (mut m, mut digits, mut after) = (0u64, 0usize, None);
    for (i, &c) in rest.iter().enumerate() {
        let d = c.wrapping_sub(b'0');
        if d <= 9 {
            m = m.wrapping_mul(10).wrapping_add(d as u64);
            digits += 1;
        } else if c == b'.' && after.is_none() {
            after = Some(i + 1);
        } else {
            return None;
        }
    }
    if digits == 0 || digits > 19 {
        return None;
    }
    Some((neg, m, after.map_or(0, |a| rest.len() - a)))
}

/// Decimal tokens read exactly where the digits and the power of ten are
/// both exact in the type: one correctly rounded division then gives
/// what `str::parse` gives (Clinger's fast path), at a fraction of its
/// time (benches/results/HISTORY.md, "Measurements behind the code").
trait PlainFloat: Sized {
    fn plain(s: &str) -> Option<Self>;
}

impl PlainFloat for f32 {
    fn plain(s: &str) -> Option<f32> {
        const POW: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];
        let (neg, m, k) = plain_decimal(s)?;
        if m > 1 << 24 || k >= POW.len() {
            return None;
        }
        let v = m as f32 / POW[k];
        Some(if neg { -v } else { v })
    }
}

impl PlainFloat for f64 {
    fn plain(s: &str) -> Option<f64> {
        const POW: [f64; 23] = [
            1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
            1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
        ];
        let (neg, m, k) = plain_decimal(s)?;
        if m > 1 << 53 || k >= POW.len() {
            return None;
        }
        let v = m as f64 / POW[k];
        Some(if neg { -v } else { v })
    }
}

macro_rules! impl_scalar {
    ($t:ty, $ty:ident, $is_float:tt) => {
        impl Scalar for $t {
            const TY: ScalarType = ScalarType::$ty;
            #[inline(always)]
            fn read(b: &[u8], big_endian: bool) -> Self {
                const N: usize = std::mem::size_of::<$t>();
                let a: [u8; N] = b[..N].try_into().unwrap();
                if big_endian {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }
            }
            #[inline(always)]
            fn write(self, out: &mut [u8], big_endian: bool) {
                const N: usize = std::mem::size_of::<$t>();
                let a = if big_endian {
                    self.to_be_bytes()
                } else {
                    self.to_le_bytes()
                };
                out[..N].copy_from_slice(&a);
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            fn parse(s: &str) -> Option<Self> {
                impl_scalar!(@parse $t, s, $is_float)
            }
            fn fmt_ascii(self, out: &mut String) {
                impl_scalar!(@fmt self, out, $is_float)
            }
            fn wrap(v: Vec<Self>) -> Column {
                Column::$ty(v)
            }
            fn slice(c: &Column) -> Option<&[Self]> {
                match c {
                    Column::$ty(v) => Some(v),
                    _ => None,
                }
            }
            fn take(c: Column) -> Option<Vec<Self>> {
                match c {
                    Column::$ty(v) => Some(v),
                    _ => None,
                }
            }
        }
    };
    (@parse $t:ty, $s:ident, false) => {{
        // Integers: exact, range-checked. A float spelling of an integer
        // value ("3.0") is accepted, since some writers print every number
        // that way; anything fractional is refused.
        if let Some(v) = plain_int($s) {
            return <$t>::try_from(v).ok();
        }
        if let Ok(v) = $s.parse::<$t>() {
            return Some(v);
        }
        let f: f64 = $s.parse().ok()?;
        if f.fract() == 0.0 && f >= <$t>::MIN as f64 && f <= <$t>::MAX as f64 {
            Some(f as $t)
        } else {
            None
        }
    }};
    (@parse $t:ty, $s:ident, true) => {{
        // A number spelled in digits that the type cannot hold (1e39 as
        // a float) is not a valid value: parsed, it would be an infinity
        // nobody wrote. "inf" and "nan" spelled out stay what they say.
        <$t>::plain($s)
            .or_else(|| $s.parse::<$t>().ok())
            .filter(|v| v.is_finite() || !$s.bytes().any(|b| b.is_ascii_digit()))
    }};
    (@fmt $v:ident, $out:ident, false) => {{
        let _ = write!($out, "{}", $v);
    }};
    (@fmt $v:ident, $out:ident, true) => {{
        // Rust prints the shortest string that round-trips; switch to
        // exponent form for very large or small magnitudes.
        let a = $v.abs();
        if a == 0.0 || !a.is_finite() || (1e-5..1e16).contains(&a) {
            let _ = write!($out, "{}", $v);
        } else {
            let _ = write!($out, "{:e}", $v);
        }
    }};
}

impl_scalar!(i8, I8, false);
impl_scalar!(u8, U8, false);
impl_scalar!(i16, I16, false);
impl_scalar!(u16, U16, false);
impl_scalar!(i32, I32, false);
impl_scalar!(u32, U32, false);
impl_scalar!(f32, F32, true);
impl_scalar!(f64, F64, true);

/// A decoded column of one scalar type.
#[derive(Clone, Debug, PartialEq)]
pub enum Column {
    I8(Vec<i8>),
    U8(Vec<u8>),
    I16(Vec<i16>),
    U16(Vec<u16>),
    I32(Vec<i32>),
    U32(Vec<u32>),
    F32(Vec<f32>),
    F64(Vec<f64>),
}

/// Runs `$body` with `$v` bound to the column's typed vector.
#[macro_export]
#[doc(hidden)]
macro_rules! with_column {
    ($c:expr, $v:ident => $body:expr) => {
        match $c {
            $crate::column::Column::I8($v) => $body,
            $crate::column::Column::U8($v) => $body,
            $crate::column::Column::I16($v) => $body,
            $crate::column::Column::U16($v) => $body,
            $crate::column::Column::I32($v) => $body,
            $crate::column::Column::U32($v) => $body,
            $crate::column::Column::F32($v) => $body,
            $crate::column::Column::F64($v) => $body,
        }
    };
}

impl Column {
    /// An empty column of type `ty`.
    pub fn empty(ty: ScalarType) -> Self {
        match ty {
            ScalarType::I8 => Column::I8(Vec::new()),
            ScalarType::U8 => Column::U8(Vec::new()),
            ScalarType::I16 => Column::I16(Vec::new()),
            ScalarType::U16 => Column::U16(Vec::new()),
            ScalarType::I32 => Column::I32(Vec::new()),
            ScalarType::U32 => Column::U32(Vec::new()),
            ScalarType::F32 => Column::F32(Vec::new()),
            ScalarType::F64 => Column::F64(Vec::new()),
        }
    }

    /// The column's scalar type.
    pub fn ty(&self) -> ScalarType {
        match self {
            Column::I8(_) => ScalarType::I8,
            Column::U8(_) => ScalarType::U8,
            Column::I16(_) => ScalarType::I16,
            Column::U16(_) => ScalarType::U16,
            Column::I32(_) => ScalarType::I32,
            Column::U32(_) => ScalarType::U32,
            Column::F32(_) => ScalarType::F32,
            Column::F64(_) => ScalarType::F64,
        }
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        with_column!(self, v => v.len())
    }

    /// True when there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Value `i` as f64.
    #[inline]
    pub fn get_f64(&self, i: usize) -> f64 {
        with_column!(self, v => v[i].to_f64())
    }

    /// Every value as f64.
    pub fn to_f64_vec(&self) -> Vec<f64> {
        match self {
            Column::F64(v) => v.clone(),
            _ => with_column!(self, v => v.iter().map(|x| x.to_f64()).collect()),
        }
    }

    /// Every value as f32 (rounded when the column is f64).
    pub fn to_f32_vec(&self) -> Vec<f32> {
        match self {
            Column::F32(v) => v.clone(),
            _ => with_column!(self, v => v.iter().map(|x| x.to_f64() as f32).collect()),
        }
    }

    /// Appends the values `rows` of a fixed-stride record block, reading the
    /// property at byte `offset` of each record.
    pub fn extend_from_records(&mut self, records: &[u8], stride: usize, offset: usize, big: bool) {
        fn ext<T: Scalar>(v: &mut Vec<T>, rec: &[u8], stride: usize, off: usize, big: bool) {
            let n = std::mem::size_of::<T>();
            v.extend(
                rec.chunks_exact(stride)
                    .map(|r| T::read(&r[off..off + n], big)),
            );
        }
        with_column!(self, v => ext(v, records, stride, offset, big))
    }

    /// Reserves room for `n` more values.
    pub fn reserve(&mut self, n: usize) {
        with_column!(self, v => v.reserve(n))
    }

    /// Appends one value decoded from `b`.
    pub fn push_bytes(&mut self, b: &[u8], big: bool) {
        with_column!(self, v => v.push(Scalar::read(b, big)))
    }

    /// Columns of type `ty` one after another, copied in parallel (a
    /// serial join of a large file's parts left a core idle).
    pub fn concat(ty: ScalarType, parts: Vec<Column>) -> Column {
        fn cat<T: Scalar>(parts: Vec<Column>) -> Column {
            T::wrap(crate::disjoint::concat(
                parts
                    .into_iter()
                    .map(|c| T::take(c).expect("columns of one type"))
                    .collect(),
            ))
        }
        match ty {
            ScalarType::I8 => cat::<i8>(parts),
            ScalarType::U8 => cat::<u8>(parts),
            ScalarType::I16 => cat::<i16>(parts),
            ScalarType::U16 => cat::<u16>(parts),
            ScalarType::I32 => cat::<i32>(parts),
            ScalarType::U32 => cat::<u32>(parts),
            ScalarType::F32 => cat::<f32>(parts),
            ScalarType::F64 => cat::<f64>(parts),
        }
    }

    /// Appends one value parsed from an ASCII token; false when invalid.
    pub fn push_token(&mut self, tok: &str) -> bool {
        fn push<T: Scalar>(v: &mut Vec<T>, tok: &str) -> bool {
            match T::parse(tok) {
                Some(x) => {
                    v.push(x);
                    true
                }
                None => false,
            }
        }
        with_column!(self, v => push(v, tok))
    }

    /// Writes value `i` in binary into `out`.
    #[inline]
    pub fn write_bin(&self, i: usize, out: &mut [u8], big: bool) {
        with_column!(self, v => v[i].write(out, big))
    }

    /// Appends value `i` as ASCII text.
    #[inline]
    pub fn fmt_ascii(&self, i: usize, out: &mut String) {
        with_column!(self, v => v[i].fmt_ascii(out))
    }

    /// Writes every value into record slots of `stride` bytes at `offset`.
    pub fn scatter_into(
        &self,
        rows: std::ops::Range<usize>,
        out: &mut [u8],
        stride: usize,
        offset: usize,
        big: bool,
    ) {
        fn sc<T: Scalar>(v: &[T], out: &mut [u8], stride: usize, off: usize, big: bool) {
            let n = std::mem::size_of::<T>();
            for (x, rec) in v.iter().zip(out.chunks_exact_mut(stride)) {
                x.write(&mut rec[off..off + n], big);
            }
        }
        with_column!(self, v => sc(&v[rows], out, stride, offset, big))
    }

    /// The values at `idx`, in that order (a gather).
    pub fn gather(&self, idx: &[usize]) -> Column {
        with_column!(self, v => Scalar::wrap(idx.iter().map(|&i| v[i]).collect()))
    }

    /// Values taken from several columns of this one's type: value `k`
    /// is value `idx[k].1` of `cols[idx[k].0]`. Panics when a column is
    /// of another type (callers compare the element's schemas first).
    pub fn gather_from(cols: &[&Column], idx: &[(u32, u32)]) -> Column {
        fn g<T: Scalar>(cols: &[&Column], idx: &[(u32, u32)]) -> Column {
            let s: Vec<&[T]> = cols
                .iter()
                .map(|c| c.as_slice::<T>().expect("columns of one type"))
                .collect();
            T::wrap(
                idx.iter()
                    .map(|&(p, r)| s[p as usize][r as usize])
                    .collect(),
            )
        }
        match cols[0].ty() {
            ScalarType::I8 => g::<i8>(cols, idx),
            ScalarType::U8 => g::<u8>(cols, idx),
            ScalarType::I16 => g::<i16>(cols, idx),
            ScalarType::U16 => g::<u16>(cols, idx),
            ScalarType::I32 => g::<i32>(cols, idx),
            ScalarType::U32 => g::<u32>(cols, idx),
            ScalarType::F32 => g::<f32>(cols, idx),
            ScalarType::F64 => g::<f64>(cols, idx),
        }
    }

    /// Typed slice access.
    pub fn as_slice<T: Scalar>(&self) -> Option<&[T]> {
        T::slice(self)
    }
}

/// Bytes read into memory: owned, or a range of a whole file's buffer
/// that other columns share.
#[derive(Debug)]
pub enum Bytes {
    Owned(Vec<u8>),
    Shared {
        buf: Arc<Vec<u8>>,
        start: usize,
        len: usize,
    },
}

impl std::ops::Deref for Bytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        match self {
            Bytes::Owned(v) => v,
            Bytes::Shared { buf, start, len } => &buf[*start..*start + *len],
        }
    }
}

/// The raw records of one fixed-stride element as read from a binary file.
#[derive(Debug)]
pub struct RawBlock {
    /// `rows * stride` bytes.
    pub bytes: Bytes,
    /// Bytes per record.
    pub stride: usize,
    /// True when the values are big-endian.
    pub big_endian: bool,
}

/// A property still in its file bytes: a block and the byte offset in a record.
#[derive(Clone, Debug)]
pub struct RawRef {
    pub block: Arc<RawBlock>,
    pub offset: usize,
}

/// A column that is decoded on first use.
///
/// Either owned (decoded) values, or a reference to a property inside a
/// [`RawBlock`], decoded at most once when read. Writers copy undecoded
/// raw bytes straight through when the byte order matches.
#[derive(Debug)]
pub struct Values {
    ty: ScalarType,
    raw: Option<RawRef>,
    col: OnceLock<Column>,
}

impl Clone for Values {
    fn clone(&self) -> Self {
        let col = OnceLock::new();
        if let Some(c) = self.col.get() {
            let _ = col.set(c.clone());
        }
        Values {
            ty: self.ty,
            raw: self.raw.clone(),
            col,
        }
    }
}

impl PartialEq for Values {
    fn eq(&self, other: &Self) -> bool {
        self.column() == other.column()
    }
}

impl From<Column> for Values {
    fn from(c: Column) -> Self {
        Values::owned(c)
    }
}

impl Values {
    /// Decoded values.
    pub fn owned(c: Column) -> Self {
        let ty = c.ty();
        let col = OnceLock::new();
        let _ = col.set(c);
        Values { ty, raw: None, col }
    }

    /// A property of a raw block, of type `ty`, decoded on first use.
    pub fn lazy(ty: ScalarType, raw: RawRef) -> Self {
        Values {
            ty,
            raw: Some(raw),
            col: OnceLock::new(),
        }
    }

    /// The scalar type.
    pub fn ty(&self) -> ScalarType {
        self.ty
    }

    /// True once the values are decoded (always for owned values).
    pub fn is_decoded(&self) -> bool {
        self.col.get().is_some()
    }

    /// The raw reference when the values still live in file bytes.
    pub fn raw(&self) -> Option<&RawRef> {
        self.raw.as_ref()
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        match (self.col.get(), &self.raw) {
            (Some(c), _) => c.len(),
            (None, Some(r)) => r.block.bytes.len() / r.block.stride,
            (None, None) => 0,
        }
    }

    /// True when there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The decoded column (decoding it now if needed).
    pub fn column(&self) -> &Column {
        self.col.get_or_init(|| {
            let raw = self
                .raw
                .as_ref()
                .expect("Values without column has raw bytes");
            let mut c = Column::empty(self.ty);
            let b = &raw.block;
            c.extend_from_records(&b.bytes, b.stride, raw.offset, b.big_endian);
            c
        })
    }

    /// Mutable decoded column; drops the raw reference.
    pub fn column_mut(&mut self) -> &mut Column {
        self.column();
        self.raw = None;
        self.col.get_mut().expect("decoded above")
    }

    /// Consumes into the decoded column.
    pub fn into_column(self) -> Column {
        self.column();
        self.col.into_inner().expect("decoded above")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What an integer token reads as without the plain-digits path:
    /// `str::parse`, else a float spelling of an integer in range.
    fn reference<T: Scalar + std::str::FromStr + TryFrom<i64>>(s: &str) -> Option<T> {
        if let Ok(v) = s.parse::<T>() {
            return Some(v);
        }
        let f: f64 = s.parse().ok()?;
        if f.fract() == 0.0 && f.abs() < 1e18 {
            T::try_from(f as i64).ok()
        } else {
            None
        }
    }

    #[test]
    fn decimal_tokens_read_as_str_parse_reads_them() {
        use rand_core::RngCore;
        let mut g = rand_pcg::Pcg32::new(9, 1);
        let mut tokens: Vec<String> = [
            "0",
            "-0",
            "0.0",
            "-0.0",
            "+1.5",
            ".5",
            "5.",
            ".",
            "-",
            "",
            "1e3",
            "1.5e-3",
            "inf",
            "nan",
            "1..2",
            "0x1",
            "16777216",
            "16777217",
            "9007199254740993",
            "0.1",
            "0.2",
            "0.3",
            "1234567.8",
            "0.0000000001",
            "12345678901234567890",
            "1.0000000000000000000",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        for _ in 0..200_000 {
            let digits = 1 + g.next_u32() as usize % 20;
            let mut t: String = (0..digits)
                .map(|_| char::from(b'0' + (g.next_u32() % 10) as u8))
                .collect();
            let point = g.next_u32() as usize % (digits + 2);
            if point <= digits {
                t.insert(point, '.');
            }
            if g.next_u32().is_multiple_of(2) {
                t.insert(0, '-');
            }
            tokens.push(t);
        }
        for t in &tokens {
            let (a, b) = (f32::parse(t), t.parse::<f32>().ok());
            assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "{t:?} as f32");
            let (a, b) = (f64::parse(t), t.parse::<f64>().ok());
            assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "{t:?} as f64");
        }
    }

    #[test]
    fn integer_tokens_read_as_str_parse_reads_them() {
        fn check<T>(tokens: &[&str])
        where
            T: Scalar + std::str::FromStr + TryFrom<i64> + PartialEq + std::fmt::Debug,
        {
            for s in tokens {
                assert_eq!(T::parse(s), reference::<T>(s), "{s:?} as {:?}", T::TY);
            }
        }
        let tokens = [
            "0",
            "7",
            "+7",
            "-0",
            "-7",
            "007",
            "-",
            "+",
            "",
            " 1",
            "1 ",
            "1x",
            "x1",
            "127",
            "128",
            "-128",
            "-129",
            "255",
            "256",
            "32767",
            "32768",
            "-32769",
            "65535",
            "65536",
            "2147483647",
            "2147483648",
            "-2147483648",
            "-2147483649",
            "4294967295",
            "4294967296",
            "999999999999999999",
            "9999999999999999999",
            "-999999999999999999",
            "3.0",
            "3.5",
            "1e2",
            "-1e2",
            "٣",
            "+-1",
            "--1",
        ];
        check::<i8>(&tokens);
        check::<u8>(&tokens);
        check::<i16>(&tokens);
        check::<u16>(&tokens);
        check::<i32>(&tokens);
        check::<u32>(&tokens);
    }
}
