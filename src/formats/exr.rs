//! OpenEXR point clouds and shade-point images (crate `exr`). The layout
//! is specified in the repository's `formats/EXR.md`.
//!
//! Two layouts, told apart by the `pcsss:points` header attribute:
//!
//! - **Point cloud** (`pcsss:points` present): point `i` is pixel
//!   `(i % width, i / width)` of a `width x height` image, `width =
//!   min(n, 1024)`; pixels past the last point are zero. One channel per
//!   component (`P.x P.y P.z`, `N.x ...`, colours `illum.R illum.G
//!   illum.B`, scalars by name). `pcsss:attributes` records each
//!   attribute's kind, role and PLY type, so a PLY -> EXR -> PLY round trip
//!   gives back the same types; detail attributes are header attributes
//!   `pcsss:detail:<name>` of their own type.
//! - **Shade-point image** (no `pcsss:points`): a renderer's P and N
//!   passes. Every covered pixel (alpha above 0; without alpha, a non-zero
//!   N) is a point that remembers its pixel (`pixel_x`, `pixel_y`) and the
//!   image's windows (details `exr_data_window`, `exr_display_window`), so
//!   that a cloud of shade points is written back as an image of the same
//!   size and data window.

use std::collections::HashMap;
use std::io::{Cursor, Write};

use exr::prelude::{f16, SmallVec};
use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Blocks, Encoding, FlatSamples, Image, ImageAttributes,
    IntegerBounds, Layer, LayerAttributes, LineOrder, ReadChannels, ReadLayers, Text, Vec2,
};

use crate::cloud::{AttrData, Attribute, Cloud, DetailValue, Element, Role, POINTS};
use crate::column::{Column, ScalarType};
use crate::error::{Error, Result};

/// Widest row of a point-cloud image.
pub const WIDTH: usize = 1024;

/// The most pixels a shade-point image written back may have (2^31).
pub const MAX_PIXELS: usize = 1 << 31;

/// Header attribute: the number of points (point-cloud layout).
pub const ATTR_POINTS: &str = "pcsss:points";
/// Header attribute: each attribute's kind, role and type.
pub const ATTR_TYPES: &str = "pcsss:attributes";
/// Header attribute prefix of detail attributes.
pub const ATTR_DETAIL: &str = "pcsss:detail:";
/// Header attribute: the detail attributes' names, in order.
pub const ATTR_DETAIL_ORDER: &str = "pcsss:details";
/// Header attribute: the cloud's free-text comments, one per line.
pub const ATTR_COMMENTS: &str = "pcsss:comments";
/// Header attribute: PLY `obj_info` lines, one per line.
pub const ATTR_OBJ_INFO: &str = "pcsss:obj_info";
/// Detail attributes of a shade-point cloud: the image's windows as
/// `"xmin ymin xmax ymax"` (inclusive, as in OpenEXR).
pub const DATA_WINDOW: &str = "exr_data_window";
pub const DISPLAY_WINDOW: &str = "exr_display_window";
/// Point attributes of a shade-point cloud: its pixel.
pub const PIXEL_X: &str = "pixel_x";
pub const PIXEL_Y: &str = "pixel_y";

/// Compression of the pixel data.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Compression {
    None,
    Rle,
    /// zlib, one scan line a block.
    Zips,
    /// zlib, 16 scan lines a block (the default).
    #[default]
    Zip,
    Piz,
    /// Lossy for 32-bit float channels (rounded to 24 bits).
    Pxr24,
    /// Lossy, compresses half channels only.
    B44,
    B44a,
}

impl Compression {
    pub const NAMES: &'static str = "none, rle, zips, zip, piz, pxr24, b44, b44a";

    fn to_exr(self) -> exr::compression::Compression {
        use exr::compression::Compression as C;
        match self {
            Compression::None => C::Uncompressed,
            Compression::Rle => C::RLE,
            Compression::Zips => C::ZIP1,
            Compression::Zip => C::ZIP16,
            Compression::Piz => C::PIZ,
            Compression::Pxr24 => C::PXR24,
            Compression::B44 => C::B44,
            Compression::B44a => C::B44A,
        }
    }
}

