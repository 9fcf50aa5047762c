//! Texture images (`texture --image`): PNG (8 or 16 bits; grey, grey and
//! alpha, RGB, RGBA, palette) and OpenEXR (`R G B`), read into linear RGB
//! texels, top row first. 8-bit PNG is taken as sRGB and decoded unless
//! told otherwise (a colour map painted for the eye); 16-bit PNG and
//! OpenEXR as linear. Alpha is dropped.

use std::io::Cursor;
use std::path::Path;

use crate::error::{Error, Result};

/// The largest texture side.
pub const MAX_SIDE: usize = 1 << 15;

/// How a PNG's values become linear ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Decode {
    /// sRGB for 8-bit PNG, linear for 16-bit PNG and OpenEXR.
    Auto,
    /// sRGB's curve undone.
    Srgb,
    /// Taken as they are (a map of numbers: roughness, a mean free path).
    Linear,
}

/// A texture: `width x height` linear RGB texels, row by row from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub width: usize,
    pub height: usize,
    pub texels: Vec<[f32; 3]>,
}

/// sRGB's transfer curve undone.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The largest texture file read: a 16k x 16k RGBA float image,
/// uncompressed (a device that never ends, `/dev/zero`, is refused after
/// it, not read until memory runs out).
pub const MAX_FILE: u64 = 4 << 30;

/// Reads the texture at `path` (PNG or OpenEXR, by its first bytes).
pub fn read(path: &Path, decode: Decode) -> Result<Texture> {
    let bytes = crate::files::read_input_of(
        path,
        MAX_FILE,
        "a texture image (PNG or OpenEXR)",
        &[PNG, EXR],
    )?;
    read_bytes(&bytes, decode)
}

/// A PNG file's first bytes.
pub const PNG: &[u8] = b"\x89PNG\r\n\x1a\n";
/// An OpenEXR file's first bytes.
pub const EXR: &[u8] = &[0x76, 0x2f, 0x31, 0x01];

/// A texture from a file's bytes (PNG or OpenEXR, by its first bytes).
pub fn read_bytes(bytes: &[u8], decode: Decode) -> Result<Texture> {
    if bytes.starts_with(PNG) {
        read_png(bytes, decode)
    } else if bytes.starts_with(EXR) {
        let (w, h, texels) = super::exr::read::read_rgb_image(bytes)?;
        let texels = match decode {
            Decode::Srgb => texels.into_iter().map(|t| t.map(srgb_to_linear)).collect(),
            _ => texels,
        };
        checked(w, h, texels)
    } else {
        Err(Error::unsupported(
            "not a PNG or OpenEXR image (a texture is one of those)",
        ))
    }
}

fn checked(width: usize, height: usize, texels: Vec<[f32; 3]>) -> Result<Texture> {
    if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
        return Err(Error::invalid(format!(
            "a texture of {width} x {height} texels (each side 1 to {MAX_SIDE})"
        )));
    }
    if let Some(i) = texels.iter().position(|t| !t.iter().all(|x| x.is_finite())) {
        return Err(Error::invalid(format!(
            "texel ({}, {}) is {:?}: not finite",
            i % width,
            i / width,
            texels[i]
        )));
    }
    Ok(Texture {
        width,
        height,
        texels,
    })
}

