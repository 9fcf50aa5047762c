"""The Python module against the binary (issue 45's measures), side by side
in one run on this machine:

- moving a 1M-point cloud between NumPy and the toolkit: a scalar
  column's view and a 3-vector's N x 3 view (no copy: a PLY's records,
  and the rows the module keeps a stage's 3-vectors in) against NumPy's
  own copy of them, and Cloud.from_arrays (a copy into columns);
- ssmulti at 1M points from Python (read, stage, write) against the
  binary doing the same, alternated, best of each.

    make pywheel && target/pyenv/bin/python benches/py/python_module.py [--points N]
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import pcsss

from timing import best  # benches/py/timing.py

ROOT = Path(__file__).resolve().parents[2]
BIN = ROOT / "target" / "release"
MESH = str(ROOT / "fixtures" / "mesh" / "bunny.obj")
LIGHTS = str(ROOT / "fixtures" / "lights" / "bunny.json")


def run(*args):
    subprocess.run([str(a) for a in args], check=True)



def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--out", default=str(ROOT / "benches" / "results" / "python_module.json"))
    a = ap.parse_args()
    d = Path(tempfile.mkdtemp())
    run(BIN / "scatter", MESH, "--count", a.points, "-q", "-o", d / "s.ply")
    run(BIN / "facet", d / "s.ply", "--mesh", MESH, "-q", "-o", d / "f.ply")
    run(BIN / "illum", d / "f.ply", "--lights", LIGHTS, "--mesh", MESH, "-q", "-o", d / "i.ply")
    cloud = pcsss.read(d / "i.ply")
    n = len(cloud)
    res = {"points": n, "machine": os.uname().nodename}
    col = cloud["ptarea"]
    res["scalar_view_s"] = best(lambda: cloud["ptarea"], 20)
    res["numpy_copy_of_scalar_s"] = best(lambda: np.array(col, copy=True), 20)
    res["scalar_view_shares_memory"] = bool(cloud["ptarea"].ctypes.data == col.ctypes.data)
    res["vec3_view_s"] = best(lambda: cloud["P"], 20)
    p = cloud["P"]
    res["vec3_view_shares_memory"] = bool(cloud["P"].ctypes.data == p.ctypes.data and not p.flags.owndata)
    res["numpy_copy_of_vec3_s"] = best(lambda: np.array(p, copy=True), 10)
    staged = pcsss.ssmulti(cloud, rd=(0.9, 0.5, 0.3), sd=0.6, rgb=True)
    res["stage_vec3_view_s"] = best(lambda: staged["ssM"], 20)
    res["stage_vec3_view_shares_memory"] = bool(
        staged["ssM"].ctypes.data == staged["ssM"].ctypes.data and not staged["ssM"].flags.owndata)
    del staged
    arrays = {"P": p, "N": cloud["N"], "ptarea": np.array(col)}
    res["from_arrays_s"] = best(lambda: pcsss.Cloud.from_arrays(arrays), 5)
    opts = dict(rd=(0.9, 0.5, 0.3), sd=0.6, rgb=True)
    argv = ["--rd", "0.9,0.5,0.3", "--sd", "0.6", "--rgb", "-q"]

    def binary():
        run(BIN / "ssmulti", d / "i.ply", *argv, "-o", d / "bin.ply")

    def python():
        pcsss.write(pcsss.ssmulti(pcsss.read(d / "i.ply"), **opts), d / "py.ply")

    tb, tp = [], []
    for _ in range(a.runs):
        tb.append(best(binary, 1))
        tp.append(best(python, 1))
    res["ssmulti_binary_s"] = tb
    res["ssmulti_python_s"] = tp
    res["python_over_binary_best"] = min(tp) / min(tb)
    same = pcsss.read(d / "bin.ply")["ssM"].tobytes() == pcsss.read(d / "py.ply")["ssM"].tobytes()
    res["same_ssM_bits"] = same
    json.dump(res, sys.stdout, indent=1)
    print()
    Path(a.out).write_text(json.dumps(res, indent=1) + "\n")


if __name__ == "__main__":
    main()