impl std::str::FromStr for Compression {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "none" | "uncompressed" => Compression::None,
            "rle" => Compression::Rle,
            "zips" | "zip1" => Compression::Zips,
            "zip" | "zip16" => Compression::Zip,
            "piz" => Compression::Piz,
            "pxr24" => Compression::Pxr24,
            "b44" => Compression::B44,
            "b44a" => Compression::B44a,
            _ => {
                return Err(format!(
                    "unknown compression '{s}' (one of: {})",
                    Compression::NAMES
                ))
            }
        })
    }
}

/// How a cloud is written as OpenEXR.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExrOptions {
    pub compression: Compression,
    /// Attributes stored as 16-bit half floats (float attributes only).
    pub half: Vec<String>,
}

/// The channel suffixes of a 3-vector attribute with `role`.
fn suffixes(role: Role) -> [&'static str; 3] {
    match role {
        Role::Color => ["R", "G", "B"],
        _ => ["x", "y", "z"],
    }
}

/// Builds an EXR `Text` from any UTF-8 string (OpenEXR strings are bytes).
fn text(s: &str) -> Text {
    Text::from_bytes_unchecked(SmallVec::from_slice(s.as_bytes()))
}

fn from_text(t: &Text) -> String {
    String::from_utf8_lossy(t.bytes()).into_owned()
}

/// One attribute component's values, placed at pixel indices.
fn samples(col: &Column, place: &[usize], pixels: usize, half: bool) -> Vec<FlatSamples> {
    /// Point `i`'s value at pixel `place[i]`, zero elsewhere.
    fn put<T: Copy + Default>(pixels: usize, place: &[usize], f: impl Fn(usize) -> T) -> Vec<T> {
        let mut v = vec![T::default(); pixels];
        for (i, &px) in place.iter().enumerate() {
            v[px] = f(i);
        }
        v
    }
    match col {
        Column::F32(c) if half => vec![FlatSamples::F16(put(pixels, place, |i| {
            f16::from_f32(c[i])
        }))],
        Column::F64(c) if half => vec![FlatSamples::F16(put(pixels, place, |i| {
            f16::from_f64(c[i])
        }))],
        Column::F32(c) => vec![FlatSamples::F32(put(pixels, place, |i| c[i]))],
        // f64: the value rounded to f32 (what other readers show) and its
        // 64 bits in two UINT channels (what this toolkit reads back).
        Column::F64(c) => vec![
            FlatSamples::F32(put(pixels, place, |i| c[i] as f32)),
            FlatSamples::U32(put(pixels, place, |i| (c[i].to_bits() >> 32) as u32)),
            FlatSamples::U32(put(pixels, place, |i| c[i].to_bits() as u32)),
        ],
        Column::U8(c) => vec![FlatSamples::U32(put(pixels, place, |i| c[i] as u32))],
        Column::U16(c) => vec![FlatSamples::U32(put(pixels, place, |i| c[i] as u32))],
        Column::U32(c) => vec![FlatSamples::U32(put(pixels, place, |i| c[i]))],
        Column::I8(c) => vec![FlatSamples::U32(put(pixels, place, |i| c[i] as i32 as u32))],
        Column::I16(c) => vec![FlatSamples::U32(put(pixels, place, |i| c[i] as i32 as u32))],
        Column::I32(c) => vec![FlatSamples::U32(put(pixels, place, |i| c[i] as u32))],
    }
}

/// A detail attribute as an EXR header attribute of its own type.
fn detail_to_exr(v: &DetailValue) -> AttributeValue {
    match v {
        DetailValue::I32(x) => AttributeValue::I32(*x),
        DetailValue::F32(x) => AttributeValue::F32(*x),
        DetailValue::F64(x) => AttributeValue::F64(*x),
        DetailValue::V3F(x) => AttributeValue::FloatVec3((x[0], x[1], x[2])),
        DetailValue::V3D(x) => AttributeValue::Custom {
            kind: Text::from("v3d"),
            bytes: x.iter().flat_map(|c| c.to_le_bytes()).collect(),
        },
        DetailValue::Str(s) => AttributeValue::Text(text(s)),
    }
}

