# The body of a Houdini Python SOP that bakes subsurface scattering onto
# its input's points: `Cd` (the picture's beauty, linear) and `ssM`.
# Paste it into a Python SOP (the `pcsss` wheel installed in Houdini's
# Python: `hython -m pip install pcsss-*.whl`), and set the spare
# parameters it reads, or edit the defaults below. Houdini is Y up; give
# the lights file in the geometry's units.
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

P = np.asarray(geo.pointFloatAttribValues("P"), dtype=np.float32).reshape(-1, 3)
faces = [[v.point().number() for v in prim.vertices()] for prim in geo.prims()]
with tempfile.TemporaryDirectory() as d:
    mesh_path = os.path.join(d, "mesh.ply")
    pcsss.write(pcsss.Cloud.from_arrays({"P": P}, faces=faces), mesh_path)
    cloud = pcsss.scatter(pcsss.read(mesh_path), count=count, blue=True, up_axis="y")
    cloud = pcsss.facet(cloud, mesh=mesh_path)
    cloud = pcsss.illum(cloud, lights=lights, mesh=mesh_path)
    cloud = pcsss.ssmulti(cloud, rd=rd, sd=sd, rgb=True)
    cloud_path = os.path.join(d, "sss.ply")
    pcsss.write(cloud, cloud_path)
    # The cloud's light onto the mesh's own points, in their order.
    baked = pcsss.filter(pcsss.read(mesh_path), cloud=cloud_path)

ssm = baked["ssM"]
for name, values in (("ssM", ssm), ("Cd", ssm)):
    if geo.findPointAttrib(name) is None:
        geo.addAttrib(hou.attribType.Point, name, (0.0, 0.0, 0.0))  # noqa: F821
    geo.setPointFloatAttribValues(name, values.astype(np.float32).ravel().tolist())
