"""The physical model's picture of the bunny against Mitsuba 3's, and the
error of each against time.

The bunny fixture (fixtures/mesh/bunny.obj, 3,674 flat triangles: Mitsuba
renders the same facets), its two distant lights (fixtures/lights/bunny.json:
a key from the front and a rim light from behind, which shines through the
ears) and its camera at SIZE x SIZE pixels, filled with a medium of
single-scattering albedo ALBEDO (per channel), mean free path MFP, g 0,
under an index-matched boundary (eta 1: Mitsuba's light sampling reaches
a directional light only through a null boundary). The bake is `make -C
pipelines MODEL=physical` (scatter to render, 16 sssingle samples, 16
rays a pixel), at each point count once with direct light alone and once
with light between surfaces (`INDIRECT=16`); Mitsuba is volpath; both
weigh a pixel's rays by Mitsuba's Gaussian pixel filter. The
reference is Mitsuba at REF samples a pixel. Errors: RMS and mean relative
error of the beauty over the pixels the bunny covers whole in the bake and
that are lit in the reference, each channel a sample; and over the ears
alone (the pixels above EAR_Y of the image's height), lit from behind.

    python mitsuba_bunny.py [REF] [COUNTS] [SPPS]
    python mitsuba_bunny.py --split [REF] [COUNT]
    python mitsuba_bunny.py --where [REF] [COUNT]

`--split`: the bake's `ssS` and `ssM` pictures apart against Mitsuba's
single scattering (the path cut after one event) and the rest.

`--where`: where the bake with light between surfaces (`INDIRECT=16`)
is off: in the pixels of a crop where no light arrives directly (the
back of the head, facing the body; found with a diffuse bunny's direct
light), beside a diffuse bunny of the medium's surface colour (Mitsuba's
`path`: its light between surfaces); on the picture's rim (covered
pixels with a neighbour not covered whole) and inside it; and on the
ears by light, each light alone in both tools.
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
RESULTS = ROOT / "benches" / "results" / "mitsuba_bunny.json"
ALBEDO, MFP = [0.95, 0.85, 0.7], 0.1
SIZE = 96
# The ears: the image's top rows, above the head.
EAR_ROWS = 0.42
LIGHTS = json.loads((ROOT / "fixtures/lights/bunny.json").read_text())["lights"]
CAMERA = dict(json.loads((ROOT / "fixtures/cameras/bunny.json").read_text()), width=SIZE, height=SIZE)
MESH = ROOT / "fixtures/mesh/bunny.obj"


def scene(cam, spp, max_depth=-1, sc=None, shift=0.0):
    """The bunny scene for Mitsuba, seen by the toolkit's camera `cam`
    (also race.py's); or race_scenes.py's scene `sc` (its mesh given as
    a path). `shift` moves the whole scene by (shift, shift, shift):
    the same picture, but Mitsuba's rays leave a surface
    `(1 + max|p|) * RayEpsilon` off it, which skips that much of the
    medium under it (race_split.py takes that out)."""
    if sc is None:
        sc = dict(mesh=MESH, flat=True, lights=LIGHTS, albedo=ALBEDO, mfp=[MFP] * 3)
    mesh = pathlib.Path(sc["mesh"])
    # An RGB parameter is a reflectance in [0, 1]: the extinction is given
    # over its largest channel, times that as the medium's scale.
    top = max(1.0 / m for m in sc["mfp"])
    s = {
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": max_depth, "rr_depth": RR_DEPTH},
        "bunny": {
            "type": mesh.suffix[1:], "filename": str(mesh), "face_normals": sc["flat"], "bsdf": {"type": "null"},
            "to_world": mi.ScalarTransform4f().translate([shift] * 3),
            "interior": {"type": "homogeneous", "albedo": {"type": "rgb", "value": sc["albedo"]},
                         "sigma_t": {"type": "rgb", "value": [1.0 / m / top for m in sc["mfp"]]}, "scale": top,
                         "phase": {"type": "hg", "g": 0.0}},
        },
        "camera": camera(moved(cam, shift), spp),
    }
    # A distant light of colour * intensity gives an irradiance of that
    # across its direction (illum's Cl); a point light, a radiant
    # intensity of that.
    for l in sc["lights"]:
        e = {"type": "rgb", "value": [c * l.get("intensity", 1.0) for c in l.get("color", [1, 1, 1])]}
        if l["type"] == "distant":
            s[l["name"]] = {"type": "directional", "direction": l["direction"], "irradiance": e}
        elif l["type"] == "point":
            s[l["name"]] = {"type": "point", "position": [x + shift for x in l["position"]], "intensity": e}
        else:
            raise SystemExit(f"light {l['name']}: only distant and point lights go to Mitsuba here")
    return s


def moved(cam, shift):
    """Camera `cam` moved by (shift, shift, shift)."""
    if shift == 0.0:
        return cam
    return dict(cam, position=[x + shift for x in cam["position"]], look_at=[x + shift for x in cam["look_at"]])


def mitsuba(spp, max_depth=-1):
    t = time.time()
    img = np.array(mi.render(mi.load_dict(scene(CAMERA, spp, max_depth)), spp=spp))
    return img[:, :, :3], time.time() - t


def bake(count, d, indirect=0):
    cam = d / "cam.json"
    cam.write_text(json.dumps(CAMERA))
    out = d / f"out{count}_{indirect}"
    t = time.time()
    subprocess.run(["make", "-s", "-C", ROOT / "pipelines", f"MESH={MESH}", f"CAMERA={cam}",
                    f"OUT={out}", f"COUNT={count}", "MODEL=physical", f"INDIRECT={indirect}",
                    f"ALBEDO={','.join(map(str, ALBEDO))}", f"MFP={MFP}", "ETA=1", "G=0", "SPP=16", "PIXEL_FILTER=gaussian",
                    "SAMPLES=16", "SHADOWS=1"] + EXTRA, check=True, stdout=subprocess.DEVNULL)
    took = time.time() - t
    img, a = read_image(out / "bunny.exr", d, SIZE)
    return img, a, took


def masks(a, ref):
    whole = (a >= 1.0) & (ref.min(axis=2) > 1e-3)
    ears = whole.copy()
    ears[int(EAR_ROWS * SIZE):, :] = False
    return whole, ears


def split(ref_spp, count):
    ref, _ = mitsuba(ref_spp)
    single, _ = mitsuba(ref_spp, max_depth=2)
    with tempfile.TemporaryDirectory() as dd:
        d = pathlib.Path(dd)
        img, a, _ = bake(count, d)
        out = d / f"out{count}_0"
        whole, ears = masks(a, ref)
        part = {}
        for attr in ["ssM", "ssS"]:
            exr = d / f"{attr}.exr"
            render_attr(out, "bunny", d / "cam.json", attr, exr)
            part[attr] = read_image(exr, d, SIZE)[0]
    if os.environ.get("SPLIT_NPZ"):  # the pictures, to look at where the error is
        np.savez(os.environ["SPLIT_NPZ"], img=img, ref=ref, single=single, ssM=part["ssM"], ssS=part["ssS"],
                 whole=whole)
    rel = (img[whole] - ref[whole]) / np.maximum(ref[whole], 1e-6)
    print("whole, the picture's relative error per pixel and channel: quantiles 5, 25, 50, 75, 95%:",
          np.quantile(rel, [0.05, 0.25, 0.5, 0.75, 0.95]).round(3))
    for name, m in [("whole", whole), ("ears", ears)]:
        print(f"{name}: single scattering: bake {part['ssS'][m].mean():.4f}, Mitsuba {single[m].mean():.4f}; "
              f"multiple (ssM / pi): bake {part['ssM'][m].mean():.4f}, "
              f"Mitsuba {(ref - single)[m].mean():.4f}")
        for what, got, want in [("single", part["ssS"], single), ("multiple", part["ssM"], ref - single)]:
            e = errors(got, want, m & (want.min(axis=2) > 1e-3))
            print(f"{name}: {what}: RMS relative error {e[0]:.3f}, mean {e[1]:+.3f}")


def diffuse(spp, max_depth, colour):
    """A diffuse bunny of the surface colour `colour` in Mitsuba's `path`."""
    scene = {"type": "scene", "integrator": {"type": "path", "max_depth": max_depth},
             "bunny": {"type": "obj", "filename": str(MESH), "face_normals": True,
                       "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": colour}}},
             "camera": camera(CAMERA, spp)}
    for l in LIGHTS:
        e = [c * l.get("intensity", 1.0) for c in l.get("color", [1, 1, 1])]
        scene[l["name"]] = {"type": "directional", "direction": l["direction"],
                            "irradiance": {"type": "rgb", "value": e}}
    return np.array(mi.render(mi.load_dict(scene), spp=spp))[:, :, :3]


