//! `ssmulti` against a plain f64 double loop written here, closed forms
//! (the plane, the kernel integrals, the lit pole of a sphere),
//! invariance under translation and scale, and bad input: one file a
//! concern, the shared clouds and the double loop here.

use std::f64::consts::PI;

use glam::DVec3;
use rand_core::RngCore;
use rand_pcg::Pcg32;

use crate::util::*;
use pcsss::cloud::Role;
use pcsss::progress::Progress;
use pcsss::stages::ssmulti::{self, burley, Falloff, Norm, Params, BURLEY_KAPPA};
use pcsss::Cloud;

mod approx;
mod closed_form;
mod exact;
mod nee;
mod physical;
mod pipe;
mod scale;
mod walk;

pub(super) fn unit(r: &mut Pcg32) -> f64 {
    r.next_u32() as f64 / 4294967296.0
}

/// A cloud from columns: f64 positions, f32 normals, ptarea, illum.
pub(super) fn cloud_of(p: &[[f64; 3]], n: &[[f64; 3]], a: &[f64], e: &[[f64; 3]]) -> Cloud {
    let mut c = Cloud::with_points(p.len());
    let pts = c.points_mut();
    pts.set_vec3("P", Role::Point, p).unwrap();
    let n32: Vec<[f32; 3]> = n.iter().map(|v| v.map(|x| x as f32)).collect();
    pts.set_vec3("N", Role::Normal, &n32).unwrap();
    pts.set_scalar("ptarea", a.iter().map(|&x| x as f32).collect::<Vec<f32>>())
        .unwrap();
    let e32: Vec<[f32; 3]> = e.iter().map(|v| v.map(|x| x as f32)).collect();
    pts.set_vec3("illum", Role::Color, &e32).unwrap();
    c
}

pub(super) fn run(c: &Cloud, p: &Params) -> Vec<[f64; 3]> {
    let mut c = c.clone();
    ssmulti::ssmulti(&mut c, p, &Progress::hidden()).unwrap();
    c.points().vec3_f64("ssM").unwrap()
}

/// docs/DESIGN.md's loop, in f64, every pair, written from the text.
pub(super) fn brute(c: &Cloud, p: &Params) -> Vec<[f64; 3]> {
    let pos = c.points().vec3_f64("P").unwrap();
    let nrm = c.points().vec3_f64("N").unwrap();
    let area = c.points().scalar_f64("ptarea").unwrap();
    let illum = c.points().vec3_f64("illum").unwrap();
    let ld: Vec<f64> = p.rd.iter().map(|r| r * p.sd).collect();
    let ld1 = ld.iter().copied().fold(0.0, f64::max);
    let w = |r: f64, d: f64, i: usize| ssmulti::falloff(p.falloff, r, d, burley::rmin(area[i]));
    // Norm::Source: each point's kernel-weighted area within reach (its
    // neighbours' r_min, as Local's sum).
    let reached: Vec<[f64; 3]> = if p.norm == Norm::Source {
        (0..pos.len())
            .map(|i| {
                let xi = DVec3::from_array(pos[i]);
                let mut a = [0.0; 3];
                for o in 0..pos.len() {
                    let r = (xi - DVec3::from_array(pos[o])).length();
                    for c in 0..3 {
                        let d = if p.rgb { ld[c] } else { ld1 };
                        if d > 0.0 && r <= d {
                            a[c] += area[o] * w(r, d, o);
                        }
                    }
                }
                a
            })
            .collect()
    } else {
        vec![[1.0; 3]; pos.len()]
    };
    let unit_normals: Vec<DVec3> = nrm
        .iter()
        .map(|n| DVec3::from_array(*n).normalize())
        .collect();
    let mut out = Vec::new();
    for o in 0..pos.len() {
        let xo = DVec3::from_array(pos[o]);
        let no = unit_normals[o];
        let mut ssm = [0.0; 3];
        let mut loc = [0.0; 3];
        for i in 0..pos.len() {
            let xi = DVec3::from_array(pos[i]);
            let r = (xo - xi).length();
            if r > ld1 || ld1 == 0.0 {
                continue;
            }
            let ni = unit_normals[i];
            let li = (xo - xi) / ld1;
            let kb = 1.0 - (1.0 - no.dot(ni)) * (1.0 - no.dot(li)) / 2.0;
            let kb = 1.0 + p.bounce * (kb - 1.0);
            for c in 0..3 {
                let d = if p.rgb { ld[c] } else { ld1 };
                if d <= 0.0 || r > d {
                    continue;
                }
                let wi = w(r, d, i);
                if kb > 0.0 && reached[i][c] > 0.0 {
                    ssm[c] += kb * illum[i][c] * area[i] * wi / reached[i][c];
                }
                loc[c] += area[i] * wi;
            }
        }
        let i1 = ssmulti::disk_integral(p.falloff, ld1);
        let mut v = [0.0; 3];
        for c in 0..3 {
            v[c] = match (p.norm, p.rgb) {
                (Norm::Seed, false) | (Norm::Channel, false) => p.rd[c] * ssm[c] / i1,
                (Norm::Seed, true) => ssm[c] / i1,
                (Norm::Channel, true) if ld[c] > 0.0 => {
                    p.rd[c] * ssm[c] / ssmulti::disk_integral(p.falloff, ld[c])
                }
                (Norm::Channel, true) => 0.0,
                (Norm::Local, _) if loc[c] > 0.0 => p.rd[c] * ssm[c] / loc[c],
                (Norm::Local, _) => 0.0,
                (Norm::Source, _) => p.rd[c] * ssm[c],
            };
        }
        out.push(v);
    }
    out
}

