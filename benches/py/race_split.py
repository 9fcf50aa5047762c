"""Where a race scene's bake is off (the dragon's figures in
docs/PERFORMANCE.md): the bake's `ssS` against Mitsuba's single
scattering (paths cut after one event) and its `ssM` against the rest,
each as the ratio of its mean over the pixels the bake covers whole and
the reference lights, minus 1.

    python race_split.py SCENE [SIZE] [SPP] [COUNT] [VAR=VALUE;...] [MESH]

SCENE: race_scenes.py's; the bake is race.py's (INDIRECT=16) with the
`;`-separated make variables (default `METHOD=walk;WALKS=32;EXIT=eye`);
MESH (a path) replaces the scene's mesh, e.g. the dragon's decimation
without open edges, out/models/dragon_vrip_res2.ply. Mitsuba's two
pictures are kept in target/race/; with RACE_SPLIT_MAP=PATH set, a PNG
of `ssM` over the rest, pixel by pixel (blue dark, red bright), is
written there (RACE_SPLIT_MAP_SINGLE: `ssS` over the single scattering).

Mitsuba's rays leave a surface `(1 + max|p|) * RayEpsilon` (about 1e-4)
off it along its normal, in f32: a ray that enters the medium skips
that much of it, which darkens its single scattering by about
`sigma_t * offset / cos` (2-4% where the mean free path is 1% of the
object's size: Suzanne's, the dragon's; mitsuba_epsilon.py measures it
on a slab). With RACE_SPLIT_SHIFT=T (e.g. 2.5) each of Mitsuba's two
pictures is also rendered with the scene moved by (T, T, T), which
grows the offset, and the split is also given against both pictures
taken linearly to no offset, pixel by pixel (the offset found from
where each pixel's centre ray meets the mesh).
"""
import json
import os
import pathlib
import subprocess
import sys
import tempfile

import mitsuba as mi
import numpy as np

import race
from mitsuba_bunny import scene
from mitsuba_images import read_image, render_attr


def main():
    a = sys.argv[1:]
    race.use(a[0])
    size = int(a[1]) if len(a) > 1 else 192
    spp = int(a[2]) if len(a) > 2 else 256
    count = int(a[3]) if len(a) > 3 else 100000
    extra = (a[4] if len(a) > 4 else "METHOD=walk;WALKS=32;EXIT=eye").split(";")
    if len(a) > 5:
        race.SCENE["mesh"] = pathlib.Path(a[5]).resolve()
    cam = dict(race.SCENE["camera"], width=size, height=size)
    tag = f"{a[0]}_{pathlib.Path(race.SCENE['mesh']).stem}_split_{size}_{spp}"
    ref = cached(f"{tag}_all", lambda: scene(cam, spp, sc=race.SCENE), spp, 5)
    single = cached(f"{tag}_single", lambda: scene(cam, spp, max_depth=2, sc=race.SCENE), spp, 6)
    with tempfile.TemporaryDirectory() as dd:
        d = pathlib.Path(dd)
        cf = d / "cam.json"
        cf.write_text(json.dumps(cam))
        img, cover, _ = race.bake(cf, count, extra, d, cam, keep=True)
        parts = {}
        for attr in ("ssS", "ssM"):
            exr = d / f"{attr}.exr"
            render_attr(d / "out", pathlib.Path(race.SCENE["mesh"]).stem, cf, attr, exr)
            parts[attr], _ = read_image(exr, d, size)
        subprocess.run(["rm", "-rf", str(d / "out")], check=True)
    m = (cover >= 1) & (ref.min(axis=2) > 1e-3)
    if os.environ.get("RACE_SPLIT_SHIFT"):
        t = float(os.environ["RACE_SPLIT_SHIFT"])
        gain = offset_gain(cam, t)
        ref = to_no_offset(ref, cached(f"{tag}_all_shift{t:g}", lambda: scene(cam, spp, sc=race.SCENE, shift=t), spp, 5), gain)
        single = to_no_offset(single, cached(f"{tag}_single_shift{t:g}",
                                             lambda: scene(cam, spp, max_depth=2, sc=race.SCENE, shift=t), spp, 6), gain)
        print(f"Mitsuba taken to no ray offset (its pictures moved by {t:g} too)")

    def off(x, y):
        return float(np.mean(x[m]) / np.mean(y[m]) - 1)

    print(f"{a[0]} {size} x {size}, {count} points, {' '.join(extra)}: picture {off(img, ref):+.3f}, "
          f"ssS against single {off(parts['ssS'], single):+.3f}, ssM against the rest "
          f"{off(parts['ssM'], ref - single):+.3f}; single is {float(np.mean(single[m]) / np.mean(ref[m])):.3f} "
          f"of the picture")
    # Where ssS is off: per channel, and by quarters of the bake's own
    # single scattering's brightness, darkest first (the reference's
    # would sort its noise: its dim quarter holds the pixels its noise
    # made dim).
    chans = [float(np.mean(parts["ssS"][m][:, c]) / np.mean(single[m][:, c]) - 1) for c in range(3)]
    lum, got = single.mean(axis=2)[m], parts["ssS"].mean(axis=2)[m]
    edges = np.quantile(got, [0.0, 0.25, 0.5, 0.75, 1.0])
    quarters = [float(got[(got >= lo) & (got <= hi)].mean() / lum[(got >= lo) & (got <= hi)].mean() - 1)
                for lo, hi in zip(edges[:-1], edges[1:])]
    print("ssS against single per channel " + ", ".join(f"{x:+.3f}" for x in chans)
          + "; by quarters of brightness, darkest first " + ", ".join(f"{x:+.3f}" for x in quarters))
    if os.environ.get("RACE_SPLIT_MAP"):
        ratio_map(parts["ssM"], ref - single, m, os.environ["RACE_SPLIT_MAP"])
    if os.environ.get("RACE_SPLIT_MAP_SINGLE"):
        ratio_map(parts["ssS"], single, m, os.environ["RACE_SPLIT_MAP_SINGLE"])


