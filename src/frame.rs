//! The frame a scene's coordinates are written in: which axis is up and
//! how many metres a unit is. A cloud records the frame of the mesh it was
//! scattered on (`scatter --up-axis --meters-per-unit`); a lights or
//! camera file may state its own; the stages move the lights and the
//! camera into the cloud's frame (`formats/LIGHTS.md#frames`).
//!
//! Y-up and Z-up frames are both right-handed and share their X axis, as
//! Blender's exporters write them: Blender's `(x, y, z)` (Z up, -Y
//! forward) is `(x, z, -y)` in a Y-up OBJ.

use glam::DVec3;
use serde::Deserialize;

/// Detail attribute of a cloud: the up axis of its coordinates (str, `y`
/// or `z`).
pub const D_UP_AXIS: &str = "up_axis";
/// Detail attribute of a cloud: metres per unit of its coordinates (f64).
pub const D_METERS_PER_UNIT: &str = "meters_per_unit";

/// Which axis is up.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum UpAxis {
    Y,
    Z,
}

impl UpAxis {
    /// `y` or `z`.
    pub fn name(self) -> &'static str {
        match self {
            UpAxis::Y => "y",
            UpAxis::Z => "z",
        }
    }

    /// The axis from its name.
    pub fn from_name(s: &str) -> Option<UpAxis> {
        match s {
            "y" | "Y" => Some(UpAxis::Y),
            "z" | "Z" => Some(UpAxis::Z),
            _ => None,
        }
    }

    /// The unit vector up.
    pub fn vector(self) -> DVec3 {
        match self {
            UpAxis::Y => DVec3::Y,
            UpAxis::Z => DVec3::Z,
        }
    }
}

/// A frame; a part not stated is not known.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Frame {
    pub up: Option<UpAxis>,
    pub meters_per_unit: Option<f64>,
}

/// The change from one frame to another: a rotation between up axes and
/// a scale, `to = rotate(from) * scale`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Change {
    rotate: Option<(UpAxis, UpAxis)>,
    /// Units of the target per unit of the source.
    pub scale: f64,
}

impl Frame {
    /// Checks `meters_per_unit` (finite, > 0); `Err` says why.
    pub fn check(&self) -> std::result::Result<(), String> {
        match self.meters_per_unit {
            Some(m) if !(m.is_finite() && m > 0.0) => {
                Err(format!("{m} is not a finite number > 0"))
            }
            _ => Ok(()),
        }
    }

    /// The change from this frame to `to`. A part either side leaves
    /// unstated is taken as equal: a file that states nothing is in the
    /// cloud's frame, as before frames were written down.
    pub fn change_to(&self, to: &Frame) -> Change {
        let rotate = match (self.up, to.up) {
            (Some(a), Some(b)) if a != b => Some((a, b)),
            _ => None,
        };
        let scale = match (self.meters_per_unit, to.meters_per_unit) {
            (Some(a), Some(b)) => a / b,
            _ => 1.0,
        };
        Change { rotate, scale }
    }
}

impl Change {
    /// Whether the change moves nothing.
    pub fn is_identity(&self) -> bool {
        self.rotate.is_none() && self.scale == 1.0
    }

    /// A direction in the new frame (rotated, not scaled).
    pub fn vector(&self, v: DVec3) -> DVec3 {
        match self.rotate {
            Some((UpAxis::Z, UpAxis::Y)) => DVec3::new(v.x, v.z, -v.y),
            Some((UpAxis::Y, UpAxis::Z)) => DVec3::new(v.x, -v.z, v.y),
            _ => v,
        }
    }

    /// A position in the new frame.
    pub fn point(&self, p: DVec3) -> DVec3 {
        self.vector(p) * self.scale
    }

    /// A length in the new frame.
    pub fn length(&self, d: f64) -> f64 {
        d * self.scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn z_up_to_y_up_is_blenders_obj_export_and_back_is_its_inverse() {
        let z = Frame {
            up: Some(UpAxis::Z),
            meters_per_unit: Some(1.0),
        };
        let y = Frame {
            up: Some(UpAxis::Y),
            meters_per_unit: Some(0.01),
        };
        let c = z.change_to(&y);
        // Blender's up (+Z) is the OBJ's +Y, its forward (-Y) the OBJ's +Z.
        assert_eq!(c.vector(DVec3::Z), DVec3::Y);
        assert_eq!(c.vector(-DVec3::Y), DVec3::Z);
        assert_eq!(c.vector(DVec3::X), DVec3::X);
        // A metre is 100 centimetres.
        assert_eq!(
            c.point(DVec3::new(1.0, 2.0, 3.0)),
            DVec3::new(100.0, 300.0, -200.0)
        );
        let back = y.change_to(&z);
        let p = DVec3::new(0.3, -1.7, 2.5);
        assert!((back.point(c.point(p)) - p).length() < 1e-15);
        // Rotations keep handedness.
        assert_eq!(
            c.vector(DVec3::X).cross(c.vector(DVec3::Y)),
            c.vector(DVec3::Z)
        );
        assert_eq!(
            back.vector(DVec3::X).cross(back.vector(DVec3::Y)),
            back.vector(DVec3::Z)
        );
    }

    #[test]
    fn an_unstated_part_is_taken_as_equal() {
        let z = Frame {
            up: Some(UpAxis::Z),
            meters_per_unit: None,
        };
        assert!(z.change_to(&Frame::default()).is_identity());
        assert!(Frame::default().change_to(&z).is_identity());
        let cm = Frame {
            up: None,
            meters_per_unit: Some(0.01),
        };
        assert_eq!(z.change_to(&cm).scale, 1.0);
        assert!(Frame {
            up: None,
            meters_per_unit: Some(-1.0)
        }
        .check()
        .is_err());
    }
}
