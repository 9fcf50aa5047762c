# The body of a Houdini Python SOP that bakes subsurface scattering onto
# its input's points: `Cd` (the picture's beauty, linear) and `ssM`.
# Paste it into a Python SOP (the `pcsss` wheel installed in Houdini's
# Python: `hython -m pip install pcsss-*.whl`), and set the spare
# parameters it reads, or edit the defaults below. Houdini is Y up; give
# the lights file in the geometry's units.
#
# `material` (a preset such as skin1, or a material file,
# formats/MATERIAL.md) bakes the physical model, as `make bake
# MATERIAL=...` does, in a scene of `meters_per_unit` metres a unit
# (Houdini's default: 1); `Cd` is then its beauty, `ssM / pi` (ssM is an
# exitance). Without it, Marengo's seed model with `rd` and `sd`.
#
# Tested outside Houdini (python/tests/test_recipes.py) with a stand-in
# for the few `hou` calls it makes, on a mesh given as arrays.
import os
import tempfile

import numpy as np

import pcsss

node = hou.pwd()  # noqa: F821 (Houdini's module)
geo = node.geometry()


def parm(name, default):
    p = node.parm(name)
    return p.eval() if p is not None else default


lights = parm("lights", "$HIP/lights.json")
count = int(parm("count", 100000))
sd = float(parm("sd", 0.6))
rd = tuple(float(x) for x in str(parm("rd", "0.9,0.5,0.3")).split(","))
material = str(parm("material", "")).strip()
meters_per_unit = float(parm("meters_per_unit", 1.0))

P = np.asarray(geo.pointFloatAttribValues("P"), dtype=np.float32).reshape(-1, 3)
faces = [[v.point().number() for v in prim.vertices()] for prim in geo.prims()]
with tempfile.TemporaryDirectory() as d:
    mesh_path = os.path.join(d, "mesh.ply")
    pcsss.write(pcsss.Cloud.from_arrays({"P": P}, faces=faces), mesh_path)
    frame = {"up_axis": "y", "meters_per_unit": meters_per_unit if material else None}
    cloud = pcsss.scatter(pcsss.read(mesh_path), count=count, blue=True, **frame)
    cloud = pcsss.facet(cloud, mesh=mesh_path)
    if material:
        medium = {"model": "physical", "material": material}
        cloud = pcsss.illum(cloud, lights=lights, mesh=mesh_path, thickness=True, **medium)
        cloud = pcsss.ssmulti(cloud, **medium)
    else:
        cloud = pcsss.illum(cloud, lights=lights, mesh=mesh_path)
        cloud = pcsss.ssmulti(cloud, rd=rd, sd=sd, rgb=True)
    cloud_path = os.path.join(d, "sss.ply")
    pcsss.write(cloud, cloud_path)
    # The cloud's light onto the mesh's own points, in their order.
    baked = pcsss.filter(pcsss.read(mesh_path), cloud=cloud_path)

ssm = baked["ssM"]
cd = ssm / np.float32(np.pi) if material else ssm
for name, values in (("ssM", ssm), ("Cd", cd)):
    if geo.findPointAttrib(name) is None:
        geo.addAttrib(hou.attribType.Point, name, (0.0, 0.0, 0.0))  # noqa: F821
    geo.setPointFloatAttribValues(name, values.astype(np.float32).ravel().tolist())