def where(ref_spp, count):
    ref, _ = mitsuba(ref_spp)
    single, _ = mitsuba(ref_spp, max_depth=2)
    with tempfile.TemporaryDirectory() as dd:
        d = pathlib.Path(dd)
        img, a, _ = bake(count, d, 16)
        out = d / f"out{count}_16"
        part = {}
        for attr in ["ssM", "ssS"]:
            exr = d / f"{attr}.exr"
            render_attr(out, "bunny", d / "cam.json", attr, exr)
            part[attr] = read_image(exr, d, SIZE)[0]
        colour = subprocess.run([ROOT / "target/release/pcinfo", out / "bunny_ss.ply"], check=True,
                                capture_output=True, text=True).stdout
        colour = [float(x) for x in colour.split("ssmulti_colour")[1].split("(")[1].split(")")[0].split(",")]
    whole, ears = masks(a, ref)
    # The crop: the back of the head, where a diffuse bunny gets no direct light.
    direct, everything = diffuse(256, 2, colour), diffuse(256, -1, colour)
    crop = np.zeros(whole.shape, bool)
    crop[31:44, 27:38] = True
    crop &= whole & (direct.sum(axis=2) == 0)
    print(f"no direct light ({int(crop.sum())} pixels), red: bake {img[crop][:, 0].mean():.4f}, "
          f"Mitsuba {ref[crop][:, 0].mean():.4f}, diffuse bunny of colour {np.round(colour, 3)} "
          f"{everything[crop][:, 0].mean():.4f}")
    inner = whole.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            inner &= np.roll(np.roll(whole, dy, 0), dx, 1)
    rim = whole & ~inner
    rel = (img - ref) / np.maximum(ref, 1e-6)
    for name, m in [("rim", rim), ("inside", inner)]:
        print(f"{name} ({int(m.sum())} pixels): mean {rel[m].mean():+.3f}, RMS {np.sqrt((rel[m] ** 2).mean()):.3f}, "
              f"10% quantile {np.quantile(rel[m], 0.1):+.3f}; multiple bake/Mitsuba "
              f"{part['ssM'][m].mean() / (ref - single)[m].mean():.3f}")
    every = list(LIGHTS)
    for l in every:
        LIGHTS[:] = [l]
        EXTRA[:] = [f"LMASK={l['name']}"]
        alone, _ = mitsuba(ref_spp)
        with tempfile.TemporaryDirectory() as dd:
            b, _, _ = bake(count, pathlib.Path(dd), 16)
        print(f"ears, {l['name']} light alone: bake / Mitsuba {np.round(b[ears].mean(0) / alone[ears].mean(0), 3)}")
    LIGHTS[:] = every


