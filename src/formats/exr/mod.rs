//! OpenEXR point clouds and shade-point images (crate `exr`): the reader
//! ([`read`](mod@read)), the writer ([`write`](mod@write)) and what they
//! share. The layout is specified in the repository's `formats/EXR.md`.
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
//!   N) is a point of an image cloud ([`crate::image`]): it remembers its
//!   pixel and the image's windows, so that a cloud of shade points is
//!   written back as an image of the same size and data window.

pub mod read;
pub mod write;

use exr::prelude::{AttributeValue, SmallVec, Text};

use crate::cloud::{DetailValue, Role};
use crate::error::Error;

pub use read::read_exr;
pub use write::write_exr;

/// Widest row of a point-cloud image.
pub const WIDTH: usize = 1024;

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

    pub(crate) fn to_exr(self) -> exr::compression::Compression {
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
pub(crate) fn suffixes(role: Role) -> [&'static str; 3] {
    match role {
        Role::Color => ["R", "G", "B"],
        _ => ["x", "y", "z"],
    }
}

/// Builds an EXR `Text` from any UTF-8 string (OpenEXR strings are bytes).
pub(crate) fn text(s: &str) -> Text {
    Text::from_bytes_unchecked(SmallVec::from_slice(s.as_bytes()))
}

pub(crate) fn from_text(t: &Text) -> String {
    String::from_utf8_lossy(t.bytes()).into_owned()
}

/// A detail attribute as an EXR header attribute of its own type.
pub(crate) fn detail_to_exr(v: &DetailValue) -> AttributeValue {
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

pub(crate) fn detail_from_exr(v: &AttributeValue) -> Option<DetailValue> {
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

pub(crate) fn exr_error(e: exr::error::Error) -> Error {
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
