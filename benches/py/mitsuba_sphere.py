"""The physical model's picture of a sphere against Mitsuba 3's, and the
error of each against time.

A sphere of radius 1 (a 256 x 128 latitude-longitude mesh for the bake,
Mitsuba's exact sphere for the path tracer), filled with a medium of
single-scattering albedo ALBEDO, mean free path MFP, g 0, under an
index-matched boundary (eta 1: a directional light is then reachable by
Mitsuba's light sampling), lit by a distant light from above and in
front, seen by a 64 x 64 pinhole camera (Mitsuba's Gaussian pixel
filter in both: the bake's 16 rays a pixel weighed by it). The reference is Mitsuba at REF samples a pixel. For the bake
(`make -C pipelines MODEL=physical`: scatter, facet, illum, ssmulti,
sssingle, render with 16 rays a pixel) at each point count, and for
Mitsuba at each sample count: the wall time and the RMS and mean relative
error of the beauty over the pixels the sphere covers whole.

    python mitsuba_sphere.py [REF] [COUNTS] [SPPS]
    python mitsuba_sphere.py --split [REF] [COUNT]

`--split`: where the bake's error is, at one point count: its `ssS` and
`ssM` pictures apart against Mitsuba's single scattering (the path cut
after one event) and the rest, the beauty's RMS and mean, and the bake
over Mitsuba by quarters of the reference's brightness (from the
terminator to the lit pole), all and the multiple part (the references
kept in target/ for the next run).
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

from mitsuba_images import camera, errors, read_image, render_attr, RR_DEPTH

mi.set_variant("scalar_rgb")
ROOT = pathlib.Path(__file__).resolve().parents[2]
# More of the bake's Makefile variables, `;`-separated, from the
# environment: `BAKE_VARS='FALLOFF=burley --sigma 9;NORMALS=flat'`.
EXTRA = [v for v in os.environ.get("BAKE_VARS", "").split(";") if v]
# The rows of the last full run (error against time), for plot_error_time.py.
RESULTS = ROOT / "benches" / "results" / "mitsuba_sphere.json"
ALBEDO, MFP = 0.95, 0.05
SIZE = 64
LIGHT = [0.0, -0.6, -0.8]  # the light's travel direction (unit)
CAMERA = {"position": [0, 0, 4], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 40,
          "width": SIZE, "height": SIZE}


def mitsuba(spp, max_depth=-1):
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": max_depth, "rr_depth": RR_DEPTH},
        "light": {"type": "directional", "direction": LIGHT,
                  "irradiance": {"type": "rgb", "value": 1.0}},
        "ball": {
            "type": "sphere", "radius": 1.0, "bsdf": {"type": "null"},
            "interior": {"type": "homogeneous", "albedo": {"type": "rgb", "value": ALBEDO},
                         "sigma_t": 1.0 / MFP, "phase": {"type": "hg", "g": 0.0}},
        },
        "camera": camera(CAMERA, spp),
    })
    t = time.time()
    img = np.array(mi.render(scene, spp=spp))
    return img[:, :, :3], time.time() - t


def sphere_obj(path, nu=256, nv=128):
    lines = []
    for j in range(1, nv):
        th = np.pi * j / nv
        for i in range(nu):
            ph = 2 * np.pi * i / nu
            lines.append(f"v {np.sin(th) * np.cos(ph)} {np.cos(th)} {np.sin(th) * np.sin(ph)}")
    lines.append("v 0 1 0")
    lines.append("v 0 -1 0")
    top, bot = nu * (nv - 1) + 1, nu * (nv - 1) + 2
    idx = lambda j, i: (j - 1) * nu + (i % nu) + 1
    for i in range(nu):
        lines.append(f"f {top} {idx(1, i + 1)} {idx(1, i)}")
        lines.append(f"f {bot} {idx(nv - 1, i)} {idx(nv - 1, i + 1)}")
    for j in range(1, nv - 1):
        for i in range(nu):
            lines.append(f"f {idx(j, i)} {idx(j, i + 1)} {idx(j + 1, i + 1)} {idx(j + 1, i)}")
    path.write_text("\n".join(lines) + "\n")


def bake(count, d):
    mesh, lights, cam = d / "sphere.obj", d / "lights.json", d / "cam.json"
    if not mesh.exists():
        sphere_obj(mesh)
        lights.write_text(json.dumps({"lights": [{"name": "sun", "type": "distant", "intensity": 1.0,
                                                  "direction": LIGHT}]}))
        cam.write_text(json.dumps(CAMERA))
    out = d / f"out{count}"
    t = time.time()
    subprocess.run(["make", "-s", "-C", ROOT / "pipelines", f"MESH={mesh}", f"LIGHTS={lights}",
                    f"CAMERA={cam}", f"OUT={out}", f"COUNT={count}", "MODEL=physical",
                    f"ALBEDO={ALBEDO}", f"MFP={MFP}", "ETA=1", "G=0", "SPP=16", "PIXEL_FILTER=gaussian", "SAMPLES=16",
                    "SHADOWS=1"] + EXTRA, check=True, stdout=subprocess.DEVNULL)
    took = time.time() - t
    img, a = read_image(out / "sphere.exr", d, SIZE)
    return img, a, took


def split(ref_spp, count):
    # The references kept for the next run (each takes minutes).
    kept = ROOT / "target" / f"mitsuba_sphere_split_{ref_spp}.npz"
    if kept.exists():
        z = np.load(kept)
        ref, single = z["ref"], z["single"]
    else:
        ref, _ = mitsuba(ref_spp)
        single, _ = mitsuba(ref_spp, max_depth=2)
        kept.parent.mkdir(parents=True, exist_ok=True)
        np.savez(kept, ref=ref, single=single)
    with tempfile.TemporaryDirectory() as dd:
        d = pathlib.Path(dd)
        img, a, _ = bake(count, d)
        out = d / f"out{count}"
        mask = (a >= 1.0) & (ref.min(axis=2) > 1e-3)
        part = {}
        for attr in ["ssM", "ssS"]:
            exr = d / f"{attr}.exr"
            render_attr(out, "sphere", d / "cam.json", attr, exr)
            part[attr] = read_image(exr, d, SIZE)[0]
    print(f"single scattering: bake {part['ssS'][mask].mean():.4f}, Mitsuba {single[mask].mean():.4f}")
    print(f"multiple scattering (ssM / pi): bake {part['ssM'][mask].mean():.4f}, "
          f"Mitsuba {(ref - single)[mask].mean():.4f}")
    e = errors(img, ref, mask)
    print(f"the beauty: RMS {e[0]:.3f}, mean {e[1]:+.3f}")
    # The multiple part: the beauty less the bake's ssS, Mitsuba's less
    # its single scattering.
    r, b = ref[mask][:, 0], img[mask][:, 0]
    rm, bm = (ref - single)[mask][:, 0], (img - part["ssS"])[mask][:, 0]
    print(f"multiple scattering, bake / Mitsuba: {bm.mean() / rm.mean():.3f}")
    q = np.quantile(r, [0, 0.25, 0.5, 0.75, 1])
    for lo, hi in zip(q[:-1], q[1:]):
        s = (r >= lo) & (r <= hi)
        print(f"reference in [{lo:.4f}, {hi:.4f}]: bake / Mitsuba {b[s].mean() / r[s].mean():.3f}, "
              f"multiple {bm[s].mean() / rm[s].mean():.3f}")


if __name__ == "__main__":
    if "--split" in sys.argv:
        args = [x for x in sys.argv[1:] if x != "--split"]
        split(int(args[0]) if args else 1024, int(args[1]) if len(args) > 1 else 200000)
        sys.exit()
    ref_spp = int(sys.argv[1]) if len(sys.argv) > 1 else 1024
    counts = [int(x) for x in (sys.argv[2] if len(sys.argv) > 2 else "50000,200000,1000000").split(",")]
    spps = [int(x) for x in (sys.argv[3] if len(sys.argv) > 3 else "4,16,64").split(",")]
    ref, ref_t = mitsuba(ref_spp)
    print(f"reference: Mitsuba {ref_spp} spp, {ref_t:.0f} s, mean {ref.mean(axis=(0, 1))}", flush=True)
    print("| tool | setting | time (s) | RMS relative error | mean relative error |")
    print("|---|---|---|---|---|")
    rows = []
    with tempfile.TemporaryDirectory() as dd:
        d = pathlib.Path(dd)
        mask = None
        for n in counts:
            img, a, t = bake(n, d)
            if mask is None:
                # Pixels the sphere covers whole in the bake, lit in the reference.
                mask = (a >= 1.0) & (ref.min(axis=2) > 1e-3)
            e = errors(img, ref, mask)
            rows.append({"tool": "bake", "setting": n, "seconds": t, "rms": e[0], "mean": e[1]})
            print(f"| bake | {n} points | {t:.1f} | {e[0]:.3f} | {e[1]:+.3f} |", flush=True)
        for s in spps:
            img, t = mitsuba(s)
            e = errors(img, ref, mask)
            rows.append({"tool": "Mitsuba", "setting": s, "seconds": t, "rms": e[0], "mean": e[1]})
            print(f"| Mitsuba | {s} spp | {t:.1f} | {e[0]:.3f} | {e[1]:+.3f} |", flush=True)
        print(f"({int(mask.sum())} pixels compared)")
    if not EXTRA:  # (a variant's rows are printed, not kept)
        RESULTS.write_text(json.dumps({"reference_spp": ref_spp, "rows": rows}, indent=1) + "\n")
