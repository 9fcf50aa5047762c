"""Thin slabs lit from behind: the light the bake sends out of the front
face against Mitsuba 3's.

A slab WIDTH x WIDTH mean free paths wide and T thick (T in mean free
paths: 0.1, 0.5, 2 by default), filled with a medium of single-scattering
albedo ALPHA, mean free path 1, g 0, under an index-matched boundary (eta
1), lit from behind along its normal by a distant light of irradiance 1.
The figure is the radiance leaving the middle of the front face along the
normal: Mitsuba's volpath through a radiance meter looking at it (all
orders, and single scattering alone by `max_depth` 2); the bake's is `ssM
/ pi + ssS` averaged over the cloud's points on the front face within
WIDTH / 10 of its middle, after `make -C pipelines MODEL=physical` up to
sssingle (the camera straight in front, far away). The light that crosses
without scattering is not in either (a distant light is a direction no
meter sees).

    python mitsuba_thin.py [SPP] [T,..] [ALPHA,..] [COUNT]
    python mitsuba_thin.py --angles [SPP] [T,..] [ALPHA,..]
    python mitsuba_thin.py --slant [SPP] [T,..] [ALPHA]

`--angles`: Mitsuba's multiple scattering out of the front face at exit
cosines 1, 0.7, 0.4, 0.15, and its exitance over pi, `2 int L mu dmu` by
the trapezoid rule (L taken as the 0.15 value down to grazing): what the
bake's Lambertian `ssM / pi` is to be held against.

`--slant`: the light at cosine 1 and 0.5 with the normal, from behind
and from the front (the meter's side), multiple scattering along the
normal, bake over Mitsuba (not cached).

Mitsuba's figures are kept in benches/results/mitsuba_thin.json (by case
and sample count) and read from there when present.
"""
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
ROOT = pathlib.Path(__file__).resolve().parents[2]
WIDTH = 60.0
CACHE = ROOT / "benches" / "results" / "mitsuba_thin.json"
# More of the bake's make variables, separated by ';', from the
# environment: `BAKE_VARS='METHOD=walk;WALKS=64'`.
EXTRA = [v for v in os.environ.get("BAKE_VARS", "").split(";") if v]


def cached(key, compute):
    """Mitsuba's figure for `key`, measured once."""
    data = json.loads(CACHE.read_text()) if CACHE.exists() else {}
    if key not in data:
        t = time.time()
        data[key] = {"value": compute(), "seconds": round(time.time() - t, 1)}
        CACHE.write_text(json.dumps(dict(sorted(data.items())), indent=1) + "\n")
    return data[key]["value"]


def mitsuba(alpha, t, spp, max_depth=-1, mu=1.0, light=(0.0, 0.0, 1.0)):
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": max_depth, "rr_depth": 1_000_000},
        "light": {"type": "directional", "direction": list(light),
                  "irradiance": {"type": "rgb", "value": 1.0}},
        "slab": {
            "type": "cube",
            "to_world": mi.ScalarTransform4f().translate([0, 0, t / 2]).scale([WIDTH / 2, WIDTH / 2, t / 2]),
            "bsdf": {"type": "null"},
            "interior": {"type": "homogeneous", "albedo": {"type": "rgb", "value": alpha},
                         "sigma_t": 1.0, "phase": {"type": "hg", "g": 0.0}},
        },
        "meter": {
            "type": "radiancemeter", "origin": [(1 - mu * mu) ** 0.5, 0, t + mu],
            "direction": [-((1 - mu * mu) ** 0.5), 0, -mu],
            "film": {"type": "hdrfilm", "width": 1, "height": 1, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": spp},
        },
    })
    t0 = time.time()
    v = float(np.array(mi.render(scene, spp=spp)).ravel()[0])
    return v, time.time() - t0


def slab_obj(path, t):
    h = WIDTH / 2
    v = [(x, y, z) for z in (0.0, t) for y in (-h, h) for x in (-h, h)]
    # Outward faces (counter-clockwise seen from outside), 1-based.
    quads = [(1, 3, 4, 2), (5, 6, 8, 7), (1, 2, 6, 5), (3, 7, 8, 4), (1, 5, 7, 3), (2, 4, 8, 6)]
    path.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in v)
                    + "".join("f " + " ".join(map(str, q)) + "\n" for q in quads))


