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

    def off(x, y):
        return float(np.mean(x[m]) / np.mean(y[m]) - 1)

    print(f"{a[0]} {size} x {size}, {count} points, {' '.join(extra)}: picture {off(img, ref):+.3f}, "
          f"ssS against single {off(parts['ssS'], single):+.3f}, ssM against the rest "
          f"{off(parts['ssM'], ref - single):+.3f}; single is {float(np.mean(single[m]) / np.mean(ref[m])):.3f} "
          f"of the picture")
    # Where ssS is off: per channel, and by quarters of the single
    # scattering's brightness, darkest first.
    chans = [float(np.mean(parts["ssS"][m][:, c]) / np.mean(single[m][:, c]) - 1) for c in range(3)]
    lum, got = single.mean(axis=2)[m], parts["ssS"].mean(axis=2)[m]
    edges = np.quantile(lum, [0.0, 0.25, 0.5, 0.75, 1.0])
    quarters = [float(got[(lum >= lo) & (lum <= hi)].mean() / lum[(lum >= lo) & (lum <= hi)].mean() - 1)
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


def ratio_map(x, y, m, out):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    r = np.where(m, x.mean(axis=2) / np.maximum(y.mean(axis=2), 1e-9), np.nan)
    plt.imsave(out, np.log2(np.clip(r, 0.25, 4.0)), cmap="coolwarm", vmin=-1, vmax=1)


if __name__ == "__main__":
    main()