fn detail_from_exr(v: &AttributeValue) -> Option<DetailValue> {
    Some(match v {
        AttributeValue::I32(x) => DetailValue::I32(*x),
        AttributeValue::F32(x) => DetailValue::F32(*x),
        AttributeValue::F64(x) => DetailValue::F64(*x),
        AttributeValue::FloatVec3(x) => DetailValue::V3F([x.0, x.1, x.2]),
        AttributeValue::Custom { kind, bytes } if kind == "v3d" && bytes.len() == 24 => {
            let c =
                |k: usize| f64::from_le_bytes(bytes[8 * k..8 * k + 8].try_into().expect("8 bytes"));
            DetailValue::V3D([c(0), c(1), c(2)])
        }
        AttributeValue::Text(t) => DetailValue::Str(from_text(t)),
        _ => return None,
    })
}

/// Parses `"xmin ymin xmax ymax"` (at most `MAX_PIXELS` pixels).
pub(crate) fn parse_window(name: &str, s: &str) -> Result<IntegerBounds> {
    let v: Vec<i32> = s
        .split_whitespace()
        .map(|t| t.parse::<i32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| Error::invalid(format!("detail '{name}' is '{s}', not four integers")))?;
    match v[..] {
        [x0, y0, x1, y1] if x1 >= x0 && y1 >= y0 => {
            let (w, h) = (x1 as i64 - x0 as i64 + 1, y1 as i64 - y0 as i64 + 1);
            // Never allocate what a detail claims: an image of at most
            // MAX_PIXELS pixels.
            if w.checked_mul(h).is_none_or(|a| a > MAX_PIXELS as i64) {
                return Err(Error::invalid(format!(
                    "detail '{name}' is '{s}': {w} x {h} pixels, more than {MAX_PIXELS}"
                )));
            }
            Ok(IntegerBounds::new(
                Vec2(x0, y0),
                Vec2(w as usize, h as usize),
            ))
        }
        _ => Err(Error::invalid(format!(
            "detail '{name}' is '{s}', not 'xmin ymin xmax ymax'"
        ))),
    }
}

fn window_str(b: IntegerBounds) -> String {
    let max = b.max();
    format!(
        "{} {} {} {}",
        b.position.x(),
        b.position.y(),
        max.x(),
        max.y()
    )
}

