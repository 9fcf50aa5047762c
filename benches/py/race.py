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

Blender Cycles (bpy, cycles_bunny.py: Random Walk given the same
medium, 2 threads) is the second path tracer, with its own reference
(two halves of CREF samples a pixel, 2 x 128 by default). Its walk does
not refract at the boundary as Mitsuba's (and the bake's) medium does
(cycles_bunny.py says how), so each picture is measured against both
references, and each path tracer against its own; the two references'
difference is printed.

Swept: each path tracer over samples a pixel (CPU of this process;
Cycles also with its denoiser, OpenImageDenoise), the bake (`make -C
pipelines`, its children's CPU) over points, with the kernel and with
walks, all with light between surfaces (`INDIRECT=16`; walks that sample
the lights follow it themselves, and `make` does not use `INDIRECT`).

    python race.py [--scene NAME] [SIZE] [REF] [SPPS] [BAKES] [CREF]
    python race.py [--scene NAME] --views N [SIZE] [REF] [SPPS] [BAKE] [CREF]
    python race.py [--scene NAME] --wide [REF] [SPPS] [BAKES]
    python race.py [--scene NAME] --plot   # race.png again from race.json

`--scene`: race_scenes.py's `bunny` (the default), `suzanne` (skin1,
both ears lit from behind) or `dragon` (thin claws, horns and crest),
each with its own lights, camera and medium; SIZE defaults to 1024 for
the bunny, 512 for the others. `--save` (anywhere): the rows go to
benches/results/race.json (the bunny) or race_NAME.json, with the plot.
`--merge` (with `--save`): the run's rows replace the saved rows of the
same tool and setting, and the others stay (e.g. bakes redone, with
SPPS `-`: no path tracer runs but the cached references).

`--wide`: one frame at 1920 x 1080 (the bunny camera's vertical field of
view, wider), against Cycles alone (2 x CREF samples a pixel).

`--views N`: N views of the same lit bunny (the camera turned about the
vertical through its target by 360/N degrees at a time), one bake for
all (`ssM` once; `sssingle` and `render` again for each view, which is
all `make` redoes when only the camera changes) against N path traces;
the CPU summed over the views, the error their mean.

BAKES: `;`-separated runs, each `COUNT[,VAR=VALUE...]`, e.g.
`50000;50000,METHOD=walk,WALKS=16`.
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

from mitsuba_bunny import scene
from mitsuba_images import read_image
from race_scenes import SCENES

ROOT = pathlib.Path(__file__).resolve().parents[2]
CACHE = ROOT / "target" / "race"
RESULTS = ROOT / "benches" / "results" / "race.json"
BIN = os.environ.get("BIN", str(ROOT / "target" / "release"))
TRACERS = ("Mitsuba", "Cycles")
# The scene raced (race_scenes.py), its mesh made or fetched once; set by
# main from `--scene`.
NAME = "bunny"
SCENE = None


def use(name):
    """Race race_scenes.py's scene `name` from here on."""
    global NAME, SCENE
    if name not in SCENES:
        raise SystemExit(f"--scene {name}: one of {', '.join(SCENES)}")
    NAME = name
    SCENE = dict(SCENES[name], mesh=SCENES[name]["mesh"]())


def cpu(who):
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def trace(tracer, cam, spp, seed, denoise=False):
    """A path tracer's picture at `spp` samples a pixel with `seed`, and
    its CPU seconds."""
    if tracer == "Cycles":
        import cycles_bunny
        return cycles_bunny.render(cam, spp, seed, denoise, scn=SCENE)
    c0 = cpu(resource.RUSAGE_SELF)
    img = np.array(mi.render(mi.load_dict(scene(cam, spp, sc=SCENE)), spp=spp, seed=seed))[:, :, :3]
    return img, cpu(resource.RUSAGE_SELF) - c0


def reference(tracer, cam, ref_spp, tag=""):
    """The two halves of a path tracer's reference, rendered once and
    kept; (mean, noise^2 per pixel)."""
    CACHE.mkdir(parents=True, exist_ok=True)
    halves = []
    prefix = "" if tracer == "Mitsuba" else tracer.lower() + "_"
    for seed in (1001, 2002):
        f = CACHE / f"{prefix}{NAME}{tag}_{cam['width']}x{cam['height']}_{ref_spp}_{seed}.npy"
        old = CACHE / f"{prefix}{NAME}{tag}_{cam['width']}_{ref_spp}_{seed}.npy"
        if cam["width"] == cam["height"] and old.exists():
            f = old
        if not f.exists():
            img, t = trace(tracer, cam, ref_spp, seed)
            np.save(f, img)
            print(f"{tracer} reference half {seed}: {ref_spp} spp, {t:.0f} s of CPU", flush=True)
        halves.append(np.load(f))
    h1, h2 = halves
    return (h1 + h2) / 2, (h1 - h2) ** 2 / 4


