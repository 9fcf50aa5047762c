"""The dome light against Mitsuba 3: irradiance on the bunny under an HDR
lat-long map, shadowed by the bunny itself.

The map (512 x 256, made here) is a sky brighter towards the zenith, a
dim ground and a small sun some 2000 times brighter than the sky. The
toolkit's `illum` with a `dome` light of that map (SAMPLES directions a
point, shadows from the mesh) gives each of POINTS points scattered on
the bunny its irradiance; Mitsuba (llvm_ad_rgb) gives the same points
theirs from its own `envmap` emitter: MI_SAMPLES directions drawn by its
own importance sampling, weighted by its own `L / pdf`, times the cosine,
its own shadow rays (`ray_test`) against the same mesh. Printed: the
ratio of the sums (toolkit / Mitsuba) per channel, the points' relative
RMS difference, and both times; kept in benches/results/mitsuba_dome.json.

    python mitsuba_dome.py [POINTS] [SAMPLES] [MI_SAMPLES]

Mitsuba's LLVM variant needs LLVM 16 or newer (Debian's libllvm19, which
`make llvm` installs; Debian 12's default LLVM 14 fails with "Cannot
select: fminimum").
"""
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
if os.path.exists(LLVM):
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402
import numpy as np  # noqa: E402

mi.set_variant("llvm_ad_rgb")
ROOT = pathlib.Path(__file__).resolve().parents[2]
BIN = ROOT / "target" / "release"
MESH = ROOT / "fixtures" / "mesh" / "bunny.obj"
OUT = ROOT / "benches" / "results" / "mitsuba_dome.json"


def make_map(path, w=512, h=256):
    u = (np.arange(w) + 0.5) / w
    v = (np.arange(h) + 0.5) / h
    uu, vv = np.meshgrid(u, v)
    up = np.cos(np.pi * vv)  # the cosine of the angle to the zenith
    sky = np.where(up > 0, 0.2 + 0.8 * up, 0.05)
    img = np.stack([sky * 0.7, sky * 0.85, sky * 1.0], axis=-1)
    # The sun: a Gaussian spot at u = 0.3, 35 degrees above the horizon.
    du = np.minimum(abs(uu - 0.3), 1 - abs(uu - 0.3))
    sun = 2000.0 * np.exp(-(du**2 * 4 + (vv - (90 - 35) / 180) ** 2) / (2 * 0.006**2))
    img += np.stack([sun, sun * 0.9, sun * 0.75], axis=-1)
    mi.Bitmap(img.astype(np.float32)).write(str(path))


def read_ascii_ply(path):
    text = pathlib.Path(path).read_text()
    header, body = text.split("end_header\n", 1)
    names = [l.split()[-1] for l in header.splitlines() if l.startswith("property")]
    n = int([l for l in header.splitlines() if l.startswith("element vertex")][0].split()[-1])
    rows = np.array(body.split(), dtype=np.float64)[: n * len(names)].reshape(n, len(names))
    col = {k: rows[:, i] for i, k in enumerate(names)}
    return col


def toolkit(d, points, samples):
    run = lambda *a: subprocess.run([str(x) for x in a], check=True, cwd=d)
    subprocess.run(
        f"{BIN/'scatter'} -q {MESH} -n {points} --seed 1 | {BIN/'facet'} -q --mesh {MESH} -o cloud.ply",
        shell=True, check=True, cwd=d)
    (d / "lights.json").write_text(json.dumps(
        {"lights": [{"name": "sky", "type": "dome", "map": "map.exr", "samples": samples}]}))
    t = time.time()
    run(BIN / "illum", "-q", "cloud.ply", "--lights", "lights.json", "--mesh", MESH,
        "--format", "ascii", "-o", "lit.ply")
    secs = time.time() - t
    c = read_ascii_ply(d / "lit.ply")
    p = np.stack([c["x"], c["y"], c["z"]], 1)
    n = np.stack([c["nx"], c["ny"], c["nz"]], 1)
    e = np.stack([c["illum_r"], c["illum_g"], c["illum_b"]], 1)
    return p, n, e, secs


def mitsuba(d, p, n, spp):
    scene = mi.load_dict({
        "type": "scene",
        "bunny": {"type": "obj", "filename": str(MESH)},
        "sky": {"type": "envmap", "filename": str(d / "map.exr")},
    })
    env = scene.environment()
    t = time.time()
    m = len(p)
    idx = np.repeat(np.arange(m), spp)
    pn = p[idx]
    nn = (n / np.linalg.norm(n, axis=1, keepdims=True))[idx]
    si = dr.zeros(mi.SurfaceInteraction3f, len(idx))
    si.p = mi.Point3f(*[mi.Float(pn[:, k] + nn[:, k] * 1e-4) for k in range(3)])
    si.n = mi.Normal3f(*[mi.Float(nn[:, k]) for k in range(3)])
    si.sh_frame = mi.Frame3f(si.n)
    rng = np.random.default_rng(5)
    sample = mi.Point2f(mi.Float(rng.random(len(idx))), mi.Float(rng.random(len(idx))))
    ds, w = env.sample_direction(si, sample, True)
    c = dr.dot(ds.d, si.n)
    cos = dr.select(c > 0, c, 0.0)
    ray = si.spawn_ray(ds.d)
    seen = ~scene.ray_test(ray)
    contrib = w * cos * dr.select(seen, 1.0, 0.0)
    arr = np.array(contrib)  # (3, N) or (N, 3)
    arr = arr.T if arr.shape[0] == 3 and arr.shape[-1] != 3 else arr
    e = arr.reshape(m, spp, 3).mean(axis=1)
    return e, time.time() - t


def main():
    points = int(sys.argv[1]) if len(sys.argv) > 1 else 400
    samples = int(sys.argv[2]) if len(sys.argv) > 2 else 1024
    mi_spp = int(sys.argv[3]) if len(sys.argv) > 3 else 16384
    with tempfile.TemporaryDirectory() as tmp:
        d = pathlib.Path(tmp)
        make_map(d / "map.exr")
        p, n, e_tk, t_tk = toolkit(d, points, samples)
        e_mi, t_mi = mitsuba(d, p, n, mi_spp)
    ratio = e_tk.sum(0) / e_mi.sum(0)
    lit = e_mi[:, 1] > 1e-3 * e_mi[:, 1].max()
    rel = (e_tk[lit, 1] - e_mi[lit, 1]) / e_mi[lit, 1]
    row = {
        "points": points, "samples": samples, "mitsuba_samples": mi_spp,
        "ratio_of_sums": [round(float(x), 5) for x in ratio],
        "rms_rel_per_point": round(float(np.sqrt((rel**2).mean())), 4),
        "median_rel_per_point": round(float(np.median(rel)), 4),
        "toolkit_s": round(t_tk, 2), "mitsuba_s": round(t_mi, 2),
    }
    print(json.dumps(row))
    data = json.loads(OUT.read_text()) if OUT.exists() else {}
    data[f"{points} {samples} {mi_spp}"] = row
    OUT.write_text(json.dumps(data, indent=1) + "\n")


if __name__ == "__main__":
    main()