/// Writes `cloud` as OpenEXR: a shade-point cloud (with `exr_data_window`
/// and `pixel_x`/`pixel_y`) as its image, any other cloud in the
/// point-cloud layout.
pub fn write_exr<W: Write + ?Sized>(w: &mut W, cloud: &Cloud, opt: &ExrOptions) -> Result<()> {
    for e in &cloud.elements {
        if e.name != POINTS && !e.is_empty() {
            return Err(Error::unsupported(format!(
                "OpenEXR holds points only: element '{}' ({} rows) would be lost (write PLY)",
                e.name,
                e.len()
            )));
        }
    }
    let pts = cloud.points();
    let n = pts.len();
    for h in &opt.half {
        match pts.attr(h) {
            None => return Err(Error::param("--half", format!("no point attribute '{h}'"))),
            Some(a) if !a_is_float(a) => {
                return Err(Error::param(
                    "--half",
                    format!("attribute '{h}' is not a float attribute"),
                ))
            }
            _ => {}
        }
    }
    let image = cloud
        .detail(DATA_WINDOW)
        .filter(|_| pts.has(PIXEL_X) && pts.has(PIXEL_Y));
    // Where each point goes: (width, height, origin, display window, pixel
    // of point i).
    let (size, origin, display, pixel_of): (Vec2<usize>, Vec2<i32>, IntegerBounds, Vec<usize>) =
        match image {
            Some(DetailValue::Str(win)) => {
                let data = parse_window(DATA_WINDOW, win)?;
                let display = match cloud.detail(DISPLAY_WINDOW) {
                    Some(DetailValue::Str(s)) => parse_window(DISPLAY_WINDOW, s)?,
                    _ => data,
                };
                let px = pts.scalar_f64(PIXEL_X)?;
                let py = pts.scalar_f64(PIXEL_Y)?;
                let (x0, y0) = (data.position.x() as f64, data.position.y() as f64);
                let (wd, ht) = (data.size.width(), data.size.height());
                let mut pix = Vec::with_capacity(n);
                for i in 0..n {
                    let (x, y) = (px[i] - x0, py[i] - y0);
                    if !(x >= 0.0 && y >= 0.0 && x < wd as f64 && y < ht as f64) {
                        return Err(Error::invalid(format!(
                            "point {i}: pixel ({}, {}) lies outside the data window {win}",
                            px[i], py[i]
                        )));
                    }
                    pix.push(y as usize * wd + x as usize);
                }
                (data.size, data.position, display, pix)
            }
            Some(_) => {
                return Err(Error::invalid(format!(
                    "detail '{DATA_WINDOW}' is not a string 'xmin ymin xmax ymax'"
                )))
            }
            None => {
                let wd = n.clamp(1, WIDTH);
                let ht = n.div_ceil(wd).max(1);
                let size = Vec2(wd, ht);
                let display = IntegerBounds::new(Vec2(0, 0), size);
                (size, Vec2(0, 0), display, (0..n).collect())
            }
        };
    let pixels = size.area();
    let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::new();
    let mut types = Vec::new();
    let mut push = |name: String, col: &Column, half: bool| {
        let s = samples(col, &pixel_of, pixels, half);
        let mut names = vec![name.clone()];
        if s.len() == 3 {
            names.push(format!("{name}.f64hi"));
            names.push(format!("{name}.f64lo"));
        }
        for (nm, data) in names.into_iter().zip(s) {
            channels.push(AnyChannel::new(text(&nm), data));
        }
    };
    let mut has_alpha = false;
    for a in pts.attrs() {
        if image.is_some() && (a.name == PIXEL_X || a.name == PIXEL_Y) {
            continue;
        }
        let half = opt.half.contains(&a.name);
        match &a.data {
            AttrData::Scalar(v) => {
                has_alpha |= a.name == "A" || a.name == "alpha";
                push(a.name.clone(), v.column(), half);
                types.push(format!("{} scalar - {}", a.name, v.ty().ply_name()));
            }
            AttrData::Vec3(role, cols) => {
                for (c, s) in cols.iter().zip(suffixes(*role)) {
                    push(format!("{}.{s}", a.name), c.column(), half);
                }
                types.push(format!(
                    "{} vec3 {} {}",
                    a.name,
                    role.name(),
                    cols[0].ty().ply_name()
                ));
            }
            AttrData::List(_) => {
                return Err(Error::unsupported(format!(
                    "point attribute '{}' is a list; OpenEXR channels hold one value a pixel (write PLY)",
                    a.name
                )))
            }
        }
    }
    let mut other: HashMap<Text, AttributeValue> = HashMap::new();
    match image {
        None => {
            let count = i32::try_from(n).map_err(|_| {
                Error::unsupported(format!(
                    "{n} points: OpenEXR point clouds hold at most 2^31 - 1"
                ))
            })?;
            other.insert(Text::from(ATTR_POINTS), AttributeValue::I32(count));
        }
        Some(_) => {
            // Coverage, so that the image reads back as the same points.
            if !has_alpha {
                let mut a = vec![0f32; pixels];
                for &p in &pixel_of {
                    a[p] = 1.0;
                }
                channels.push(AnyChannel::new("A", FlatSamples::F32(a)));
            }
        }
    }
    other.insert(
        Text::from(ATTR_TYPES),
        AttributeValue::Text(text(&types.join("; "))),
    );
    for d in &cloud.detail {
        if image.is_some() && (d.name == DATA_WINDOW || d.name == DISPLAY_WINDOW) {
            continue;
        }
        other.insert(
            text(&format!("{ATTR_DETAIL}{}", d.name)),
            detail_to_exr(&d.value),
        );
    }
    let order: Vec<&str> = cloud
        .detail
        .iter()
        .map(|d| d.name.as_str())
        .filter(|n| image.is_none() || (*n != DATA_WINDOW && *n != DISPLAY_WINDOW))
        .collect();
    if !order.is_empty() {
        other.insert(
            Text::from(ATTR_DETAIL_ORDER),
            AttributeValue::Text(text(&order.join(" "))),
        );
    }
    if !cloud.comments.is_empty() {
        other.insert(
            Text::from(ATTR_COMMENTS),
            AttributeValue::Text(text(&cloud.comments.join("\n"))),
        );
    }
    if !cloud.obj_info.is_empty() {
        other.insert(
            Text::from(ATTR_OBJ_INFO),
            AttributeValue::Text(text(&cloud.obj_info.join("\n"))),
        );
    }
    let mut names: Vec<&Text> = channels.iter().map(|c| &c.name).collect();
    names.sort();
    if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
        return Err(Error::invalid(format!(
            "two attributes make the channel '{}'",
            from_text(w[0])
        )));
    }
    let attrs = LayerAttributes {
        layer_position: origin,
        other,
        ..Default::default()
    };
    let layer = Layer::new(
        size,
        attrs,
        Encoding {
            compression: opt.compression.to_exr(),
            blocks: Blocks::ScanLines,
            line_order: LineOrder::Increasing,
        },
        AnyChannels::sort(channels.into()),
    );
    let img = Image::new(ImageAttributes::new(display), layer);
    // The crate writes to a seekable sink: a buffer, then the output.
    let mut buf = Cursor::new(Vec::new());
    exr::prelude::WritableImage::write(&img)
        .to_buffered(&mut buf)
        .map_err(exr_error)?;
    w.write_all(buf.get_ref())?;
    Ok(())
}