if __name__ == "__main__":
    if "--where" in sys.argv:
        args = [x for x in sys.argv[1:] if x != "--where"]
        where(int(args[0]) if args else 1024, int(args[1]) if len(args) > 1 else 200000)
        sys.exit()
    if "--split" in sys.argv:
        args = [x for x in sys.argv[1:] if x != "--split"]
        split(int(args[0]) if args else 1024, int(args[1]) if len(args) > 1 else 200000)
        sys.exit()
    ref_spp = int(sys.argv[1]) if len(sys.argv) > 1 else 1024
    counts = [int(x) for x in (sys.argv[2] if len(sys.argv) > 2 else "50000,200000,1000000").split(",")]
    spps = [int(x) for x in (sys.argv[3] if len(sys.argv) > 3 else "4,16,64,256").split(",")]
    ref, ref_t = mitsuba(ref_spp)
    print(f"reference: Mitsuba {ref_spp} spp, {ref_t:.0f} s, mean {ref.mean(axis=(0, 1))}", flush=True)
    print("| tool | setting | time (s) | RMS relative error | mean relative error | ears: RMS | ears: mean |")
    print("|---|---|---|---|---|---|---|")
    rows = []
    with tempfile.TemporaryDirectory() as dd:
        d = pathlib.Path(dd)
        whole = ears = None
        for indirect, tool in [(0, "bake"), (16, "bake, indirect")]:
            for n in counts:
                img, a, t = bake(n, d, indirect)
                if whole is None:
                    whole, ears = masks(a, ref)
                e, f = errors(img, ref, whole), errors(img, ref, ears)
                rows.append({"tool": tool, "setting": n, "seconds": t, "rms": e[0], "mean": e[1],
                             "ears_rms": f[0], "ears_mean": f[1]})
                print(f"| {tool} | {n} points | {t:.1f} | {e[0]:.3f} | {e[1]:+.3f} | {f[0]:.3f} | {f[1]:+.3f} |",
                      flush=True)
        for s in spps:
            img, t = mitsuba(s)
            e, f = errors(img, ref, whole), errors(img, ref, ears)
            rows.append({"tool": "Mitsuba", "setting": s, "seconds": t, "rms": e[0], "mean": e[1],
                         "ears_rms": f[0], "ears_mean": f[1]})
            print(f"| Mitsuba | {s} spp | {t:.1f} | {e[0]:.3f} | {e[1]:+.3f} | {f[0]:.3f} | {f[1]:+.3f} |",
                  flush=True)
        print(f"({int(whole.sum())} pixels compared, {int(ears.sum())} on the ears)")
    if not EXTRA:  # (a variant's rows are printed, not kept)
        RESULTS.write_text(json.dumps({"reference_spp": ref_spp, "rows": rows}, indent=1) + "\n")
