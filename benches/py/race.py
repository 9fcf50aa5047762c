"""The race (issue 58): CPU seconds (user + sys) to reach an image error
against a converged path-traced reference, the bake beside Mitsuba 3, at
film resolution.

The bunny scene of mitsuba_bunny.py (its mesh, two distant lights, the
medium of albedo 0.95, 0.85, 0.7 and mean free path 0.1 under an
index-matched boundary, Mitsuba's Gaussian pixel filter) at SIZE x SIZE
pixels. The reference is Mitsuba's volpath following every path
(`rr_depth` 1e6) as two independent halves of REF samples a pixel each
(different seeds), kept in target/race/ (a rerun reuses them). The
halves give the reference's own noise per pixel, `(h1 - h2)^2 / 4`, which
is taken out of each error: `rms^2 = mean(rel^2) - mean(noise^2 / ref^2)`
over the pixels the bunny covers whole in the bake and that are lit in
the reference, each channel a sample (the reference's own RMS noise is
printed). Beside it the same over the pixels brighter than a fifth of
the mean ("bright"): in the bunny's shadowed crease and face a small
difference is a large relative one, and the tenth of the pixels that
are darker hold most of the squared relative error.

Swept: Mitsuba over samples a pixel (CPU of this process), the bake
(`make -C pipelines`, its children's CPU) over points, with the kernel
and with walks, all with light between surfaces (`INDIRECT=16`). Cycles
(bpy) is not in the race yet.

    python race.py [SIZE] [REF] [SPPS] [BAKES]
    python race.py --views N [SIZE] [REF] [SPPS] [BAKE]

`--views N`: N views of the same lit bunny (the camera turned about the
vertical through its target by 360/N degrees at a time), one bake for
all (`ssM` once; `sssingle` and `render` again for each view, which is
all `make` redoes when only the camera changes) against N path traces;
the CPU summed over the views, the error their mean.

BAKES: `;`-separated runs, each `COUNT[,VAR=VALUE...]`, e.g.
`50000;50000,METHOD=walk,WALKS=16`. Rows go to benches/results/race.json
(for plot_error_time.py) when run with the default arguments.
"""
import json
import math
import os
import pathlib
import resource
import subprocess
import sys
import tempfile

import mitsuba as mi
import numpy as np

from mitsuba_bunny import ALBEDO, MESH, MFP, scene
from mitsuba_images import read_image

ROOT = pathlib.Path(__file__).resolve().parents[2]
CACHE = ROOT / "target" / "race"
RESULTS = ROOT / "benches" / "results" / "race.json"
BIN = os.environ.get("BIN", str(ROOT / "target" / "release"))


def cpu(who):
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def mitsuba(cam, spp, seed):
    """Mitsuba's picture at `spp` samples a pixel with `seed`, and its
    CPU seconds."""
    c0 = cpu(resource.RUSAGE_SELF)
    img = np.array(mi.render(mi.load_dict(scene(cam, spp)), spp=spp, seed=seed))[:, :, :3]
    return img, cpu(resource.RUSAGE_SELF) - c0


def reference(cam, size, ref_spp, tag=""):
    """The two halves of the reference, rendered once and kept."""
    CACHE.mkdir(parents=True, exist_ok=True)
    halves = []
    for seed in (1001, 2002):
        f = CACHE / f"bunny{tag}_{size}_{ref_spp}_{seed}.npy"
        if not f.exists():
            img, t = mitsuba(cam, ref_spp, seed)
            np.save(f, img)
            print(f"reference half {seed}: {ref_spp} spp, {t:.0f} s of CPU", flush=True)
        halves.append(np.load(f))
    return halves


def bake(cam_file, count, extra, d, size, keep=False, target=None):
    """The bake's picture, coverage and CPU seconds; with `keep` its
    folder stays for another view (`make` then redoes what the camera
    changes)."""
    out = d / "out"
    c0 = cpu(resource.RUSAGE_CHILDREN)
    subprocess.run(["make", "-s", "-C", ROOT / "pipelines", f"BIN={BIN}", f"MESH={MESH}",
                    f"CAMERA={cam_file}", f"OUT={out}", f"COUNT={count}", "MODEL=physical", "INDIRECT=16",
                    f"ALBEDO={','.join(map(str, ALBEDO))}", f"MFP={MFP}", "ETA=1", "G=0", "SPP=4",
                    "PIXEL_FILTER=gaussian", "SAMPLES=16", "SHADOWS=1"] + extra + ([target] if target else []),
                   check=True, stdout=subprocess.DEVNULL)
    took = cpu(resource.RUSAGE_CHILDREN) - c0
    img, a = read_image(out / "bunny.exr", d, size, pathlib.Path(BIN) / "pcconvert")
    if not keep:
        subprocess.run(["rm", "-rf", out], check=True)
    return img, a, took


def turned(cam, degrees):
    """`cam` turned about the vertical through its target."""
    t = math.radians(degrees)
    p, c = np.array(cam["position"], float), np.array(cam["look_at"], float)
    v = p - c
    r = np.array([v[0] * math.cos(t) + v[2] * math.sin(t), v[1], -v[0] * math.sin(t) + v[2] * math.cos(t)])
    return dict(cam, position=(c + r).tolist())