fn a_is_float(a: &Attribute) -> bool {
    match &a.data {
        AttrData::Scalar(v) => v.ty().is_float(),
        AttrData::Vec3(_, c) => c[0].ty().is_float(),
        AttrData::List(_) => false,
    }
}

fn exr_error(e: exr::error::Error) -> Error {
    match e {
        exr::error::Error::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            Error::truncated("OpenEXR data ends early")
        }
        exr::error::Error::Io(io) => Error::Io(io),
        exr::error::Error::NotSupported(m) => Error::unsupported(format!("OpenEXR: {m}")),
        exr::error::Error::Invalid(m) => Error::invalid(format!("OpenEXR: {m}")),
        exr::error::Error::Aborted => Error::invalid("OpenEXR: reading aborted"),
    }
}

/// A channel as read: its name and values as the column they become.
struct Chan {
    name: String,
    data: FlatSamples,
}

/// What `pcsss:attributes` says of one attribute.
struct TypeInfo {
    kind: String,
    role: Option<Role>,
    ty: ScalarType,
}

fn parse_types(s: &str) -> HashMap<String, TypeInfo> {
    let mut m = HashMap::new();
    for item in s.split(';') {
        let f: Vec<&str> = item.split_whitespace().collect();
        if let [name, kind, role, ty] = f[..] {
            if let Some(ty) = ScalarType::from_ply_name(ty) {
                m.insert(
                    name.to_string(),
                    TypeInfo {
                        kind: kind.to_string(),
                        role: Role::from_name(role),
                        ty,
                    },
                );
            }
        }
    }
    m
}

/// The column a channel's values (at `idx`, the pixels that are points)
/// become: `ty` from the type record, else the channel's own type (half
/// widened to f32).
fn column_of(
    c: &Chan,
    idx: &[usize],
    ty: Option<ScalarType>,
    f64_bits: Option<(&Chan, &Chan)>,
) -> Column {
    let f32s = |d: &FlatSamples| -> Vec<f32> {
        match d {
            FlatSamples::F16(v) => idx.iter().map(|&i| v[i].to_f32()).collect(),
            FlatSamples::F32(v) => idx.iter().map(|&i| v[i]).collect(),
            FlatSamples::U32(v) => idx.iter().map(|&i| v[i] as f32).collect(),
        }
    };
    let u32s = |d: &FlatSamples| -> Option<Vec<u32>> {
        match d {
            FlatSamples::U32(v) => Some(idx.iter().map(|&i| v[i]).collect()),
            _ => None,
        }
    };
    match ty {
        Some(ScalarType::F64) => {
            if let Some((hi, lo)) = f64_bits {
                if let (Some(h), Some(l)) = (u32s(&hi.data), u32s(&lo.data)) {
                    return Column::F64(
                        h.iter()
                            .zip(&l)
                            .map(|(&h, &l)| f64::from_bits((h as u64) << 32 | l as u64))
                            .collect(),
                    );
                }
            }
            Column::F64(f32s(&c.data).into_iter().map(f64::from).collect())
        }
        Some(int) if !int.is_float() => match u32s(&c.data) {
            Some(v) => match int {
                ScalarType::U8 => Column::U8(v.iter().map(|&x| x as u8).collect()),
                ScalarType::U16 => Column::U16(v.iter().map(|&x| x as u16).collect()),
                ScalarType::I8 => Column::I8(v.iter().map(|&x| x as i32 as i8).collect()),
                ScalarType::I16 => Column::I16(v.iter().map(|&x| x as i32 as i16).collect()),
                ScalarType::I32 => Column::I32(v.iter().map(|&x| x as i32).collect()),
                _ => Column::U32(v),
            },
            None => Column::F32(f32s(&c.data)),
        },
        _ => match &c.data {
            FlatSamples::U32(_) if ty.is_none() => Column::U32(u32s(&c.data).expect("u32")),
            d => Column::F32(f32s(d)),
        },
    }
}

