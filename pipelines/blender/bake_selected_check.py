"""`make blender-bake`: the recipe of pipelines/blender/bake_selected.py run
in Blender (bpy) on a UV sphere under a sun and a point light, held
against the same bake by the binaries on the mesh Blender exported.

Usage: python bake_selected_check.py BIN_DIR WORK_DIR
"""

import os
import subprocess
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
import bake_selected  # noqa: E402

import pcsss  # noqa: E402

BIN, WORK = sys.argv[-2], sys.argv[-1]
os.makedirs(WORK, exist_ok=True)

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(0.5, 0.0, 1.0))
sphere = bpy.context.active_object
bpy.ops.object.light_add(type="SUN", rotation=(0.6, 0.2, 0.3))
bpy.context.active_object.data.energy = 3.0
bpy.ops.object.light_add(type="POINT", location=(2.0, -2.0, 3.0))
bpy.context.active_object.data.energy = 500.0
bpy.context.active_object.data.shadow_soft_size = 0.0
bpy.context.view_layer.objects.active = sphere

got = bake_selected.bake(sphere, count=20000, sd=0.05)
me = sphere.data
attr = me.color_attributes["sss"]
rgba = np.empty(len(me.vertices) * 4, np.float32)
attr.data.foreach_get("color", rgba)
assert np.array_equal(rgba.reshape(-1, 4)[:, :3], got)

# The binaries on the same mesh and lights.
me_world = np.empty(len(me.vertices) * 3, np.float32)
me.vertices.foreach_get("co", me_world)
p = me_world.reshape(-1, 3) + np.array([0.5, 0.0, 1.0], np.float32)
mesh = os.path.join(WORK, "sphere.ply")
pcsss.write(pcsss.Cloud.from_arrays({"P": p}, faces=[list(f.vertices) for f in me.polygons]), mesh)
lights = os.path.join(WORK, "lights.json")
import json  # noqa: E402

with open(lights, "w") as f:
    json.dump(bake_selected.lights_file(bpy.context.scene), f)
run = lambda *a: subprocess.run([os.path.join(BIN, a[0])] + [str(x) for x in a[1:]], check=True)
run("scatter", mesh, "--count", 20000, "--blue", "--seed", 0, "--up-axis", "z", "--meters-per-unit", 1,
    "-o", os.path.join(WORK, "s.ply"))
run("facet", os.path.join(WORK, "s.ply"), "--mesh", mesh, "-o", os.path.join(WORK, "f.ply"))
run("illum", os.path.join(WORK, "f.ply"), "--lights", lights, "--mesh", mesh, "-o", os.path.join(WORK, "i.ply"))
run("ssmulti", os.path.join(WORK, "i.ply"), "--rd", "0.9,0.5,0.3", "--sd", 0.05, "--rgb",
    "-o", os.path.join(WORK, "m.ply"))
run("filter", mesh, "--cloud", os.path.join(WORK, "m.ply"), "-o", os.path.join(WORK, "v.ply"))
want = pcsss.read(os.path.join(WORK, "v.ply"))["ssM"]
lit = int((want[:, 0] > 0).sum())
same = bool(np.array_equal(got, want))
print(f"blender-bake: {len(want)} vertices, {lit} lit, the colour attribute equals the binaries' bake: {same}")
sys.exit(0 if same and lit > len(want) // 4 else 1)
