"""Reading a USD mesh of a million triangles: the toolkit (pcinfo, which
reads the stage as a mesh through openusd, built unoptimised: Cargo.toml)
against Pixar's own library opening the stage and reading its points,
side by side in one run, as `.usdc` and as `.usda`.

    cargo build --release && target/pyenv/bin/python benches/py/usd_read.py
"""

import json
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from pxr import Sdf, Usd, UsdGeom, Vt

from timing import best  # benches/py/timing.py

ROOT = Path(__file__).resolve().parents[2]
PCINFO = ROOT / "target" / "release" / "pcinfo"


def write(path, n=708):
    """A wavy grid of n^2 quads (about a million triangles) with `st`."""
    xs = np.linspace(0, 1, n + 1, dtype=np.float32)
    x, y = np.meshgrid(xs, xs)
    p = np.stack([x.ravel(), y.ravel(), (0.1 * np.sin(6 * x) * np.cos(5 * y)).ravel()], 1)
    p = p.astype(np.float32)
    i = np.arange(n)
    a = (i[:, None] * (n + 1) + i[None, :]).ravel()
    idx = np.stack([a, a + 1, a + n + 2, a + n + 1], 1).ravel().astype(np.int32)
    st = Usd.Stage.CreateNew(str(path))
    m = UsdGeom.Mesh.Define(st, "/grid")
    m.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(p))
    m.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(n * n, 4, np.int32)))
    m.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(idx))
    pv = UsdGeom.PrimvarsAPI(m).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                             UsdGeom.Tokens.vertex)
    pv.Set(Vt.Vec2fArray.FromNumpy(p[:, :2].copy()))
    st.GetRootLayer().Save()



def main():
    d = Path(tempfile.mkdtemp())
    res = {}
    for ext in ("usdc", "usda"):
        path = d / f"grid.{ext}"
        write(path)
        ours = best(lambda: subprocess.run([str(PCINFO), str(path)], check=True,
                                           capture_output=True))

        def pixar_read():
            stage = Usd.Stage.Open(str(path))
            mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/grid"))
            return len(mesh.GetPointsAttr().Get()) + len(mesh.GetFaceVertexIndicesAttr().Get())

        pixar = best(pixar_read)
        res[ext] = {"bytes": path.stat().st_size, "pcsss_s": ours, "pixar_s": pixar,
                    "pcsss_over_pixar": ours / pixar}
    print(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
