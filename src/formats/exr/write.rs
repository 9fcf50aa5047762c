//! Writing a cloud as OpenEXR: an image cloud as its image, any other in
//! the point-cloud layout.

use std::collections::HashMap;
use std::io::{Cursor, Write};

use exr::prelude::f16;
use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Blocks, Encoding, FlatSamples, Image, ImageAttributes,
    IntegerBounds, Layer, LayerAttributes, LineOrder, Text, Vec2,
};

use super::{
    detail_to_exr, exr_error, from_text, suffixes, text, ExrOptions, ATTR_COMMENTS, ATTR_DETAIL,
    ATTR_DETAIL_ORDER, ATTR_OBJ_INFO, ATTR_POINTS, ATTR_TYPES, WIDTH,
};
use crate::cloud::{AttrData, Attribute, Cloud, POINTS};
use crate::column::Column;
use crate::error::{Error, Result};
use crate::image::{self, Window, DATA_WINDOW, DISPLAY_WINDOW, PIXEL_X, PIXEL_Y};

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
            None => return Err(Error::param("half", format!("no point attribute '{h}'"))),
            Some(a) if !a_is_float(a) => {
                return Err(Error::param(
                    "half",
                    format!("attribute '{h}' is not a float attribute"),
                ))
            }
            Some(a) => {
                // Never a finite value turned into infinity.
                let max = f16::MAX.to_f64();
                for c in a.components() {
                    let col = c.column();
                    if let Some(i) = (0..n).find(|&i| {
                        let x = col.get_f64(i);
                        x.is_finite() && x.abs() > max
                    }) {
                        return Err(Error::param(
                            "half",
                            format!(
                                "attribute '{h}' is {:e} at point {i}, beyond a half's range ({max})",
                                col.get_f64(i)
                            ),
                        ));
                    }
                }
            }
        }
    }
    let image = image::data_window(cloud)?;
    // Where each point goes: (width, height, origin, display window, pixel
    // of point i).
    let (size, origin, display, pixel_of): (Vec2<usize>, Vec2<i32>, IntegerBounds, Vec<usize>) =
        match image {
            Some(data) => {
                let display = image::display_window(cloud, data)?;
                let px = pts.scalar_f64(PIXEL_X)?;
                let py = pts.scalar_f64(PIXEL_Y)?;
                let mut pix = Vec::with_capacity(n);
                for i in 0..n {
                    let Some(at) = data.index(px[i], py[i]) else {
                        return Err(Error::invalid(format!(
                            "point {i}: pixel ({}, {}) lies outside the data window {data}",
                            px[i], py[i]
                        )));
                    };
                    pix.push(at);
                }
                (
                    Vec2(data.width(), data.height()),
                    Vec2(data.x0, data.y0),
                    bounds(display),
                    pix,
                )
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
    if channels.is_empty() {
        // OpenEXR needs a channel; a placeholder would be a channel other
        // readers show as data.
        return Err(Error::unsupported(
            "the points have no attributes and OpenEXR needs at least one channel (write PLY)",
        ));
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
    let mut bytes = buf.into_inner();
    sort_header(&mut bytes);
    w.write_all(&bytes)?;
    Ok(())
}

/// A window as the `exr` crate's bounds.
fn bounds(w: Window) -> IntegerBounds {
    IntegerBounds::new(Vec2(w.x0, w.y0), Vec2(w.width(), w.height()))
}

fn a_is_float(a: &Attribute) -> bool {
    match &a.data {
        AttrData::Scalar(v) => v.ty().is_float(),
        AttrData::Vec3(_, c) => c[0].ty().is_float(),
        AttrData::List(_) => false,
    }
}
/// The header's attributes of a single-part OpenEXR file `bytes` put in
/// order of their names, in place: the crate keeps them in a `HashMap`,
/// whose order changes from one run to the next, and the same cloud must
/// make the same bytes. The header keeps its length, so the offset table
/// after it still points where it did. A file this cannot read as a
/// single-part header is left as it is.
fn sort_header(bytes: &mut [u8]) {
    const MULTIPART: u32 = 0x1000;
    let Some(flags) = bytes.get(4..8) else {
        return;
    };
    if u32::from_le_bytes([flags[0], flags[1], flags[2], flags[3]]) & MULTIPART != 0 {
        return;
    }
    let zero_after = |at: usize| bytes[at..].iter().position(|&b| b == 0).map(|k| at + k);
    let mut attrs: Vec<(usize, usize, usize)> = Vec::new();
    let mut at = 8;
    loop {
        let Some(name_end) = zero_after(at) else {
            return;
        };
        if name_end == at {
            break;
        }
        let Some(type_end) = zero_after(name_end + 1) else {
            return;
        };
        let Some(size) = bytes.get(type_end + 1..type_end + 5) else {
            return;
        };
        let size = i32::from_le_bytes([size[0], size[1], size[2], size[3]]);
        let end = type_end + 5 + size.max(0) as usize;
        if size < 0 || end > bytes.len() {
            return;
        }
        attrs.push((at, name_end, end));
        at = end;
    }
    let mut sorted = attrs.clone();
    sorted.sort_by(|a, b| bytes[a.0..a.1].cmp(&bytes[b.0..b.1]));
    let header: Vec<u8> = sorted
        .iter()
        .flat_map(|&(s, _, e)| bytes[s..e].iter().copied())
        .collect();
    bytes[8..at].copy_from_slice(&header);
}
