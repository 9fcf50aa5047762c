//! The dome light: radiance arriving from every direction, a constant
//! colour or a lat-long map (formats/LIGHTS.md#dome).
//!
//! A map is sampled in proportion to its luminance times the sine of its
//! rows' polar angle (their solid angle), by a marginal CDF over rows and
//! a conditional CDF over each row's columns (pbrt's piecewise-constant
//! 2-D distribution), and looked up at the same texels, so each sample's
//! weight `L / pdf` is exact for the map as it is drawn. A constant dome
//! is sampled by the cosine around the receiver's normal: unoccluded, its
//! samples sum to `pi L` with no variance.

use std::f64::consts::PI;
use std::sync::Arc;

use glam::DVec3;

/// The largest map side in texels.
pub const MAX_SIDE: usize = 1 << 15;

/// A lat-long map of radiance with its sampling tables.
pub struct LatLong {
    width: usize,
    height: usize,
    texels: Vec<[f32; 3]>,
    /// Marginal CDF over rows (height + 1 entries, 0 to 1).
    rows: Vec<f64>,
    /// Conditional CDF over each row's columns (width + 1 a row).
    cols: Vec<f64>,
    /// The map's file, and XXH3-128 of its texels (its identity in the
    /// lights' digest).
    name: String,
    digest: u128,
}

impl std::fmt::Debug for LatLong {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "LatLong({} x {}, {:032x})",
            self.width, self.height, self.digest
        )
    }
}

impl PartialEq for LatLong {
    fn eq(&self, other: &Self) -> bool {
        (self.width, self.height, self.digest) == (other.width, other.height, other.digest)
    }
}

/// Rec. 709 luminance.
fn luminance(c: [f32; 3]) -> f64 {
    0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64
}

/// A CDF from weights (running sum, normalised to end at 1); `None` when
/// they sum to zero.
fn cdf(w: impl Iterator<Item = f64>, out: &mut Vec<f64>) -> f64 {
    let start = out.len();
    out.push(0.0);
    let mut s = 0.0;
    for x in w {
        s += x;
        out.push(s);
    }
    if s > 0.0 {
        for c in &mut out[start..] {
            *c /= s;
        }
    }
    s
}

/// The bin of `x` in `cdf` (whose first entry is 0 and last 1), skipping
/// empty bins, and where in it `x` falls (0 to 1).
fn find(cdf: &[f64], x: f64) -> (usize, f64) {
    let n = cdf.len() - 1;
    let i = cdf.partition_point(|&c| c <= x).clamp(1, n) - 1;
    let w = cdf[i + 1] - cdf[i];
    let t = if w > 0.0 {
        ((x - cdf[i]) / w).clamp(0.0, 1.0 - f64::EPSILON)
    } else {
        0.5
    };
    (i, t)
}

impl LatLong {
    /// A map from its texels, row by row from the top (the up pole);
    /// `Err` says what is wrong with it.
    pub fn new(
        width: usize,
        height: usize,
        texels: Vec<[f32; 3]>,
        name: &str,
    ) -> std::result::Result<LatLong, String> {
        if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
            return Err(format!(
                "a map of {width} x {height} texels (each side 1 to {MAX_SIDE})"
            ));
        }
        if texels.len() != width * height {
            return Err(format!("{} texels for {width} x {height}", texels.len()));
        }
        if let Some(i) = texels
            .iter()
            .position(|t| !t.iter().all(|x| x.is_finite() && *x >= 0.0))
        {
            return Err(format!(
                "texel ({}, {}) is {:?}: radiance must be finite and >= 0",
                i % width,
                i / width,
                texels[i]
            ));
        }
        let mut rows = Vec::with_capacity(height + 1);
        let mut cols = Vec::with_capacity(height * (width + 1));
        let mut row_w = Vec::with_capacity(height);
        for y in 0..height {
            let row = &texels[y * width..(y + 1) * width];
            let sum = cdf(row.iter().map(|t| luminance(*t)), &mut cols);
            let sin = (PI * (y as f64 + 0.5) / height as f64).sin();
            row_w.push(sum * sin);
        }
        if cdf(row_w.into_iter(), &mut rows) <= 0.0 {
            return Err("the map is black: a dome that sends no light".into());
        }
        let bytes: Vec<u8> = texels
            .iter()
            .flat_map(|t| t.iter().flat_map(|x| x.to_le_bytes()))
            .collect();
        Ok(LatLong {
            width,
            height,
            digest: xxhash_rust::xxh3::xxh3_128(&bytes),
            texels,
            rows,
            cols,
            name: name.to_string(),
        })
    }

    /// The map's file.
    pub fn name(&self) -> &str {
        &self.name
    }

    fn texel(&self, u: f64, v: f64) -> [f32; 3] {
        let x = ((u * self.width as f64) as usize).min(self.width - 1);
        let y = ((v * self.height as f64) as usize).min(self.height - 1);
        self.texels[y * self.width + x]
    }

    /// A point `(u, v)` of the map drawn from `(a, b)` in [0, 1)^2, with
    /// its density over the unit square.
    fn sample(&self, a: f64, b: f64) -> (f64, f64, f64) {
        let (y, ty) = find(&self.rows, b);
        let row = &self.cols[y * (self.width + 1)..(y + 1) * (self.width + 1)];
        let (x, tx) = find(row, a);
        let p_row = self.rows[y + 1] - self.rows[y];
        let p_col = row[x + 1] - row[x];
        let pdf = p_row * p_col * (self.width * self.height) as f64;
        (
            (x as f64 + tx) / self.width as f64,
            (y as f64 + ty) / self.height as f64,
            pdf,
        )
    }

    /// The density over the unit square at `(u, v)`.
    fn pdf(&self, u: f64, v: f64) -> f64 {
        let x = ((u * self.width as f64) as usize).min(self.width - 1);
        let y = ((v * self.height as f64) as usize).min(self.height - 1);
        let row = &self.cols[y * (self.width + 1)..(y + 1) * (self.width + 1)];
        (self.rows[y + 1] - self.rows[y])
            * (row[x + 1] - row[x])
            * (self.width * self.height) as f64
    }
}