/// Reads an OpenEXR point cloud or shade-point image from its bytes.
pub fn read_exr(bytes: &[u8]) -> Result<Cloud> {
    // The header first: its claims are checked before pixels are decoded.
    let meta =
        exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(exr_error)?;
    for h in &meta.headers {
        if h.deep {
            return Err(Error::unsupported(
                "OpenEXR: a deep image; point clouds and shade points need a flat one",
            ));
        }
        for c in &h.channels.list {
            if c.sampling != Vec2(1, 1) {
                return Err(Error::unsupported(format!(
                    "OpenEXR channel '{}' is subsampled ({}x{}); every channel needs one sample a pixel",
                    from_text(&c.name),
                    c.sampling.x(),
                    c.sampling.y()
                )));
            }
        }
    }
    let img = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(exr_error)?;
    let layer = img
        .layer_data
        .iter()
        .find(|l| {
            l.channel_data
                .list
                .iter()
                .any(|c| is_p(&from_text(&c.name)))
        })
        .or_else(|| img.layer_data.first())
        .ok_or_else(|| Error::invalid("OpenEXR: no layers"))?;
    let mut other = img.attributes.other.clone();
    other.extend(layer.attributes.other.clone());
    let chans: Vec<Chan> = layer
        .channel_data
        .list
        .iter()
        .map(|c| Chan {
            name: from_text(&c.name),
            data: c.sample_data.clone(),
        })
        .collect();
    let size = layer.size;
    let pixels = size.area();
    let types = match other.get(&Text::from(ATTR_TYPES)) {
        Some(AttributeValue::Text(t)) => parse_types(&from_text(t)),
        _ => HashMap::new(),
    };
    let mut cloud = Cloud::default();
    let idx: Vec<usize>;
    let mut image = false;
    match other.get(&Text::from(ATTR_POINTS)) {
        Some(AttributeValue::I32(n)) => {
            let n = usize::try_from(*n)
                .map_err(|_| Error::invalid(format!("OpenEXR: {ATTR_POINTS} is {n}")))?;
            if n > pixels {
                return Err(Error::invalid(format!(
                    "OpenEXR: the header says {n} points but the image has {pixels} pixels"
                )));
            }
            idx = (0..n).collect();
        }
        Some(_) => {
            return Err(Error::invalid(format!(
                "OpenEXR: header attribute {ATTR_POINTS} is not an int"
            )))
        }
        None => {
            image = true;
            idx = covered(&chans, pixels)?;
        }
    }
    let mut el = Element::new(POINTS, idx.len());
    // Group channels into attributes.
    let by_name: HashMap<&str, &Chan> = chans.iter().map(|c| (c.name.as_str(), c)).collect();
    let mut used: std::collections::HashSet<&str> = std::collections::HashSet::new();
    let mut attrs: Vec<Attribute> = Vec::new();
    // Recorded attributes first, in their recorded order.
    let mut recorded: Vec<(&String, &TypeInfo)> = types.iter().collect();
    let order_of = |name: &str| match other.get(&Text::from(ATTR_TYPES)) {
        Some(AttributeValue::Text(t)) => from_text(t)
            .split(';')
            .position(|it| it.split_whitespace().next() == Some(name))
            .unwrap_or(usize::MAX),
        _ => usize::MAX,
    };
    recorded.sort_by_key(|(n, _)| order_of(n));
    for (name, info) in recorded {
        let comp = |ch: &str| -> Option<Column> {
            let c = by_name.get(ch)?;
            let bits = match (
                by_name.get(format!("{ch}.f64hi").as_str()),
                by_name.get(format!("{ch}.f64lo").as_str()),
            ) {
                (Some(h), Some(l)) => Some((*h, *l)),
                _ => None,
            };
            Some(column_of(c, &idx, Some(info.ty), bits))
        };
        if info.kind == "vec3" {
            let role = info.role.unwrap_or(Role::Vector);
            let names = suffixes(role).map(|s| format!("{name}.{s}"));
            let cols: Option<Vec<Column>> = names.iter().map(|n| comp(n)).collect();
            if let Some(cols) = cols {
                for n in &names {
                    used.insert(by_name.get_key_value(n.as_str()).expect("found").0);
                    mark_bits(&by_name, n, &mut used);
                }
                let [a, b, c]: [Column; 3] = cols.try_into().expect("three components");
                attrs.push(Attribute::vec3(name, role, [a, b, c]));
            }
        } else if let Some(col) = comp(name) {
            used.insert(by_name.get_key_value(name.as_str()).expect("found").0);
            mark_bits(&by_name, name, &mut used);
            attrs.push(Attribute::scalar(name, col));
        }
    }
    // Then the rest by their spellings: layer.{x,y,z} and layer.{R,G,B}
    // spelled any common way are 3-vectors; anything else a scalar.
    let rest: Vec<&Chan> = chans
        .iter()
        .filter(|c| !used.contains(c.name.as_str()))
        .collect();
    let mut layers: Vec<String> = Vec::new();
    for c in &rest {
        if let Some((layer, _)) = c.name.rsplit_once('.') {
            if !layers.iter().any(|l| l == layer) {
                layers.push(layer.to_string());
            }
        }
    }
    for layer in &layers {
        for (spellings, role) in VEC_SPELLINGS {
            // P and N are a point and a normal however they are spelt.
            let role = match layer.as_str() {
                "P" => Role::Point,
                "N" => Role::Normal,
                _ => *role,
            };
            for sp in *spellings {
                let names = sp.map(|s| format!("{layer}.{s}"));
                if names
                    .iter()
                    .all(|n| rest.iter().any(|c| &c.name == n) && !used.contains(n.as_str()))
                {
                    let cols = names
                        .clone()
                        .map(|n| column_of(by_name[n.as_str()], &idx, None, None));
                    // Components of one attribute share one type.
                    let cols = if cols.iter().all(|c| c.ty() == cols[0].ty()) {
                        cols
                    } else {
                        names.clone().map(|n| {
                            column_of(by_name[n.as_str()], &idx, Some(ScalarType::F32), None)
                        })
                    };
                    for n in &names {
                        used.insert(by_name.get_key_value(n.as_str()).expect("found").0);
                    }
                    if !attrs.iter().any(|a| &a.name == layer) {
                        attrs.push(Attribute::vec3(layer, role, cols));
                    }
                }
            }
        }
    }
    for c in &chans {
        if !used.contains(c.name.as_str()) && !attrs.iter().any(|a| a.name == c.name) {
            attrs.push(Attribute::scalar(&c.name, column_of(c, &idx, None, None)));
        }
    }
    if image {
        let w = size.width();
        let (x0, y0) = (
            layer.attributes.layer_position.x(),
            layer.attributes.layer_position.y(),
        );
        attrs.push(Attribute::scalar(
            PIXEL_X,
            Column::I32(idx.iter().map(|&i| x0 + (i % w) as i32).collect()),
        ));
        attrs.push(Attribute::scalar(
            PIXEL_Y,
            Column::I32(idx.iter().map(|&i| y0 + (i / w) as i32).collect()),
        ));
    }
    for a in attrs {
        el.set(a)?;
    }
    cloud.elements.push(el);
    if image {
        let data = IntegerBounds::new(layer.attributes.layer_position, size);
        cloud.set_detail(DATA_WINDOW, DetailValue::Str(window_str(data)));
        cloud.set_detail(
            DISPLAY_WINDOW,
            DetailValue::Str(window_str(img.attributes.display_window)),
        );
    }
    let mut details: Vec<(String, DetailValue)> = other
        .iter()
        .filter_map(|(k, v)| {
            let k = from_text(k);
            let name = k.strip_prefix(ATTR_DETAIL)?.to_string();
            Some((name, detail_from_exr(v)?))
        })
        .collect();
    // In the recorded order, then any others by name.
    let order: Vec<String> = match other.get(&Text::from(ATTR_DETAIL_ORDER)) {
        Some(AttributeValue::Text(t)) => from_text(t).split(' ').map(String::from).collect(),
        _ => Vec::new(),
    };
    details.sort_by_key(|(name, _)| {
        (
            order.iter().position(|o| o == name).unwrap_or(usize::MAX),
            name.clone(),
        )
    });
    for (k, v) in details {
        cloud.set_detail(&k, v);
    }
    let lines = |key: &str| match other.get(&Text::from(key)) {
        Some(AttributeValue::Text(t)) => from_text(t).lines().map(String::from).collect(),
        _ => Vec::new(),
    };
    cloud.comments = lines(ATTR_COMMENTS);
    cloud.obj_info = lines(ATTR_OBJ_INFO);
    Ok(cloud)
}

