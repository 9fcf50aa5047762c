"""The physical ssmulti where the diffusion length is long (issue 59):
skim milk on a unit cube of 200,000 points, its red diffuse mean free
path a fifth of the cube and a fiftieth, the exact method and the
approximate one (`--tolerance`), CPU seconds (user + sys of the ssmulti
process) and the error against the exact method of the same length.

    python long_diffusion.py [--grey] [COUNT] [TOLERANCES] [RUNS]

COUNT defaults to 200000; TOLERANCES (comma-separated) to 0.2,0.3,0.4;
RUNS (the best of which is kept) to 3. `--grey`: one length for the
three channels (`--color 0.9`, the red length), one kernel a pair. The cloud is `make -C pipelines`'s
illuminated cube (the bunny fixture's two distant lights). Errors per
point and channel, relative to the exact value: RMS over the points
above a hundredth of the largest value (a face the light does not reach
gets only the far tails of its neighbours' light, where a small
absolute error is a large relative one), and the RMS over all points of
the difference over the exact values' RMS. Rows go to
benches/results/long_diffusion.json.
"""
import json
import pathlib
import resource
import subprocess
import sys
import tempfile

import numpy as np
from plyfile import PlyData

ROOT = pathlib.Path(__file__).resolve().parents[2]
BIN = ROOT / "target" / "release"
# skim milk's red diffuse mean free path, in millimetres (ssmulti_dmfp
# with unit_length 1, read back below).
RED_DMFP_MM = None


def cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def ssm(path):
    v = PlyData.read(str(path))["vertex"]
    return np.stack([v["ssM_r"], v["ssM_g"], v["ssM_b"]], 1).astype(float)


def detail(path, key):
    out = subprocess.run([BIN / "pcinfo", path], check=True, capture_output=True, text=True).stdout
    line = next(x for x in out.splitlines() if x.split()[:1] == [key])
    return line


def ssmulti(cloud, unit_mm, tol, out, runs, grey=None):
    """The best CPU seconds of `runs` and the pairs summed; `grey`: the
    one diffuse mean free path of a grey medium, in place of skim milk."""
    if grey is None:
        mat = out.with_suffix(".json")
        mat.write_text(json.dumps({"preset": "skimmilk", "unit_length": unit_mm}))
        medium = ["--material", mat]
    else:
        medium = ["--model", "physical", "--color", "0.9", "--dmfp", str(grey)]
    best, pairs = None, None
    for _ in range(runs):
        c0 = cpu()
        r = subprocess.run([BIN / "ssmulti", "-v", cloud, *medium, "--tolerance", str(tol), "-o", out],
                           check=True, capture_output=True, text=True)
        t = cpu() - c0
        best = t if best is None else min(best, t)
        pairs = int(r.stderr.split(" pairs")[0].split()[-1])
    return best, pairs


def main():
    a = sys.argv[1:]
    grey = "--grey" in a
    a = [x for x in a if x != "--grey"]
    count = int(a[0]) if len(a) > 0 else 200000
    tols = [float(x) for x in (a[1] if len(a) > 1 else "0.2,0.3,0.4").split(",")]
    runs = int(a[2]) if len(a) > 2 else 3
    rows = []
    with tempfile.TemporaryDirectory() as dd:
        d = pathlib.Path(dd)
        subprocess.run(["make", "-s", "-C", ROOT / "pipelines", f"BIN={BIN}", f"MESH={ROOT}/fixtures/mesh/cube.obj",
                        f"OUT={d}", f"COUNT={count}", "MODEL=physical", "PROGRESS=0",
                        f"LIGHTS={ROOT}/fixtures/lights/bunny.json", f"{d}/cube_illum.ply"], check=True)
        cloud = d / "cube_illum.ply"
        probe = d / "probe.ply"
        ssmulti(cloud, 1.0, 0.0, probe, 1)
        red = float(detail(probe, "ssmulti_dmfp").split("(")[1].split(",")[0])
        what = "grey, colour 0.9" if grey else f"skim milk, red dmfp {red:.3g} mm (the cube 1 unit)"
        print(f"{count} points on a unit cube; {what}; best of {runs}, CPU of the ssmulti process", flush=True)
        print("| red dmfp (cube sides) | tolerance | CPU (s) | over the exact method at a fiftieth | pairs | "
              "RMS relative, points above 1% | RMS over all, of the exact RMS |")
        print("|---|---|---|---|---|---|---|")
        base = None
        for frac in (1 / 50, 1 / 5):
            unit = red / frac
            exact_out = d / f"exact_{frac:.3f}.ply"
            g = frac if grey else None
            t0, p0 = ssmulti(cloud, unit, 0.0, exact_out, runs, g)
            e = ssm(exact_out)
            if base is None:
                base = t0
            for tol in [0.0] + tols:
                if tol == 0.0:
                    t, pairs, a = t0, p0, e
                else:
                    out = d / f"approx_{frac:.3f}_{tol}.ply"
                    t, pairs = ssmulti(cloud, unit, tol, out, runs, g)
                    a = ssm(out)
                m = e > 0.01 * e.max()
                rel = np.sqrt(np.mean(((a - e)[m] / e[m]) ** 2))
                glob = np.sqrt(np.mean((a - e) ** 2)) / np.sqrt(np.mean(e ** 2))
                rows.append({"dmfp": frac, "tolerance": tol, "cpu": t, "ratio": t / base, "pairs": pairs,
                             "rms_rel": rel, "rms_global": glob})
                print(f"| 1/{round(1 / frac)} | {tol:g} | {t:.2f} | {t / base:.2f} | {pairs:,} | {rel:.2e} | "
                      f"{glob:.2e} |", flush=True)
    name = "long_diffusion_grey.json" if grey else "long_diffusion.json"
    (ROOT / "benches" / "results" / name).write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