def bake(cam_file, count, extra, d, cam, keep=False, target=None):
    """The bake's picture, coverage and CPU seconds; with `keep` its
    folder stays for another view (`make` then redoes what the camera
    changes)."""
    out = d / "out"
    lights = d / "lights.json"
    # (Rewritten only when it changes: a newer lights file would redo the
    # lighting for another view of the same bake.)
    text = json.dumps({"lights": SCENE["lights"]})
    if not lights.exists() or lights.read_text() != text:
        lights.write_text(text)
    c0 = cpu(resource.RUSAGE_CHILDREN)
    subprocess.run(["make", "-s", "-C", ROOT / "pipelines", f"BIN={BIN}", f"MESH={SCENE['mesh']}",
                    f"LIGHTS={lights}", f"CAMERA={cam_file}", f"OUT={out}", f"COUNT={count}", "MODEL=physical",
                    "INDIRECT=16", f"ALBEDO={','.join(map(str, SCENE['albedo']))}",
                    f"MFP={','.join(map(str, SCENE['mfp']))}", "ETA=1", "G=0", "SPP=4",
                    "PIXEL_FILTER=gaussian", "SAMPLES=16", "SHADOWS=1"] + extra + ([target] if target else []),
                   check=True, stdout=subprocess.DEVNULL)
    took = cpu(resource.RUSAGE_CHILDREN) - c0
    img, a = read_image(out / f"{pathlib.Path(SCENE['mesh']).stem}.exr", d, (cam["width"], cam["height"]), pathlib.Path(BIN) / "pcconvert")
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


class Judge:
    """Errors of a picture against each reference, over the pixels the
    bake covers whole and that are lit in that reference (and the bright
    ones among them)."""

    def __init__(self, refs, coverage):
        self.refs = refs
        self.masks = {}
        for t, (ref, _) in refs.items():
            mask = (coverage >= 1.0) & (ref.min(axis=2) > 1e-3)
            self.masks[t] = (mask, mask & (ref.min(axis=2) > 0.2 * ref[mask].mean()))

    def __call__(self, img):
        """{tracer: (rms, mean, bright rms, bright mean)}"""
        found = {}
        for t, (ref, noise2) in self.refs.items():
            mask, bright = self.masks[t]
            found[t] = error(img, ref, noise2, mask) + error(img, ref, noise2, bright)
        return found

    def describe(self):
        for t, (ref, noise2) in self.refs.items():
            mask, bright = self.masks[t]
            own = np.sqrt(np.mean(noise2[mask] / np.maximum(ref[mask], 1e-6) ** 2))
            whose = t + ("'" if t.endswith("s") else "'s")
            print(f"({whose} reference: own noise {own:.3f} RMS relative; {int(mask.sum())} pixels "
                  f"compared, {int(bright.sum())} bright)", flush=True)
        if len(self.refs) == 2:
            (a, (ra, na)), (b, (rb, nb)) = self.refs.items()
            mask, bright = self.masks[a]
            e = error(rb, ra, na + nb, mask) + error(rb, ra, na + nb, bright)
            print(f"({b}' reference against {a}'s, both noises out: RMS {e[0]:.3f} (mean {e[1]:+.3f}), "
                  f"bright {e[2]:.3f} ({e[3]:+.3f}))", flush=True)


def sweep(tracers, spps):
    """(tracer, spp, denoise) rows of the path tracers' sweep."""
    rows = []
    for t in tracers:
        for s in spps:
            rows.append((t, s, False))
            if t == "Cycles":
                rows.append((t, s, True))
    return rows


def label(tracer, spp, denoise):
    return f"{tracer}{', denoised' if denoise else ''}", f"{spp} spp"