/// A dome: its map (none: constant) and orientation. The map's top row
/// is `up`; its column `u` looks along `zero cos(2 pi u) + right sin(2 pi
/// u)` (Mitsuba's `envmap`: with `up` +Y, `u = 0` looks along -Z and
/// `u = 1/4` along +X).
#[derive(Clone, Debug, PartialEq)]
pub struct Dome {
    pub map: Option<Arc<LatLong>>,
    pub up: DVec3,
    pub zero: DVec3,
    pub right: DVec3,
}

/// One direction drawn on a dome: where, and the radiance over the
/// density (per steradian) it was drawn with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Draw {
    pub dir: DVec3,
    pub weight: DVec3,
}

impl Dome {
    /// The dome of a file whose up axis is +Y, turned by `rotation`
    /// degrees about it (right-handed: +X towards -Z).
    pub fn new(map: Option<Arc<LatLong>>, rotation_deg: f64) -> Dome {
        let (s, c) = rotation_deg.to_radians().sin_cos();
        // Rotation about +Y by the angle: x' = c x + s z, z' = -s x + c z.
        let rot = |v: DVec3| DVec3::new(c * v.x + s * v.z, v.y, -s * v.x + c * v.z);
        Dome {
            map,
            up: DVec3::Y,
            zero: rot(-DVec3::Z),
            right: rot(DVec3::X),
        }
    }

    /// The direction of map point `(u, v)`.
    pub fn direction(&self, u: f64, v: f64) -> DVec3 {
        let (st, ct) = (PI * v).sin_cos();
        let (sp, cp) = (2.0 * PI * u).sin_cos();
        self.up * ct + (self.zero * cp + self.right * sp) * st
    }

    /// The map point `(u, v)` a direction looks at.
    pub fn uv(&self, d: DVec3) -> (f64, f64) {
        let v = d.dot(self.up).clamp(-1.0, 1.0).acos() / PI;
        let mut u = d.dot(self.right).atan2(d.dot(self.zero)) / (2.0 * PI);
        if u < 0.0 {
            u += 1.0;
        }
        (u.min(1.0 - f64::EPSILON), v)
    }

    /// The map's radiance (a multiplier of the light's `Cl`) towards `d`.
    pub fn radiance(&self, d: DVec3) -> DVec3 {
        match &self.map {
            None => DVec3::ONE,
            Some(m) => {
                let (u, v) = self.uv(d);
                DVec3::from_array(m.texel(u, v).map(f64::from))
            }
        }
    }

    /// The density (per steradian) with which [`Dome::draw`] draws `d`
    /// for a receiver with normal `n`.
    pub fn pdf(&self, d: DVec3, n: Option<DVec3>) -> f64 {
        match (&self.map, n) {
            (Some(m), _) => {
                let (u, v) = self.uv(d);
                let st = (PI * v).sin();
                if st <= 0.0 {
                    0.0
                } else {
                    m.pdf(u, v) / (2.0 * PI * PI * st)
                }
            }
            (None, Some(n)) => n.dot(d).max(0.0) / PI,
            (None, None) => 1.0 / (4.0 * PI),
        }
    }

