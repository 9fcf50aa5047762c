"""What light between surfaces costs the diffusion bake (issue 59 item
3; the figures in docs/PERFORMANCE.md, "Light between surfaces"): `make
bake MODEL=physical` on the bunny at COUNT points, `INDIRECT=0`,
`INDIRECT=16` with the first pass on a quarter of the points (the
default) and with `COARSE=0` (on every point), run alternately ROUNDS
times; CPU seconds (user + sys) of each make, and the ratio of each
mean to `INDIRECT=0`'s. Then each picture's RMS relative difference per
pixel and channel from a converged one: the first pass on every point
with TRUTH rays a point (256 by default), whose own noise is then small
beside 16 rays' (so the error of each 16-ray bake is its rays' noise and
the coarse pass's bias); and no light between surfaces against it (the
light's size).

    python indirect_cost.py [COUNT] [ROUNDS] [TRUTH]     # BIN: the stages (else target/release)
"""
import pathlib
import resource
import subprocess
import sys
import tempfile

import numpy as np

from mitsuba_images import BIN, read_image

ROOT = pathlib.Path(__file__).resolve().parents[2]
RUNS = {"INDIRECT=0": ["INDIRECT=0"], "INDIRECT=16": ["INDIRECT=16"],
        "INDIRECT=16 COARSE=0": ["INDIRECT=16", "COARSE=0"]}


def bake(out, count, extra):
    """The CPU seconds of one bake into `out` (emptied first)."""
    subprocess.run(["rm", "-rf", str(out)], check=True)
    t0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(["make", "-s", "-C", ROOT / "pipelines", "bake", f"BIN={BIN}", f"OUT={out}", f"COUNT={count}",
                    "MODEL=physical", "PROGRESS=0"] + extra, check=True, stdout=subprocess.DEVNULL)
    t1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (t1.ru_utime - t0.ru_utime) + (t1.ru_stime - t0.ru_stime)


def main():
    count = int(sys.argv[1]) if len(sys.argv) > 1 else 200000
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 2
    truth = int(sys.argv[3]) if len(sys.argv) > 3 else 256
    times = {k: [] for k in RUNS}
    with tempfile.TemporaryDirectory() as dd:
        d = pathlib.Path(dd)
        pictures = {}
        for _ in range(rounds):
            for k, extra in RUNS.items():
                out = d / k.replace(" ", "_").replace("=", "")
                times[k].append(bake(out, count, extra))
                pictures[k] = read_image(out / "bunny.exr", d, 480)
        base = np.mean(times["INDIRECT=0"])
        for k, t in times.items():
            print(f"{k}: CPU {', '.join(f'{x:.2f}' for x in t)} s; {np.mean(t) / base:.2f} of INDIRECT=0")
        out = d / "truth"
        bake(out, count, [f"INDIRECT={truth}", "COARSE=0"])
        full, cover = read_image(out / "bunny.exr", d, 480)
        m = (cover >= 1) & (full.min(axis=2) > 1e-4)

        def rms(a):
            r = (a[m] - full[m]) / full[m]
            return float(np.sqrt(np.mean(r ** 2))), float(np.mean(a[m]) / np.mean(full[m]) - 1)

        print(f"against {truth} rays a point on every point:")
        print("  INDIRECT=16, the first pass and the rays on a quarter of the points: RMS %.4f, mean %+.2e"
              % rms(pictures["INDIRECT=16"][0]))
        print("  INDIRECT=16 COARSE=0, both on every point: RMS %.4f, mean %+.2e"
              % rms(pictures["INDIRECT=16 COARSE=0"][0]))
        print("  no light between surfaces: RMS %.4f, mean %+.2e" % rms(pictures["INDIRECT=0"][0]))


if __name__ == "__main__":
    main()