/// A wavy sheet folded into a half-tube: neighbours facing many ways
/// (bounce matters), f64 positions around `offset`, random areas and
/// light, some points unlit.
pub(crate) fn wavy(n: usize, offset: DVec3, scale: f64, seed: u64) -> Cloud {
    let mut r = Pcg32::new(seed, 0);
    let (mut p, mut nn, mut a, mut e) = (vec![], vec![], vec![], vec![]);
    for k in 0..n {
        let u = unit(&mut r) * PI;
        let v = unit(&mut r) * 2.0;
        let rad = 1.0 + 0.1 * (5.0 * v).sin();
        let q = DVec3::new(rad * u.cos(), v, rad * u.sin());
        p.push((offset + q * scale).to_array());
        nn.push([u.cos(), 0.1 * (unit(&mut r) - 0.5), u.sin()]);
        a.push((0.5 + unit(&mut r)) * 2.0 * PI / n as f64 * scale * scale);
        if k % 5 == 0 {
            e.push([0.0; 3]);
        } else {
            e.push([unit(&mut r), unit(&mut r), 2.0 * unit(&mut r)]);
        }
    }
    cloud_of(&p, &nn, &a, &e)
}

pub(super) fn falloffs() -> [Falloff; 4] {
    [
        Falloff::Smooth,
        Falloff::Exp { sigma: 3.0 },
        Falloff::Exp { sigma: 1e-6 },
        Falloff::Burley {
            kappa: BURLEY_KAPPA,
        },
    ]
}

pub(super) fn rel_err(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(1e-30)
}

/// `c` under white light: every `illum` its first channel three times.
pub(super) fn white(c: &Cloud) -> Cloud {
    let mut c = c.clone();
    let e: Vec<[f32; 3]> = c
        .points()
        .vec3_f64("illum")
        .unwrap()
        .iter()
        .map(|v| [v[0] as f32; 3])
        .collect();
    c.points_mut().set_vec3("illum", Role::Color, &e).unwrap();
    c
}

/// A square grid of `k` x `k` points of spacing `h` on z = 0, area `h^2`
/// each, uniform light `e`.
pub(super) fn grid(k: usize, h: f64, e: [f64; 3], jitter: f64, seed: u64) -> Cloud {
    let mut r = Pcg32::new(seed, 1);
    let (mut p, mut n, mut a, mut l) = (vec![], vec![], vec![], vec![]);
    for i in 0..k {
        for j in 0..k {
            let dx = jitter * (unit(&mut r) - 0.5) * h;
            let dy = jitter * (unit(&mut r) - 0.5) * h;
            p.push([i as f64 * h + dx, j as f64 * h + dy, 0.0]);
            n.push([0.0, 0.0, 1.0]);
            a.push(h * h);
            l.push(e);
        }
    }
    cloud_of(&p, &n, &a, &l)
}

/// Composite Gauss-Legendre (5 points) of `f` on [0, d] in `m` pieces.
pub(super) fn quad(f: impl Fn(f64) -> f64, d: f64, m: usize) -> f64 {
    let x = [
        0.0,
        -0.538_469_310_105_683,
        0.538_469_310_105_683,
        -0.906_179_845_938_664,
        0.906_179_845_938_664,
    ];
    let w = [
        0.568_888_888_888_889,
        0.478_628_670_499_366,
        0.478_628_670_499_366,
        0.236_926_885_056_189,
        0.236_926_885_056_189,
    ];
    let h = d / m as f64;
    let mut s = 0.0;
    for k in 0..m {
        let c = (k as f64 + 0.5) * h;
        for j in 0..5 {
            s += w[j] * f(c + x[j] * h / 2.0) * h / 2.0;
        }
    }
    s
}

/// `a` and `b` as one cloud, `a`'s points first.
pub(super) fn joined(a: &Cloud, b: &Cloud) -> Cloud {
    let cols = |c: &Cloud| {
        let pts = c.points();
        (
            pts.vec3_f64("P").unwrap(),
            pts.vec3_f64("N").unwrap(),
            pts.scalar_f64("ptarea").unwrap(),
            pts.vec3_f64("illum").unwrap(),
        )
    };
    let (mut p, mut n, mut ar, mut e) = cols(a);
    let (p2, n2, a2, e2) = cols(b);
    p.extend(p2);
    n.extend(n2);
    ar.extend(a2);
    e.extend(e2);
    cloud_of(&p, &n, &ar, &e)
}

/// Sums and report of `c`.
pub(super) fn run_report(c: &Cloud, p: &Params) -> (Vec<[f64; 3]>, ssmulti::Report) {
    let mut c = c.clone();
    let r = ssmulti::ssmulti(&mut c, p, &Progress::hidden()).unwrap();
    (c.points().vec3_f64("ssM").unwrap(), r)
}
