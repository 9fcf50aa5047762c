//! The transform arithmetic of Pixar's library (`Gf`, and
//! `UsdGeomXformOp::GetOpTransform`), operation for operation, so that a
//! mesh or light read from a stage lands on the same floats as one a
//! Pixar-based exporter flattened to world space: the same scene in USD
//! and in PLY and JSON bakes to the same bits.
//!
//! Matrices are Pixar's: row-major, acting on row vectors (`p * M`), so a
//! product here is Pixar's product in Pixar's order. Floating-point
//! products are not associative, and a rotation built another way (glam's
//! sine and cosine of the whole angle) rounds differently from Pixar's
//! (a normalised quaternion of the half angle); both are kept as Pixar
//! keeps them. `tests/it/usd_in.rs` holds this against Pixar's own
//! `ComputeLocalToWorldTransform` over random stacks of every op kind.

use glam::DMat4;

/// A 4x4 matrix as Pixar stores it: `m[row][col]`, row vectors.
pub type Matrix4 = [[f64; 4]; 4];
type Matrix3 = [[f64; 3]; 3];

/// The identity.
pub const IDENTITY: Matrix4 = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// `GF_MIN_VECTOR_LENGTH`.
const MIN_VECTOR_LENGTH: f64 = 1e-10;

/// The unit axes X, Y, Z.
pub const AXES: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `GfMatrix4d::operator*`: each entry summed over k = 0..3 in order.
pub fn mul(a: &Matrix4, b: &Matrix4) -> Matrix4 {
    let mut m = [[0.0; 4]; 4];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j] + a[i][3] * b[3][j];
        }
    }
    m
}

fn mul3(a: &Matrix3, b: &Matrix3) -> Matrix3 {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    m
}

/// The matrix glam uses for the same map (column vectors): Pixar's rows
/// are glam's columns, the same numbers.
pub fn to_glam(m: &Matrix4) -> DMat4 {
    DMat4::from_cols_array_2d(m)
}

/// `GfMatrix4d::SetTranslate`.
pub fn translate(t: [f64; 3]) -> Matrix4 {
    let mut m = IDENTITY;
    m[3][..3].copy_from_slice(&t);
    m
}

/// `GfMatrix4d::SetScale`.
pub fn scale(s: [f64; 3]) -> Matrix4 {
    let mut m = IDENTITY;
    for k in 0..3 {
        m[k][k] = s[k];
    }
    m
}

/// A `GfRotation`: a unit axis and an angle in degrees.
#[derive(Clone, Copy, Debug)]
pub struct Rotation {
    axis: [f64; 3],
    degrees: f64,
}

impl Rotation {
    /// `GfRotation(axis, angle)` (`SetAxisAngle`: the axis normalised
    /// unless its square length is within 1e-10 of one).
    pub fn new(axis: [f64; 3], degrees: f64) -> Self {
        let d = dot(axis, axis);
        let axis = if (d - 1.0).abs() >= 1e-10 {
            // `GfVec3d::Normalize`: times the reciprocal of the length.
            let r = 1.0 / d.sqrt();
            axis.map(|c| c * r)
        } else {
            axis
        };
        Rotation { axis, degrees }
    }

    /// `GfRotation(GfQuatd)` (`SetQuat`): `real` and `imaginary` parts.
    pub fn from_quat(real: f64, imaginary: [f64; 3]) -> Self {
        let len = dot(imaginary, imaginary).sqrt();
        if len <= MIN_VECTOR_LENGTH {
            return Rotation::new(AXES[0], 0.0);
        }
        let x = real.clamp(-1.0, 1.0).acos();
        let r = 1.0 / len;
        Rotation::new(
            imaginary.map(|c| c * r),
            2.0 * (x * (180.0 / std::f64::consts::PI)),
        )
    }

    /// `GfRotation::GetInverse`.
    pub fn inverse(self) -> Self {
        Rotation {
            degrees: -self.degrees,
            ..self
        }
    }

