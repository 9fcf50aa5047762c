"""Does the walk method converge to the path tracer (issue 58's first
target)? A race scene at a size where Mitsuba's reference can be made
clean, the bake swept over walks (and points), each bake made twice with
independent seeds, so that its error splits into what more walks remove
and what they do not:

    python converge.py SCENE SIZE REF BAKES

SCENE: race_scenes.py's (`bunny`, `suzanne`, `dragon`); SIZE: pixels a
side; REF: Mitsuba's samples a pixel in each of the reference's two
halves (seeds 1001 and 2002, kept in target/race/ as race.py keeps its
own); BAKES: `;`-separated, each `COUNT[,VAR=VALUE...]` as race.py's,
e.g. `200000,METHOD=walk,WALKS=16;200000,METHOD=walk,WALKS=64`.

With CONVERGE_SHIFT=T (e.g. 2.5) each half is also rendered with the
scene moved by (T, T, T) and both are taken to no ray offset pixel by
pixel, as race_split.py does (Mitsuba's f32 ray offset skips a layer of
the medium: 2-4% of the single scattering where the mean free path is a
hundredth of the object; mitsuba_epsilon.py).

Columns, over the pixels the bake covers whole and that the reference
lights (each channel a sample), relative to the reference, each with
the reference's own noise `(h1 - h2)^2 / 4` taken out:
- `RMS`: one bake's error (the mean of the two bakes' squares);
- `noise`: the bake's own, from its two seeds, `(b1 - b2)^2 / 2`;
- `floor`: what is left with the bake's noise taken out too, the error
  more walks do not remove (the points' spacing, the filter on the
  cloud, the model);
- `mean`: the mean relative error of the two bakes' mean.
A converging method's `noise` halves with four times the walks and its
`floor` goes to the reference's noise with more points. With
CONVERGE_ONCE=1 each bake is made once (seed 1): its RMS alone.

With CONVERGE_RESOLVED=X only the pixels whose reference's own noise is
at most X of their value are compared (a point light's fireflies leave
a few pixels that two halves of thousands of samples do not resolve,
and their noise, though taken out on average, swamps the rest). The
bakes' pictures are kept in target/race/ (a rerun with another mask
reuses them; the stages' BIN and the bake's settings name them).
"""
import json
import os
import pathlib
import sys
import tempfile

import numpy as np

import race
import race_split


def reference(cam, spp, shift):
    """Mitsuba's two halves (taken to no ray offset with `shift`):
    (mean, noise^2 a pixel)."""
    halves = []
    gain = race_split.offset_gain(cam, shift) if shift else None
    for seed in (1001, 2002):
        tag = f"{race.NAME}_converge_{cam['width']}_{spp}_{seed}"
        h = race_split.cached(tag, lambda: race.scene(cam, spp, sc=race.SCENE), spp, seed)
        if shift:
            moved = race_split.cached(f"{tag}_shift{shift:g}",
                                      lambda: race.scene(cam, spp, sc=race.SCENE, shift=shift), spp, seed)
            h = race_split.to_no_offset(h, moved, gain)
        halves.append(h)
    h1, h2 = halves
    return (h1 + h2) / 2, (h1 - h2) ** 2 / 4


def main():
    name, size, spp, bakes = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    race.use(name)
    shift = float(os.environ.get("CONVERGE_SHIFT", "0"))
    cam = dict(race.SCENE["camera"], width=size, height=size)
    ref, noise2 = reference(cam, spp, shift)
    print(f"{name}, {size} x {size}; Mitsuba 2 x {spp} spp" + (f", taken to no ray offset (moved {shift:g})"
                                                              if shift else ""), flush=True)
    print("| bake | CPU a bake (s) | RMS | noise | floor | mean |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as dd:
        d = pathlib.Path(dd)
        cf = d / "cam.json"
        cf.write_text(json.dumps(cam))
        mask = None
        for b in bakes.split(";"):
            count, *extra = b.split(",")
            pics, cpu = [], 0.0
            seeds = (1,) if os.environ.get("CONVERGE_ONCE") == "1" else (1, 2)
            for seed in seeds:
                key = "_".join([name, str(size), count, *extra, f"SEED={seed}"]).replace("=", "")
                f = race.CACHE / f"converge_bake_{key}.npz"
                if f.exists():
                    z = np.load(f)
                    img, cover, t = z["img"], z["cover"], float(z["cpu"])
                else:
                    img, cover, t = race.bake(cf, int(count), extra + [f"SEED={seed}"], d, cam)
                    np.savez(f, img=img, cover=cover, cpu=t)
                pics.append(img)
                cpu += t
            if mask is None:
                mask = (cover >= 1) & (ref.min(axis=2) > 1e-3)
                if os.environ.get("CONVERGE_RESOLVED"):
                    x = float(os.environ["CONVERGE_RESOLVED"])
                    own_px = np.sqrt(noise2.max(axis=2)) / np.maximum(ref.min(axis=2), 1e-6)
                    print(f"(pixels whose reference noise is at most {x:g} of their value: "
                          f"{int((mask & (own_px <= x)).sum())} of {int(mask.sum())})", flush=True)
                    mask &= own_px <= x
                own = np.sqrt(np.mean(noise2[mask] / np.maximum(ref[mask], 1e-6) ** 2))
                print(f"(the reference's own noise {own:.4f} RMS relative, {int(mask.sum())} pixels)", flush=True)
            r = np.maximum(ref[mask], 1e-6)
            out = noise2[mask] / r ** 2
            setting = " ".join([f"{int(count) // 1000}k points"] + extra)
            if len(pics) == 1:
                one = np.mean(((pics[0][mask] - ref[mask]) / r) ** 2)
                mean = float(np.mean((pics[0][mask] - ref[mask]) / r))
                print(f"| {setting} | {cpu:.1f} | {np.sqrt(max(one - out.mean(), 0.0)):.4f} | | | {mean:+.4f} |",
                      flush=True)
                continue
            b1, b2 = pics[0][mask], pics[1][mask]
            one = 0.5 * (np.mean(((b1 - ref[mask]) / r) ** 2) + np.mean(((b2 - ref[mask]) / r) ** 2))
            rms = np.sqrt(max(one - out.mean(), 0.0))
            own2 = ((b1 - b2) / r) ** 2 / 2
            noise = np.sqrt(own2.mean())
            both = np.mean((((b1 + b2) / 2 - ref[mask]) / r) ** 2)
            floor = np.sqrt(max(both - own2.mean() / 2 - out.mean(), 0.0))
            mean = float(np.mean(((b1 + b2) / 2 - ref[mask]) / r))
            print(f"| {setting} | {cpu / 2:.1f} | {rms:.4f} | {noise:.4f} | {floor:.4f} | {mean:+.4f} |", flush=True)


if __name__ == "__main__":
    main()