def views(n, size, ref_spp, spps, bake_spec, cref, tracers):
    """One bake, `n` views, against `n` path traces of each tracer."""
    base = dict(SCENE["camera"], width=size, height=size)
    cams = [turned(base, 360.0 * k / n) for k in range(n)]
    count, *extra = bake_spec.split(",")
    runs = [("bake", None, None)] + sweep(tracers, spps)
    found = {r: [] for r in runs}
    cpu_of = {r: 0.0 for r in runs}
    with tempfile.TemporaryDirectory() as dd:
        d = pathlib.Path(dd)
        for k, cam in enumerate(cams):
            refs = {t: reference(t, cam, ref_spp if t == "Mitsuba" else cref, f"_view{k}of{n}") for t in tracers}
            cam_file = d / f"cam{k}.json"
            cam_file.write_text(json.dumps(cam))
            img, a, t = bake(cam_file, int(count), extra, d, cam, keep=True,
                             target=str(d / "out" / f"{pathlib.Path(SCENE['mesh']).stem}.exr"))
            judge = Judge(refs, a)
            cpu_of[runs[0]] += t
            found[runs[0]].append(judge(img))
            print(f"view {k}: bake {t:.1f} s, " + ", ".join(
                f"against {tr}: RMS {e[0]:.3f}, bright {e[2]:.3f}" for tr, e in found[runs[0]][-1].items()),
                flush=True)
            for r in runs[1:]:
                img, t = trace(r[0], cam, r[1], 7 + k, r[2])
                cpu_of[r] += t
                found[r].append(judge(img))
    print(f"{n} views at {size} x {size}; references: Mitsuba 2 x {ref_spp} spp, Cycles 2 x {cref} spp each")
    print("| tool | setting | CPU, all views (s) | " + " | ".join(
        f"against {t}: mean RMS | bright" for t in tracers) + " |")
    print("|---|---|---|" + "---|---|" * len(tracers))
    for r in runs:
        tool, setting = ("bake", " ".join([f"{int(count) // 1000}k points"] + extra)) if r[0] == "bake" \
            else label(*r)
        cells = []
        for t in tracers:
            e = np.array([f[t] for f in found[r]])
            cells.append(f"{e[:, 0].mean():.3f} | {e[:, 2].mean():.3f}")
        print(f"| {tool} | {setting} | {cpu_of[r]:.1f} | " + " | ".join(cells) + " |")


def error(img, ref, noise2, mask):
    """RMS relative error with the reference's noise taken out, and the
    mean relative error, over `mask`."""
    r = np.maximum(ref[mask], 1e-6)
    rel = (img[mask] - ref[mask]) / r
    ms = np.mean(rel ** 2) - np.mean(noise2[mask] / r ** 2)
    return float(np.sqrt(max(ms, 0.0))), float(np.mean(rel))


def race(cam, ref_spp, spps, bakes, cref, tracers):
    """The bakes and the path tracers' sweeps against the references;
    the rows."""
    refs = {t: reference(t, cam, ref_spp if t == "Mitsuba" else cref) for t in tracers}
    rows = []
    print(f"{cam['width']} x {cam['height']}; references: " + ", ".join(
        f"{t} 2 x {ref_spp if t == 'Mitsuba' else cref} spp" for t in tracers), flush=True)
    head = "| tool | setting | CPU (s) | " + " | ".join(
        f"against {t}: RMS | mean | bright RMS | bright mean" for t in tracers) + " |"
    print(head)
    print("|---|---|---|" + "---|---|---|---|" * len(tracers))

    def show(tool, setting, t, found):
        print(f"| {tool} | {setting} | {t:.1f} | " + " | ".join(
            f"{e[0]:.3f} | {e[1]:+.3f} | {e[2]:.3f} | {e[3]:+.3f}" for e in found.values()) + " |", flush=True)

    judge = None
    with tempfile.TemporaryDirectory() as dd:
        d = pathlib.Path(dd)
        cam_file = d / "cam.json"
        cam_file.write_text(json.dumps(cam))
        for b in bakes:
            count, *extra = b.split(",")
            img, a, t = bake(cam_file, int(count), extra, d, cam)
            if judge is None:
                judge = Judge(refs, a)
                judge.describe()
            found = judge(img)
            rows.append({"tool": "bake, indirect", "setting": int(count), "extra": extra, "seconds": t,
                         **{f"{k}_{tr.lower()}": v for tr, e in found.items()
                            for k, v in zip(("rms", "mean", "bright_rms", "bright_mean"), e)}})
            show("bake", " ".join([f"{int(count) // 1000}k points"] + extra), t, found)
        for tr, s, dn in sweep(tracers, spps):
            img, t = trace(tr, cam, s, 7, dn)
            found = judge(img)
            tool, setting = label(tr, s, dn)
            rows.append({"tool": tool, "setting": s, "seconds": t,
                         **{f"{k}_{r.lower()}": v for r, e in found.items()
                            for k, v in zip(("rms", "mean", "bright_rms", "bright_mean"), e)}})
            show(tool, setting, t, found)
    return rows


