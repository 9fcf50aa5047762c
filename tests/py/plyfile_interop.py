"""Interop partner for tests/it/python_interop.rs: PLY files written and
read by Python's plyfile and trimesh, readers nobody on this project wrote.

  plyfile_interop.py dump FILE   -> JSON of every element/property value
  plyfile_interop.py write DIR   -> writes plyfile_*.ply and trimesh_*.ply

Floats are given as the bits of their float64 value, so the comparison is
exact; integers as integers.
"""
import json
import os
import struct
import sys

import numpy as np
from plyfile import PlyData, PlyElement


def bits(v):
    return struct.unpack("<Q", struct.pack("<d", float(v)))[0]


def enc(arr):
    arr = np.asarray(arr)
    if arr.dtype.kind == "f":
        return {"kind": "f", "v": [bits(x) for x in arr.tolist()]}
    return {"kind": "i", "v": [int(x) for x in arr.tolist()]}


def dump(path):
    ply = PlyData.read(path)
    out = {
        "comments": list(ply.comments),
        "obj_info": list(ply.obj_info),
        "text": ply.text,
        "byte_order": ply.byte_order,
        "elements": [],
    }
    for el in ply.elements:
        props = []
        for p in el.properties:
            data = el.data[p.name]
            if hasattr(p, "len_dtype"):
                props.append({"name": p.name, "list": True, "rows": [enc(r) for r in data]})
            else:
                props.append({"name": p.name, "list": False, "values": enc(data)})
        out["elements"].append({"name": el.name, "count": int(el.count), "props": props})
    json.dump(out, sys.stdout)


def write(d):
    rng = np.random.default_rng(7)
    n = 7
    dt = [
        ("x", "f8"), ("y", "f8"), ("z", "f8"),
        ("nx", "f4"), ("ny", "f4"), ("nz", "f4"),
        ("s_i1", "i1"), ("s_u1", "u1"), ("s_i2", "i2"), ("s_u2", "u2"),
        ("s_i4", "i4"), ("s_u4", "u4"), ("s_f4", "f4"),
        ("illum_r", "f4"), ("illum_g", "f4"), ("illum_b", "f4"),
    ]
    v = np.zeros(n, dtype=dt)
    for name, t in dt:
        if t.startswith("f"):
            v[name] = rng.normal(size=n) * 10.0 ** rng.integers(-30, 30, size=n)
        else:
            info = np.iinfo(t)
            v[name] = rng.integers(info.min, info.max, size=n, endpoint=True)
    v["x"][0] = 1e6 + 0.1
    v["s_f4"][1] = np.float32(np.inf)
    v["s_f4"][2] = np.float32(-0.0)
    v["s_f4"][3] = np.finfo(np.float32).tiny / 8
    face = np.empty(2, dtype=[("vertex_indices", "i4", (3,)), ("area", "f4")])
    face["vertex_indices"] = [[0, 1, 2], [2, 3, 4]]
    face["area"] = [0.5, 0.25]
    tags = np.empty(3, dtype=[("tags", "O"), ("w", "f8")])
    tags["tags"] = [np.array([], dtype="u2"), np.array([1, 65535], dtype="u2"), np.array([7, 8, 9], dtype="u2")]
    tags["w"] = [1.5, -2.5, 1e-300]
    els = [
        PlyElement.describe(v, "vertex"),
        PlyElement.describe(face, "face"),
        PlyElement.describe(tags, "extra", len_types={"tags": "u4"}, val_types={"tags": "u2"}),
    ]
    for name, text, order in [("le", False, "<"), ("be", False, ">"), ("ascii", True, "=")]:
        PlyData(els, text=text, byte_order=order, comments=["written by plyfile"], obj_info=["interop"]).write(
            os.path.join(d, f"plyfile_{name}.ply")
        )
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=2)
    m.export(os.path.join(d, "trimesh_icosphere.ply"))
    m.export(os.path.join(d, "trimesh_icosphere_ascii.ply"), encoding="ascii")


if __name__ == "__main__":
    if sys.argv[1] == "dump":
        dump(sys.argv[2])
    elif sys.argv[1] == "write":
        write(sys.argv[2])
    else:
        sys.exit("usage: plyfile_interop.py dump FILE | write DIR")