def bake(alpha, t, count, d, light=(0.0, 0.0, 1.0)):
    mesh, lights, cam = d / "slab.obj", d / "lights.json", d / "cam.json"
    slab_obj(mesh, t)
    lights.write_text(json.dumps({"lights": [{"name": "back", "type": "distant", "direction": list(light)}]}))
    cam.write_text(json.dumps({"position": [0, 0, 1e4], "look_at": [0, 0, 0], "up": [0, 1, 0],
                               "fov": 1, "width": 8, "height": 8}))
    out = d / "out"
    t0 = time.time()
    subprocess.run(["make", "-s", "-C", ROOT / "pipelines", f"MESH={mesh}", f"LIGHTS={lights}",
                    f"CAMERA={cam}", f"OUT={out}", f"COUNT={count}", "MODEL=physical",
                    f"ALBEDO={alpha}", "MFP=1", "ETA=1", "G=0", "SAMPLES=64", *EXTRA,
                    str(out / "slab_sss.ply")], check=True, stdout=subprocess.DEVNULL)
    took = time.time() - t0
    text = subprocess.run([ROOT / "target/release/pcconvert", "-q", out / "slab_sss.ply", "--format",
                           "ply-ascii"], check=True, capture_output=True, text=True).stdout
    header, body = text.split("end_header\n")
    names = [x.split()[-1] for x in header.splitlines() if x.startswith("property")]
    rows = np.loadtxt(body.splitlines()[: int(header.split("element vertex ")[1].split()[0])], ndmin=2)
    col = {n: rows[:, k] for k, n in enumerate(names)}
    front = (col["z"] > t - 1e-6) & (np.abs(col["x"]) < WIDTH / 10) & (np.abs(col["y"]) < WIDTH / 10)
    return float(col["ssM_r"][front].mean() / np.pi), float(col["ssS_r"][front].mean()), took


def angles(spp, ts, alphas):
    cosines = [1.0, 0.7, 0.4, 0.15]
    for t in ts:
        for a in alphas:
            multiple = [mitsuba(a, t, spp, -1, mu)[0] - mitsuba(a, t, spp, 2, mu)[0] for mu in cosines]
            xs, ys = [0.0] + cosines[::-1], [multiple[-1]] + multiple[::-1]
            f = [x * y for x, y in zip(xs, ys)]
            exit_over_pi = 2 * sum((xs[k + 1] - xs[k]) * (f[k] + f[k + 1]) / 2 for k in range(len(xs) - 1))
            print(f"thickness {t}, albedo {a}: multiple at cosines {cosines}: "
                  f"{[round(m, 4) for m in multiple]}; exitance / pi {exit_over_pi:.4f}", flush=True)


def slant(spp, ts, alpha, count=300000):
    for t in ts:
        for side, z in [("behind", 1.0), ("front", -1.0)]:
            for mu in [1.0, 0.5]:
                light = ((1 - mu * mu) ** 0.5 * z, 0.0, mu * z)
                m = mitsuba(alpha, t, spp, -1, 1.0, light)[0] - mitsuba(alpha, t, spp, 2, 1.0, light)[0]
                with tempfile.TemporaryDirectory() as dd:
                    b, _, _ = bake(alpha, t, count, pathlib.Path(dd), light)
                print(f"thickness {t}, lit from {side} at cosine {mu}: multiple along the normal: "
                      f"Mitsuba {m:.4f}, bake {b:.4f}, bake / Mitsuba {b / m:.3f}", flush=True)


if __name__ == "__main__":
    if "--slant" in sys.argv:
        args = [x for x in sys.argv[1:] if x != "--slant"]
        slant(int(args[0]) if args else 65536,
              [float(x) for x in (args[1] if len(args) > 1 else "0.5,2,30").split(",")],
              float(args[2]) if len(args) > 2 else 0.95)
        sys.exit()
    if "--angles" in sys.argv:
        args = [x for x in sys.argv[1:] if x != "--angles"]
        angles(int(args[0]) if args else 65536,
               [float(x) for x in (args[1] if len(args) > 1 else "0.5,2").split(",")],
               [float(x) for x in (args[2] if len(args) > 2 else "0.8").split(",")])
        sys.exit()
    spp = int(sys.argv[1]) if len(sys.argv) > 1 else 65536
    ts = [float(x) for x in (sys.argv[2] if len(sys.argv) > 2 else "0.1,0.5,2").split(",")]
    alphas = [float(x) for x in (sys.argv[3] if len(sys.argv) > 3 else "0.8,0.95").split(",")]
    count = int(sys.argv[4]) if len(sys.argv) > 4 else 300000
    print("| thickness (mfp) | albedo | Mitsuba all | Mitsuba single | Mitsuba multiple | bake all | "
          "bake ssS | bake ssM / pi | bake / Mitsuba |")
    print("|---|---|---|---|---|---|---|---|---|")
    for t in ts:
        for a in alphas:
            key = f"thickness {t} albedo {a} spp {spp}"
            m_all = cached(key + " all", lambda: mitsuba(a, t, spp)[0])
            m_one = cached(key + " single", lambda: mitsuba(a, t, spp, max_depth=2)[0])
            with tempfile.TemporaryDirectory() as dd:
                b_m, b_s, _ = bake(a, t, count, pathlib.Path(dd))
            print(f"| {t} | {a} | {m_all:.4f} | {m_one:.4f} | {m_all - m_one:.4f} | {b_m + b_s:.4f} | "
                  f"{b_s:.4f} | {b_m:.4f} | {(b_m + b_s) / m_all:.2f} |", flush=True)
