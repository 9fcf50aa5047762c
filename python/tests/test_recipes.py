"""The guide's recipes, run outside their hosts: the Houdini Python SOP
body (pipelines/houdini/python_sop.py) with a stand-in for the `hou`
calls it makes, on a mesh given as arrays, against the stages run by
the binaries on the same mesh."""

import json
import os
import subprocess
import types
from pathlib import Path

import numpy as np

import pcsss

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("PCSSS_BIN", ROOT / "target" / "release"))


def icosphere():
    """A unit icosahedron subdivided twice, as arrays."""
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
         (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5),
         (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    v = [np.array(p, float) / np.linalg.norm(p) for p in v]
    for _ in range(2):
        mid, nf = {}, []

        def m(a, b):
            k = (min(a, b), max(a, b))
            if k not in mid:
                p = v[a] + v[b]
                v.append(p / np.linalg.norm(p))
                mid[k] = len(v) - 1
            return mid[k]

        for a, b, c in f:
            ab, bc, ca = m(a, b), m(b, c), m(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    return np.array(v, np.float32) * 5.0, [list(x) for x in f]


class Geometry:
    """What the SOP body asks of hou.Geometry, over arrays."""

    def __init__(self, p, faces):
        self.attribs = {"P": p}
        self.faces = faces

    def pointFloatAttribValues(self, name):
        return self.attribs[name].ravel().tolist()

    def prims(self):
        point = lambda i: types.SimpleNamespace(point=lambda: types.SimpleNamespace(number=lambda: i))
        return [types.SimpleNamespace(vertices=lambda f=f: [point(i) for i in f]) for f in self.faces]

    def findPointAttrib(self, name):
        return name if name in self.attribs else None

    def addAttrib(self, kind, name, default):
        self.attribs[name] = np.zeros((len(self.attribs["P"]), len(default)), np.float32)

    def setPointFloatAttribValues(self, name, values):
        self.attribs[name] = np.asarray(values, np.float32).reshape(len(self.attribs["P"]), -1)


def run_sop(tmp_path, parms):
    """The SOP body run on the icosphere under one distant light, with the
    spare parameters `parms` (and `lights`): (points, faces, lights file,
    the geometry it wrote)."""
    p, faces = icosphere()
    lights = tmp_path / "lights.json"
    lights.write_text(json.dumps({"lights": [
        {"name": "key", "type": "distant", "direction": [0.3, -1.0, -0.4], "intensity": 2.0}]}))
    geo = Geometry(p, faces)
    parms = dict(parms, lights=str(lights))
    node = types.SimpleNamespace(
        geometry=lambda: geo,
        parm=lambda n: types.SimpleNamespace(eval=lambda: parms[n]) if n in parms else None)
    hou = types.SimpleNamespace(pwd=lambda: node, attribType=types.SimpleNamespace(Point="point"))
    body = (ROOT / "pipelines" / "houdini" / "python_sop.py").read_text()
    exec(compile(body, "python_sop.py", "exec"), {"hou": hou, "__name__": "__sop__"})
    return p, faces, lights, geo


def test_the_houdini_sop_body_bakes_the_binaries_bits(tmp_path):
    p, faces, lights, geo = run_sop(tmp_path, {"count": 5000, "sd": 0.8, "rd": "0.9,0.5,0.3"})
    cd = geo.attribs["Cd"]
    assert cd.shape == p.shape and (cd > 0).any()

    # The same bake by the binaries, on the same mesh.
    mesh = tmp_path / "mesh.ply"
    pcsss.write(pcsss.Cloud.from_arrays({"P": p}, faces=faces), mesh)
    steps = [
        ["scatter", mesh, "--count", "5000", "--blue", "--up-axis", "y", "-o", tmp_path / "s.ply"],
        ["facet", tmp_path / "s.ply", "--mesh", mesh, "-o", tmp_path / "f.ply"],
        ["illum", tmp_path / "f.ply", "--lights", lights, "--mesh", mesh, "-o", tmp_path / "i.ply"],
        ["ssmulti", tmp_path / "i.ply", "--rd", "0.9,0.5,0.3", "--sd", "0.8", "--rgb", "-o", tmp_path / "m.ply"],
        ["filter", mesh, "--cloud", tmp_path / "m.ply", "-o", tmp_path / "v.ply"],
    ]
    for s in steps:
        subprocess.run([str(BIN / s[0])] + [str(a) for a in s[1:]], check=True, capture_output=True)
    want = pcsss.read(tmp_path / "v.ply")["ssM"]
    assert np.array_equal(geo.attribs["ssM"], want)


def test_the_houdini_sop_body_bakes_the_physical_model_with_a_material(tmp_path):
    # A ball of radius 5 units at 10 mm a unit: skin1 (a 1.3 mm mean free
    # path in red) on a 10 cm ball.
    p, faces, lights, geo = run_sop(tmp_path, {"count": 5000, "material": "skin1", "meters_per_unit": 0.01})

    mesh = tmp_path / "mesh.ply"
    pcsss.write(pcsss.Cloud.from_arrays({"P": p}, faces=faces), mesh)
    medium = ["--model", "physical", "--material", "skin1"]
    steps = [
        ["scatter", mesh, "--count", "5000", "--blue", "--up-axis", "y", "--meters-per-unit", "0.01",
         "-o", tmp_path / "s.ply"],
        ["facet", tmp_path / "s.ply", "--mesh", mesh, "-o", tmp_path / "f.ply"],
        ["illum", tmp_path / "f.ply", "--lights", lights, "--mesh", mesh, "--thickness", *medium,
         "-o", tmp_path / "i.ply"],
        ["ssmulti", tmp_path / "i.ply", *medium, "-o", tmp_path / "m.ply"],
        ["filter", mesh, "--cloud", tmp_path / "m.ply", "-o", tmp_path / "v.ply"],
    ]
    for s in steps:
        subprocess.run([str(BIN / s[0])] + [str(a) for a in s[1:]], check=True, capture_output=True)
    v = pcsss.read(tmp_path / "v.ply")
    assert np.array_equal(geo.attribs["ssM"], v["ssM"])
    assert np.array_equal(geo.attribs["Cd"], v["ssM"] / np.float32(np.pi))
    # The medium is skin1's at that scale (a millimetre is 0.1 unit).
    c = pcsss.read(tmp_path / "m.ply")
    assert abs(c.detail["ssmulti_mfp"][0] / (1 / 0.772 / 10) - 1) < 1e-9
    assert (geo.attribs["ssM"][:, 0] > geo.attribs["ssM"][:, 2]).mean() > 0.5