fn mark_bits<'a>(
    by_name: &HashMap<&'a str, &Chan>,
    ch: &str,
    used: &mut std::collections::HashSet<&'a str>,
) {
    for s in ["f64hi", "f64lo"] {
        if let Some((k, _)) = by_name.get_key_value(format!("{ch}.{s}").as_str()) {
            used.insert(k);
        }
    }
}

/// Spellings of 3-vector channels that renderers write.
const VEC_SPELLINGS: &[(&[[&str; 3]], Role)] = &[
    (&[["x", "y", "z"], ["X", "Y", "Z"]], Role::Vector),
    (
        &[["R", "G", "B"], ["r", "g", "b"], ["red", "green", "blue"]],
        Role::Color,
    ),
];

/// Is `name` a component of a P pass?
fn is_p(name: &str) -> bool {
    matches!(
        name,
        "P.x" | "P.X" | "P.R" | "P.r" | "P.red" | "P.y" | "P.Y" | "P.G" | "P.z" | "P.Z" | "P.B"
    )
}

/// The pixels of a shade-point image that are points: alpha (`A`,
/// `alpha`, `Alpha`, `a`) above 0; without alpha, a non-zero N. Needs P
/// and N passes.
fn covered(chans: &[Chan], pixels: usize) -> Result<Vec<usize>> {
    let find = |layer: &str| -> Option<[&Chan; 3]> {
        for (spellings, _) in VEC_SPELLINGS {
            for sp in *spellings {
                let f: Option<Vec<&Chan>> = sp
                    .iter()
                    .map(|s| chans.iter().find(|c| c.name == format!("{layer}.{s}")))
                    .collect();
                if let Some(f) = f {
                    return f.try_into().ok();
                }
            }
        }
        None
    };
    let Some(_) = find("P") else {
        return Err(Error::invalid(
            "OpenEXR image has no P pass (P.x P.y P.z, or P.X/P.R/P.red ...): read without pcsss:points, it is shade points and needs one",
        ));
    };
    let value = |c: &Chan, i: usize| -> f32 {
        match &c.data {
            FlatSamples::F16(v) => v[i].to_f32(),
            FlatSamples::F32(v) => v[i],
            FlatSamples::U32(v) => v[i] as f32,
        }
    };
    let alpha = chans
        .iter()
        .find(|c| matches!(c.name.as_str(), "A" | "alpha" | "Alpha" | "a"));
    if let Some(a) = alpha {
        return Ok((0..pixels).filter(|&i| value(a, i) > 0.0).collect());
    }
    let Some(n) = find("N") else {
        return Err(Error::invalid(
            "OpenEXR shade points: no alpha channel (A or alpha) and no N pass to tell covered pixels",
        ));
    };
    Ok((0..pixels)
        .filter(|&i| n.iter().any(|c| value(c, i) != 0.0))
        .collect())
}