fn read_png(bytes: &[u8], decode: Decode) -> Result<Texture> {
    let bad = |e: png::DecodingError| match e {
        png::DecodingError::LimitsExceeded => {
            Error::invalid("PNG: the header claims more pixels than the file's bytes can hold")
        }
        e => Error::invalid(format!("PNG: {e}")),
    };
    // Never more decoded bytes than deflate can make of the file's
    // (at most 1032 to 1), nor more than a texture may have.
    let cap = (bytes.len().saturating_mul(1032)).min(MAX_SIDE * MAX_SIDE * 8);
    let mut dec = png::Decoder::new_with_limits(Cursor::new(bytes), png::Limits { bytes: cap });
    dec.set_transformations(png::Transformations::EXPAND);
    let mut reader = dec.read_info().map_err(bad)?;
    let (w, h) = (reader.info().width as usize, reader.info().height as usize);
    let size = reader.output_buffer_size();
    // The header's claim against the bytes there are, before anything
    // is allocated for it.
    if w > MAX_SIDE || h > MAX_SIDE || size > cap {
        return Err(Error::invalid(format!(
            "PNG: the header claims {w} x {h} pixels ({size} bytes) in a file of {} bytes",
            bytes.len()
        )));
    }
    crate::memory::check_available(size as u64, "image", "the texture")?;
    let mut buf = vec![0u8; size];
    let info = reader.next_frame(&mut buf).map_err(bad)?;
    let (w, h) = (info.width as usize, info.height as usize);
    let channels = info.color_type.samples();
    let sixteen = info.bit_depth == png::BitDepth::Sixteen;
    let srgb = match decode {
        Decode::Auto => !sixteen,
        Decode::Srgb => true,
        Decode::Linear => false,
    };
    let value = |k: usize| -> f32 {
        let x = if sixteen {
            u16::from_be_bytes([buf[2 * k], buf[2 * k + 1]]) as f32 / 65535.0
        } else {
            buf[k] as f32 / 255.0
        };
        if srgb {
            srgb_to_linear(x)
        } else {
            x
        }
    };
    let texels = (0..w * h)
        .map(|i| {
            let k = i * channels;
            match channels {
                1 | 2 => [value(k); 3],
                _ => [value(k), value(k + 1), value(k + 2)],
            }
        })
        .collect();
    checked(w, h, texels)
}

impl Texture {
    /// The texture at `(u, v)` (v up, OpenGL's and Blender's convention:
    /// `v = 0` is the bottom row), bilinear between texel centres;
    /// `repeat` wraps, else the edge texels extend.
    pub fn sample(&self, u: f64, v: f64, repeat: bool) -> [f32; 3] {
        let (w, h) = (self.width as i64, self.height as i64);
        let s = u * w as f64 - 0.5;
        let t = (1.0 - v) * h as f64 - 0.5;
        let (x0, y0) = (s.floor(), t.floor());
        let (fx, fy) = ((s - x0) as f32, (t - y0) as f32);
        let at = |x: i64, y: i64| -> [f32; 3] {
            let (x, y) = if repeat {
                (x.rem_euclid(w), y.rem_euclid(h))
            } else {
                (x.clamp(0, w - 1), y.clamp(0, h - 1))
            };
            self.texels[(y * w + x) as usize]
        };
        let (x0, y0) = (x0 as i64, y0 as i64);
        let (a, b, c, d) = (
            at(x0, y0),
            at(x0 + 1, y0),
            at(x0, y0 + 1),
            at(x0 + 1, y0 + 1),
        );
        [0, 1, 2].map(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            top + (bottom - top) * fy
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_between_texel_centres_wrapping_or_clamping() {
        // 2 x 1: black, white.
        let t = Texture {
            width: 2,
            height: 1,
            texels: vec![[0.0; 3], [1.0; 3]],
        };
        // Texel centres.
        assert_eq!(t.sample(0.25, 0.5, true)[0], 0.0);
        assert_eq!(t.sample(0.75, 0.5, true)[0], 1.0);
        assert!((t.sample(0.5, 0.5, true)[0] - 0.5).abs() < 1e-6);
        // Past the right centre: repeat blends towards the left texel,
        // clamp stays white.
        assert!((t.sample(1.0, 0.5, true)[0] - 0.5).abs() < 1e-6);
        assert_eq!(t.sample(1.0, 0.5, false)[0], 1.0);
        assert!((t.sample(-0.25, 0.3, true)[0] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn srgb_decodes_to_its_linear_values() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        // 50% sRGB grey is 21.4% linear.
        assert!((srgb_to_linear(0.5) - 0.214).abs() < 1e-3);
    }
}