def views(n, size, ref_spp, spps, bake_spec):
    """One bake, `n` views, against `n` path traces."""
    base = dict(json.loads((ROOT / "fixtures/cameras/bunny.json").read_text()), width=size, height=size)
    cams = [turned(base, 360.0 * k / n) for k in range(n)]
    refs = [reference(c, size, ref_spp, f"_view{k}of{n}") for k, c in enumerate(cams)]
    count, *extra = bake_spec.split(",")
    found = {"bake": [], **{s: [] for s in spps}}
    cpu_of = {"bake": 0.0, **{s: 0.0 for s in spps}}
    with tempfile.TemporaryDirectory() as dd:
        d = pathlib.Path(dd)
        for k, (cam, (h1, h2)) in enumerate(zip(cams, refs)):
            ref, noise2 = (h1 + h2) / 2, (h1 - h2) ** 2 / 4
            cam_file = d / f"cam{k}.json"
            cam_file.write_text(json.dumps(cam))
            img, a, t = bake(cam_file, int(count), extra, d, size, keep=True, target=str(d / "out" / "bunny.exr"))
            cpu_of["bake"] += t
            mask = (a >= 1.0) & (ref.min(axis=2) > 1e-3)
            bright = mask & (ref.min(axis=2) > 0.2 * ref[mask].mean())
            found["bake"].append(error(img, ref, noise2, mask) + error(img, ref, noise2, bright))
            print(f"view {k}: bake {t:.1f} s, RMS {found['bake'][-1][0]:.3f}, bright {found['bake'][-1][2]:.3f}",
                  flush=True)
            for s in spps:
                img, t = mitsuba(cam, s, 7 + k)
                cpu_of[s] += t
                found[s].append(error(img, ref, noise2, mask) + error(img, ref, noise2, bright))
    print(f"{n} views at {size} x {size}; references: Mitsuba 2 x {ref_spp} spp each")
    print("| tool | setting | CPU, all views (s) | mean RMS | mean bright RMS |")
    print("|---|---|---|---|---|")
    rows = [("bake", " ".join([f"{int(count) // 1000}k points"] + extra), "bake")] + \
        [("Mitsuba", f"{s} spp", s) for s in spps]
    for tool, setting, key in rows:
        e = np.array(found[key])
        print(f"| {tool} | {setting} | {cpu_of[key]:.1f} | {e[:, 0].mean():.3f} | {e[:, 2].mean():.3f} |")


def error(img, ref, noise2, mask):
    """RMS relative error with the reference's noise taken out, and the
    mean relative error, over `mask`."""
    r = np.maximum(ref[mask], 1e-6)
    rel = (img[mask] - ref[mask]) / r
    ms = np.mean(rel ** 2) - np.mean(noise2[mask] / r ** 2)
    return float(np.sqrt(max(ms, 0.0))), float(np.mean(rel))


def main():
    args = sys.argv[1:]
    if args[:1] == ["--views"]:
        n = int(args[1])
        rest = args[2:]
        views(n, int(rest[0]) if rest else 256, int(rest[1]) if len(rest) > 1 else 64,
              [int(x) for x in (rest[2] if len(rest) > 2 else "16,64").split(",")],
              rest[3] if len(rest) > 3 else "50000")
        return
    size = int(args[0]) if args else 1024
    ref_spp = int(args[1]) if len(args) > 1 else 64
    spps = [int(x) for x in (args[2] if len(args) > 2 else "4,16,64").split(",")]
    bakes = (args[3] if len(args) > 3 else
             "50000;200000;50000,METHOD=walk,WALKS=16;50000,METHOD=walk,WALKS=64").split(";")
    cam = dict(json.loads((ROOT / "fixtures/cameras/bunny.json").read_text()), width=size, height=size)
    h1, h2 = reference(cam, size, ref_spp)
    ref, noise2 = (h1 + h2) / 2, (h1 - h2) ** 2 / 4
    rows = []
    print(f"{size} x {size}; reference: Mitsuba 2 x {ref_spp} spp", flush=True)
    print("| tool | setting | CPU (s) | RMS relative error | mean | bright: RMS | bright: mean |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as dd:
        d = pathlib.Path(dd)
        cam_file = d / "cam.json"
        cam_file.write_text(json.dumps(cam))
        mask = None
        for b in bakes:
            count, *extra = b.split(",")
            img, a, t = bake(cam_file, int(count), extra, d, size)
            if mask is None:
                mask = (a >= 1.0) & (ref.min(axis=2) > 1e-3)
                bright = mask & (ref.min(axis=2) > 0.2 * ref[mask].mean())
                rel_noise = np.sqrt(np.mean(noise2[mask] / np.maximum(ref[mask], 1e-6) ** 2))
                print(f"(the reference's own noise: {rel_noise:.3f} RMS relative; "
                      f"{int(mask.sum())} pixels compared, {int(bright.sum())} bright)", flush=True)
            e, f = error(img, ref, noise2, mask), error(img, ref, noise2, bright)
            setting = " ".join([f"{int(count) // 1000}k points"] + extra)
            rows.append({"tool": "bake, indirect", "setting": int(count), "extra": extra, "seconds": t,
                         "rms": e[0], "mean": e[1], "bright_rms": f[0], "bright_mean": f[1]})
            print(f"| bake | {setting} | {t:.1f} | {e[0]:.3f} | {e[1]:+.3f} | {f[0]:.3f} | {f[1]:+.3f} |",
                  flush=True)
        for s in spps:
            img, t = mitsuba(cam, s, 7)
            e, f = error(img, ref, noise2, mask), error(img, ref, noise2, bright)
            rows.append({"tool": "Mitsuba", "setting": s, "seconds": t, "rms": e[0], "mean": e[1],
                         "bright_rms": f[0], "bright_mean": f[1]})
            print(f"| Mitsuba | {s} spp | {t:.1f} | {e[0]:.3f} | {e[1]:+.3f} | {f[0]:.3f} | {f[1]:+.3f} |",
                  flush=True)
    if len(sys.argv) == 1:
        RESULTS.write_text(json.dumps({"reference_spp": 2 * ref_spp, "size": size, "rows": rows},
                                      indent=1) + "\n")


if __name__ == "__main__":
    main()