def cached(name, sc, spp, seed):
    """Mitsuba's picture of scene `sc()`, kept in target/race/ as `name`."""
    f = race.CACHE / f"{name}.npy"
    if not f.exists():
        race.CACHE.mkdir(parents=True, exist_ok=True)
        np.save(f, np.array(mi.render(mi.load_dict(sc()), spp=spp, seed=seed))[:, :, :3])
    return np.load(f)


def offset_gain(cam, t):
    """Per pixel, d0 / (d1 - d0): Mitsuba's ray offset `(1 + max|p|)`
    where the pixel's centre ray meets the mesh (d0), and with the scene
    moved by (t, t, t) (d1); 0 where the ray meets nothing."""
    sc = mi.load_dict(scene(cam, 1, sc=race.SCENE))
    sensor = sc.sensors()[0]
    w, h = cam["width"], cam["height"]
    gain = np.zeros((h, w, 1))
    for y in range(h):
        for x in range(w):
            ray, _ = sensor.sample_ray(0.0, 0.5, mi.ScalarPoint2f((x + 0.5) / w, (y + 0.5) / h),
                                       mi.ScalarPoint2f(0.5, 0.5))
            si = sc.ray_intersect(ray)
            if si.is_valid():
                p = np.array(si.p)
                d0, d1 = 1 + np.abs(p).max(), 1 + np.abs(p + t).max()
                gain[y, x] = d0 / (d1 - d0)
    return gain


def to_no_offset(r0, r1, gain):
    """Mitsuba's picture `r0` taken linearly to no ray offset, from `r1`
    (the same with a larger offset)."""
    return r0 + (r0 - r1) * gain


def ratio_map(x, y, m, out):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    r = np.where(m, x.mean(axis=2) / np.maximum(y.mean(axis=2), 1e-9), np.nan)
    plt.imsave(out, np.log2(np.clip(r, 0.25, 4.0)), cmap="coolwarm", vmin=-1, vmax=1)


if __name__ == "__main__":
    main()
