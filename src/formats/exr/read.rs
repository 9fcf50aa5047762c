//! Reading an OpenEXR point cloud or shade-point image.

use std::collections::{HashMap, HashSet};
use std::io::Cursor;

use exr::prelude::{AttributeValue, FlatSamples, ReadChannels, ReadLayers, Text, Vec2};

use super::{
    detail_from_exr, exr_error, from_text, suffixes, ATTR_COMMENTS, ATTR_DETAIL, ATTR_DETAIL_ORDER,
    ATTR_OBJ_INFO, ATTR_POINTS, ATTR_TYPES,
};
use crate::cloud::{Attribute, Cloud, Detail, DetailValue, Element, Role, POINTS};
use crate::column::{Column, ScalarType};
use crate::error::{Error, Result};
use crate::image::{self, Window, PIXEL_X, PIXEL_Y};

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

/// The most decoded sample bytes a file may hold per byte of it.
const MAX_RATIO: u64 = 4096;

/// The image in `bytes`, every layer and channel at full resolution,
/// after checking the header's claims against the bytes there are.
fn decode(bytes: &[u8]) -> Result<FlatImage> {
    // The header first: its claims are checked before pixels are decoded.
    let meta =
        exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(exr_error)?;
    for h in &meta.headers {
        // Never allocate what a header claims beyond what its bytes can
        // hold: no codec OpenEXR has expands data more than MAX_RATIO
        // times (deflate's bound is 1032).
        let pixels = h.layer_size.width() as u64 * h.layer_size.height() as u64;
        let sample_bytes: u64 = h
            .channels
            .list
            .iter()
            .map(|c| c.sample_type.bytes_per_sample() as u64)
            .sum();
        let decoded = pixels.saturating_mul(sample_bytes);
        if pixels > crate::image::MAX_PIXELS as u64
            || decoded > MAX_RATIO.saturating_mul(bytes.len() as u64)
        {
            return Err(Error::invalid(format!(
                "OpenEXR: the header claims {} x {} pixels ({decoded} bytes of samples) in a file of {} bytes",
                h.layer_size.width(),
                h.layer_size.height(),
                bytes.len()
            )));
        }
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
    Ok(img)
}

type FlatImage = exr::prelude::Image<exr::prelude::Layers<exr::prelude::AnyChannels<FlatSamples>>>;

/// An RGB picture (a dome light's lat-long map): width, height and the
/// pixels row by row from the top, from the first layer's `R G B`
/// channels (or `r g b`, `red green blue`, with or without a layer
/// prefix); half and uint channels widen to f32.
pub fn read_rgb_image(bytes: &[u8]) -> Result<(usize, usize, Vec<[f32; 3]>)> {
    let img = decode(bytes)?;
    let layer = img
        .layer_data
        .first()
        .ok_or_else(|| Error::invalid("OpenEXR: no layers"))?;
    let list = &layer.channel_data.list;
    let find = |names: &[&str]| {
        list.iter().find(|c| {
            let n = from_text(&c.name);
            let last = n.rsplit('.').next().unwrap_or(&n).to_string();
            names.contains(&last.as_str())
        })
    };
    let chan = |names: &[&str], which: &str| {
        find(names).ok_or_else(|| {
            let have: Vec<String> = list.iter().map(|c| from_text(&c.name)).collect();
            Error::invalid(format!(
                "OpenEXR: no {which} channel (the channels are: {})",
                have.join(", ")
            ))
        })
    };
    let r = chan(&["R", "r", "red"], "R")?;
    let g = chan(&["G", "g", "green"], "G")?;
    let b = chan(&["B", "b", "blue"], "B")?;
    let f = |d: &FlatSamples, i: usize| match d {
        FlatSamples::F16(v) => v[i].to_f32(),
        FlatSamples::F32(v) => v[i],
        FlatSamples::U32(v) => v[i] as f32,
    };
    let (w, h) = (layer.size.width(), layer.size.height());
    let px = (0..w * h)
        .map(|i| {
            [
                f(&r.sample_data, i),
                f(&g.sample_data, i),
                f(&b.sample_data, i),
            ]
        })
        .collect();
    Ok((w, h, px))
}

/// Reads an OpenEXR point cloud or shade-point image from its bytes.
pub fn read_exr(bytes: &[u8]) -> Result<Cloud> {
    let img = decode(bytes)?;
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
    let mut used: HashSet<&str> = HashSet::new();
    let mut attrs: Vec<Attribute> = Vec::new();
    // Recorded attributes first, in their recorded order.
    let mut recorded: Vec<(&String, &TypeInfo)> = types.iter().collect();
    // (Positions from a map, not a scan each: linear in the attributes.)
    let type_text = match other.get(&Text::from(ATTR_TYPES)) {
        Some(AttributeValue::Text(t)) => from_text(t),
        _ => String::new(),
    };
    let mut type_order: HashMap<&str, usize> = HashMap::new();
    for (i, it) in type_text.split(';').enumerate() {
        if let Some(n) = it.split_whitespace().next() {
            type_order.entry(n).or_insert(i);
        }
    }
    recorded.sort_by_key(|(n, _)| type_order.get(n.as_str()).copied().unwrap_or(usize::MAX));
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
    // (Sets, not searches of the lists: a file may have tens of thousands
    // of channels.)
    let rest_names: HashSet<&str> = rest.iter().map(|c| c.name.as_str()).collect();
    let mut layers: Vec<String> = Vec::new();
    let mut seen_layers: HashSet<&str> = HashSet::new();
    for c in &rest {
        if let Some((layer, _)) = c.name.rsplit_once('.') {
            if seen_layers.insert(layer) {
                layers.push(layer.to_string());
            }
        }
    }
    let mut named: HashSet<String> = attrs.iter().map(|a| a.name.clone()).collect();
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
                    .all(|n| rest_names.contains(n.as_str()) && !used.contains(n.as_str()))
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
                    if named.insert(layer.clone()) {
                        attrs.push(Attribute::vec3(layer, role, cols));
                    }
                }
            }
        }
    }
    for c in &chans {
        if !used.contains(c.name.as_str()) && named.insert(c.name.clone()) {
            attrs.push(Attribute::scalar(&c.name, column_of(c, &idx, None, None)));
        }
    }
    if image {
        let w = size.width();
        let (x0, y0) = (
            layer.attributes.layer_position.x(),
            layer.attributes.layer_position.y(),
        );
        // The pixels are where the image says, whatever a channel of
        // that name held.
        attrs.retain(|a| a.name != PIXEL_X && a.name != PIXEL_Y);
        attrs.push(Attribute::scalar(
            PIXEL_X,
            Column::I32(idx.iter().map(|&i| x0 + (i % w) as i32).collect()),
        ));
        attrs.push(Attribute::scalar(
            PIXEL_Y,
            Column::I32(idx.iter().map(|&i| y0 + (i / w) as i32).collect()),
        ));
    }
    // The names are unique (`named`), so no search for each.
    for a in attrs {
        el.push_unique(a)?;
    }
    cloud.elements.push(el);
    if image {
        let window = |b: exr::prelude::IntegerBounds| {
            let max = b.max();
            Window {
                x0: b.position.x(),
                y0: b.position.y(),
                x1: max.x(),
                y1: max.y(),
            }
        };
        let data = exr::prelude::IntegerBounds::new(layer.attributes.layer_position, size);
        image::set_windows(
            &mut cloud,
            window(data),
            window(img.attributes.display_window),
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
    let order_text = match other.get(&Text::from(ATTR_DETAIL_ORDER)) {
        Some(AttributeValue::Text(t)) => from_text(t),
        _ => String::new(),
    };
    let mut order: HashMap<&str, usize> = HashMap::new();
    for (i, n) in order_text.split(' ').enumerate() {
        order.entry(n).or_insert(i);
    }
    details.sort_by(|(a, _), (b, _)| {
        let at = |n: &String| order.get(n.as_str()).copied().unwrap_or(usize::MAX);
        (at(a), a).cmp(&(at(b), b))
    });
    // (The header's names are distinct: pushed, not searched.)
    cloud.detail.extend(
        details
            .into_iter()
            .map(|(name, value)| Detail { name, value }),
    );
    let lines = |key: &str| match other.get(&Text::from(key)) {
        // Written only when there are lines, joined by '\n': split, not
        // `lines()`, keeps empty lines and a trailing '\r'.
        Some(AttributeValue::Text(t)) => from_text(t).split('\n').map(String::from).collect(),
        _ => Vec::new(),
    };
    cloud.comments = lines(ATTR_COMMENTS);
    cloud.obj_info = lines(ATTR_OBJ_INFO);
    Ok(cloud)
}

fn mark_bits<'a>(by_name: &HashMap<&'a str, &Chan>, ch: &str, used: &mut HashSet<&'a str>) {
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
