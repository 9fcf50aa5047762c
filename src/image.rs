//! Image clouds: shade points that remember their pixels.
//!
//! A renderer's P and N passes, or `render`'s camera rays, give one shade
//! point a covered pixel. Such a cloud carries its pixel as the point
//! attributes [`PIXEL_X`], [`PIXEL_Y`] (int) and the image's windows as
//! the detail attributes [`DATA_WINDOW`], [`DISPLAY_WINDOW`] (strings
//! `"xmin ymin xmax ymax"`, inclusive, as in OpenEXR), so that whatever a
//! stage adds can be written back as an image of the same size
//! (`formats/EXR.md`).

use crate::cloud::{Cloud, DetailValue};
use crate::error::{Error, Result};

pub use crate::names::{DATA_WINDOW, DISPLAY_WINDOW, PIXEL_X, PIXEL_Y};

/// The most pixels an image cloud's window may have (2^31): never
/// allocate what a detail attribute claims beyond it.
pub const MAX_PIXELS: usize = 1 << 31;

/// A window of pixels, corners inclusive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    pub x0: i32,
    pub y0: i32,
    pub x1: i32,
    pub y1: i32,
}

impl Window {
    /// The window from pixel (0, 0) of a `width x height` image.
    pub fn of_size(width: u32, height: u32) -> Window {
        Window {
            x0: 0,
            y0: 0,
            x1: width as i32 - 1,
            y1: height as i32 - 1,
        }
    }

    /// Parses `"xmin ymin xmax ymax"`, the value of detail `name` (at
    /// most [`MAX_PIXELS`] pixels).
    pub fn parse(name: &str, s: &str) -> Result<Window> {
        let v: Vec<i32> = s
            .split_whitespace()
            .map(|t| t.parse::<i32>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| Error::invalid(format!("detail '{name}' is '{s}', not four integers")))?;
        match v[..] {
            [x0, y0, x1, y1] if x1 >= x0 && y1 >= y0 => {
                let w = Window { x0, y0, x1, y1 };
                let (wd, ht) = (w.width() as u64, w.height() as u64);
                if wd * ht > MAX_PIXELS as u64 {
                    return Err(Error::invalid(format!(
                        "detail '{name}' is '{s}': {wd} x {ht} pixels, more than {MAX_PIXELS}"
                    )));
                }
                Ok(w)
            }
            _ => Err(Error::invalid(format!(
                "detail '{name}' is '{s}', not 'xmin ymin xmax ymax'"
            ))),
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        (self.x1 as i64 - self.x0 as i64 + 1) as usize
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        (self.y1 as i64 - self.y0 as i64 + 1) as usize
    }

    /// The index of pixel (x, y) in a row-major buffer of the window, or
    /// `None` outside it.
    pub fn index(&self, x: f64, y: f64) -> Option<usize> {
        let (x, y) = (x - self.x0 as f64, y - self.y0 as f64);
        let inside = x >= 0.0 && y >= 0.0 && x < self.width() as f64 && y < self.height() as f64;
        inside.then(|| y as usize * self.width() + x as usize)
    }
}

impl std::fmt::Display for Window {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {} {} {}", self.x0, self.y0, self.x1, self.y1)
    }
}

/// The data window of an image cloud, `None` for any other cloud (one
/// without the window detail or the pixel attributes).
pub fn data_window(cloud: &Cloud) -> Result<Option<Window>> {
    let pts = cloud.points();
    if !(pts.has(PIXEL_X) && pts.has(PIXEL_Y)) {
        return Ok(None);
    }
    match cloud.detail(DATA_WINDOW) {
        None => Ok(None),
        Some(DetailValue::Str(s)) => Window::parse(DATA_WINDOW, s).map(Some),
        Some(_) => Err(Error::invalid(format!(
            "detail '{DATA_WINDOW}' is not a string 'xmin ymin xmax ymax'"
        ))),
    }
}

/// The display window of an image cloud (its data window when absent).
pub fn display_window(cloud: &Cloud, data: Window) -> Result<Window> {
    match cloud.detail(DISPLAY_WINDOW) {
        Some(DetailValue::Str(s)) => Window::parse(DISPLAY_WINDOW, s),
        _ => Ok(data),
    }
}

/// Marks `cloud` as an image cloud with windows `data` and `display`
/// (the pixel attributes are the caller's).
pub fn set_windows(cloud: &mut Cloud, data: Window, display: Window) {
    cloud.set_detail(DATA_WINDOW, DetailValue::Str(data.to_string()));
    cloud.set_detail(DISPLAY_WINDOW, DetailValue::Str(display.to_string()));
}