    /// `GfRotation::GetQuat`, `GfQuatd::GetNormalized`: the real part
    /// divided by the length, the imaginary times its reciprocal.
    fn quat(self) -> (f64, [f64; 3]) {
        let half = self.degrees * (std::f64::consts::PI / 180.0) / 2.0;
        let (s, c) = half.sin_cos();
        let i = self.axis.map(|a| a * s);
        let len = (c * c + dot(i, i)).sqrt();
        if len < MIN_VECTOR_LENGTH {
            return (1.0, [0.0; 3]);
        }
        let r = 1.0 / len;
        (c / len, i.map(|v| v * r))
    }

    /// `GfMatrix3d(GfRotation)` (`_SetRotateFromQuat`).
    fn matrix3(self) -> Matrix3 {
        let (r, i) = self.quat();
        [
            [
                1.0 - 2.0 * (i[1] * i[1] + i[2] * i[2]),
                2.0 * (i[0] * i[1] + i[2] * r),
                2.0 * (i[2] * i[0] - i[1] * r),
            ],
            [
                2.0 * (i[0] * i[1] - i[2] * r),
                1.0 - 2.0 * (i[2] * i[2] + i[0] * i[0]),
                2.0 * (i[1] * i[2] + i[0] * r),
            ],
            [
                2.0 * (i[2] * i[0] + i[1] * r),
                2.0 * (i[1] * i[2] - i[0] * r),
                1.0 - 2.0 * (i[1] * i[1] + i[0] * i[0]),
            ],
        ]
    }

    /// `GfMatrix4d(1).SetRotate(rotation)`.
    pub fn matrix(self) -> Matrix4 {
        embed(&self.matrix3())
    }
}

fn embed(r: &Matrix3) -> Matrix4 {
    let mut m = IDENTITY;
    for (row, src) in m.iter_mut().zip(r) {
        row[..3].copy_from_slice(src);
    }
    m
}

/// A three-axis rotation op (`rotateXYZ` and its kin): `order` names the
/// axes as the op does (`[0, 1, 2]` for XYZ, X applied first), each
/// axis's angle in `degrees` by axis; `inverse` for `!invert!`, which
/// negates the angles and reverses the product.
pub fn euler(degrees: [f64; 3], order: [usize; 3], inverse: bool) -> Matrix4 {
    let sign = if inverse { -1.0 } else { 1.0 };
    let r = |k: usize| Rotation::new(AXES[k], sign * degrees[k]).matrix3();
    let [a, b, c] = if inverse {
        [order[2], order[1], order[0]]
    } else {
        order
    };
    embed(&mul3(&mul3(&r(a), &r(b)), &r(c)))
}

/// `UsdGeomXformable::GetLocalTransformation`: the op matrices in the
/// order `xformOpOrder` lists them (the first outermost), multiplied from
/// the last, identities skipped.
pub fn compose(ops: &[Matrix4]) -> Matrix4 {
    let mut m = IDENTITY;
    for op in ops.iter().rev() {
        if *op != IDENTITY {
            m = mul(&m, op);
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quarter_turn_about_z_takes_x_to_y() {
        let m = Rotation::new(AXES[2], 90.0).matrix();
        // Row vector (1, 0, 0) times M is M's first row.
        assert!((m[0][0]).abs() < 1e-15 && (m[0][1] - 1.0).abs() < 1e-15);
    }

    #[test]
    fn pixar_s_row_vectors_are_glam_s_column_vectors() {
        let m = mul(
            &translate([1.0, 2.0, 3.0]),
            &Rotation::new(AXES[1], 30.0).matrix(),
        );
        let p = to_glam(&m).transform_point3(glam::DVec3::new(0.5, -1.0, 2.0));
        let row = [0.5, -1.0, 2.0, 1.0];
        for (k, v) in p.to_array().into_iter().enumerate() {
            let want: f64 = (0..4).map(|i| row[i] * m[i][k]).sum();
            assert!((v - want).abs() < 1e-12);
        }
    }

    #[test]
    fn an_inverted_euler_undoes_it() {
        let (d, o) = ([10.0, -35.0, 120.0], [2, 0, 1]);
        let m = mul(&euler(d, o, false), &euler(d, o, true));
        for (i, row) in m.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                assert!((v - IDENTITY[i][j]).abs() < 1e-12);
            }
        }
    }
}