def plot(data, out):
    """Error against CPU, one panel a reference, from race.json's rows."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    refs = [t for t in TRACERS if any(f"rms_{t.lower()}" in r for r in data["rows"])]
    fig, axes = plt.subplots(1, len(refs), figsize=(6.5 * len(refs), 5.5), dpi=100, squeeze=False)
    for ax, ref in zip(axes[0], refs):
        groups = {}
        for r in data["rows"]:
            if r["tool"].startswith("bake"):
                extra = r.get("extra", [])
                walks = [e.split("=")[1] for e in extra if e.startswith("WALKS=")]
                how = ("from the eye" if "EXIT=eye" in extra else
                       "cloud's light" if "SAMPLE_LIGHTS=0" in extra else "lights sampled")
                name = f"bake, walks ({how})" if walks else "bake, kernel"
                label = f"{r['setting'] // 1000}k" + (f" x{walks[0]}" if walks else "")
            else:
                name, label = r["tool"], f"{r['setting']} spp"
            groups.setdefault(name, []).append((r["seconds"], r[f"rms_{ref.lower()}"], label))
        for name, pts in groups.items():
            pts.sort()
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-" if name.startswith("bake") else "s--",
                    label=name)
            for x, y, lab in pts:
                ax.annotate(lab, (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
        for level in (0.2, 0.1, 0.05, 0.02):
            ax.axhline(level, color="grey", lw=0.5, ls=":")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("CPU seconds (user + sys)")
        ax.set_ylabel("RMS relative error per pixel")
        whose = ref + ("'" if ref.endswith("s") else "'s")
        ax.set_title(f"{data.get('scene', 'bunny')} against {whose} reference ({data['reference_spp'][ref]} spp), "
                     f"{data['size']} x {data['size']}", fontsize=9)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out)


def main():
    args = sys.argv[1:]
    name = "bunny"
    save = "--save" in args
    merge = "--merge" in args
    args = [a for a in args if a not in ("--save", "--merge")]
    if args[:1] == ["--scene"]:
        name, args = args[1], args[2:]
    results = RESULTS if name == "bunny" else RESULTS.with_name(f"race_{name}.json")
    if args[:1] == ["--plot"]:
        plot(json.loads(results.read_text()), results.with_suffix(".png"))
        return
    use(name)
    tracers = tuple(t for t in os.environ.get("TRACERS", ",".join(TRACERS)).split(",") if t)
    if args[:1] == ["--views"]:
        n = int(args[1])
        rest = args[2:]
        views(n, int(rest[0]) if rest else 256, int(rest[1]) if len(rest) > 1 else 64,
              [int(x) for x in (rest[2] if len(rest) > 2 else "16,64").split(",") if x != "-"],
              rest[3] if len(rest) > 3 else "50000", int(rest[4]) if len(rest) > 4 else 128, tracers)
        return
    base = SCENE["camera"]
    if args[:1] == ["--wide"]:
        rest = args[1:]
        cam = dict(base, width=1920, height=1080)
        race(cam, 0, [int(x) for x in (rest[1] if len(rest) > 1 else "4,16,64").split(",") if x != "-"],
             (rest[2] if len(rest) > 2 else "50000;50000,METHOD=walk,WALKS=64").split(";"),
             int(rest[0]) if rest else 64, ("Cycles",))
        return
    size = int(args[0]) if args else (1024 if name == "bunny" else 512)
    ref_spp = int(args[1]) if len(args) > 1 else 64
    spps = [int(x) for x in (args[2] if len(args) > 2 else "4,16,64").split(",") if x != "-"]
    bakes = (args[3] if len(args) > 3 else
             "50000;200000;50000,METHOD=walk,WALKS=16,SAMPLE_LIGHTS=0,EXIT=sky;"
             "50000,METHOD=walk,WALKS=16,EXIT=sky;200000,METHOD=walk,WALKS=16,EXIT=sky;"
             "50000,METHOD=walk,WALKS=16,EXIT=eye;"
             "200000,METHOD=walk,WALKS=16,EXIT=eye;200000,METHOD=walk,WALKS=64,EXIT=eye" if name == "bunny" else
             "50000;200000;50000,METHOD=walk,WALKS=16,EXIT=sky;50000,METHOD=walk,WALKS=16,EXIT=eye;"
             "200000,METHOD=walk,WALKS=16,EXIT=eye;200000,METHOD=walk,WALKS=64,EXIT=eye").split(";")
    cref = int(args[4]) if len(args) > 4 else 128
    cam = dict(base, width=size, height=size)
    rows = race(cam, ref_spp, spps, bakes, cref, tracers)
    if save:
        if merge:
            key = lambda r: (r["tool"], r["setting"], tuple(r.get("extra") or ()))
            new = {key(r): r for r in rows}
            old = json.loads(results.read_text())["rows"]
            rows = [new.pop(key(r), r) for r in old] + list(new.values())
        data = {"scene": name, "reference_spp": {"Mitsuba": 2 * ref_spp, "Cycles": 2 * cref}, "size": size,
                "rows": rows}
        results.write_text(json.dumps(data, indent=1) + "\n")
        plot(data, results.with_suffix(".png"))


if __name__ == "__main__":
    main()