    /// A direction drawn from `(a, b)` in [0, 1)^2: from the map by its
    /// luminance, else (constant) by the cosine about the receiver's
    /// normal `n`, or uniformly on the sphere when there is none (a point
    /// inside a medium).
    pub fn draw(&self, a: f64, b: f64, n: Option<DVec3>) -> Option<Draw> {
        match (&self.map, n) {
            (Some(m), _) => {
                let (u, v, pdf_uv) = m.sample(a, b);
                let st = (PI * v).sin();
                if pdf_uv <= 0.0 || st <= 0.0 {
                    return None;
                }
                let pdf = pdf_uv / (2.0 * PI * PI * st);
                let l = DVec3::from_array(m.texel(u, v).map(f64::from));
                Some(Draw {
                    dir: self.direction(u, v),
                    weight: l / pdf,
                })
            }
            (None, Some(n)) => {
                let (t1, t2) = crate::geom::tangent_basis(n);
                let (r, phi) = (a.sqrt(), 2.0 * PI * b);
                let z = (1.0 - a).max(0.0).sqrt();
                if z <= 0.0 {
                    return None;
                }
                let dir = n * z + t1 * (r * phi.cos()) + t2 * (r * phi.sin());
                Some(Draw {
                    dir,
                    weight: DVec3::splat(PI / z),
                })
            }
            (None, None) => {
                let z = 1.0 - 2.0 * a;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = 2.0 * PI * b;
                Some(Draw {
                    dir: DVec3::new(r * phi.cos(), r * phi.sin(), z),
                    weight: DVec3::splat(4.0 * PI),
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(w: usize, h: usize, f: impl Fn(f64, f64) -> f32) -> Arc<LatLong> {
        let t = (0..w * h)
            .map(|i| {
                let (u, v) = (
                    ((i % w) as f64 + 0.5) / w as f64,
                    ((i / w) as f64 + 0.5) / h as f64,
                );
                [f(u, v); 3]
            })
            .collect();
        Arc::new(LatLong::new(w, h, t, "test").unwrap())
    }

    #[test]
    fn directions_and_map_points_are_inverse_and_follow_mitsuba() {
        let d = Dome::new(None, 0.0);
        assert!((d.direction(0.0, 0.5) - -DVec3::Z).length() < 1e-12);
        assert!((d.direction(0.25, 0.5) - DVec3::X).length() < 1e-12);
        assert!((d.direction(0.3, 0.0) - DVec3::Y).length() < 1e-12);
        let r = Dome::new(None, 90.0);
        // Turned a quarter about +Y: -Z goes to -X.
        assert!((r.direction(0.0, 0.5) - -DVec3::X).length() < 1e-12);
        for (u, v) in [(0.1, 0.2), (0.7, 0.9), (0.5, 0.5), (0.99, 0.01)] {
            let (u2, v2) = r.uv(r.direction(u, v));
            assert!((u - u2).abs() < 1e-12 && (v - v2).abs() < 1e-12, "{u} {v}");
        }
    }

    #[test]
    fn the_draws_density_integrates_to_one_and_matches_pdf() {
        // A map with a bright spot and a dark half.
        let m = map(32, 16, |u, v| {
            if v > 0.5 {
                0.0
            } else {
                1.0 + 50.0 * (-((u - 0.3).powi(2) + (v - 0.2).powi(2)) / 0.002).exp() as f32
            }
        });
        let dome = Dome::new(Some(m), 30.0);
        // The pdf over the sphere integrates to 1 (midpoint rule).
        let (nu, nv) = (512, 256);
        let mut total = 0.0;
        for j in 0..nv {
            for i in 0..nu {
                let (u, v) = ((i as f64 + 0.5) / nu as f64, (j as f64 + 0.5) / nv as f64);
                let d = dome.direction(u, v);
                let dw = 2.0 * PI * PI * (PI * v).sin() / (nu * nv) as f64;
                total += dome.pdf(d, None) * dw;
            }
        }
        assert!((total - 1.0).abs() < 1e-3, "{total}");
        // A draw's weight is the radiance over pdf() at its direction.
        for k in 0..200 {
            let (a, b) = ((k as f64 * 0.618034) % 1.0, (k as f64 + 0.5) / 200.0);
            if let Some(s) = dome.draw(a, b, None) {
                let want = dome.radiance(s.dir) / dome.pdf(s.dir, None);
                assert!((s.weight - want).length() <= 1e-9 * want.length(), "{k}");
                assert!(s.dir.dot(dome.up) > -1e-9, "drew the black half");
            }
        }
    }

    #[test]
    fn a_black_or_bad_map_is_refused() {
        assert!(LatLong::new(2, 1, vec![[0.0; 3]; 2], "m").is_err());
        assert!(LatLong::new(2, 1, vec![[1.0, -1.0, 0.0]; 2], "m").is_err());
        assert!(LatLong::new(2, 1, vec![[f32::NAN; 3]; 2], "m").is_err());
        assert!(LatLong::new(2, 2, vec![[1.0; 3]; 2], "m").is_err());
        assert!(LatLong::new(0, 0, vec![], "m").is_err());
    }
}
