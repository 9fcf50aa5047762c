"""`make blender-addon-check`: the add-on (target/blender/pcsss-addon.zip)
installed into Blender (bpy from PyPI, a Python without pcsss of its own:
the add-on's wheel is the one that runs) as Blender installs extensions,
then its panel's bake run on Suzanne (subdivided, 100 mm a unit, skin1,
a sun from the front and a point light behind the head) and its colour
attributes held against `make bake` of the same scene by the binaries:
equal to the bit. Also the Cycles material it sets up (Random Walk, the
bake's medium read back through Cycles' fit).

Usage: python addon_check.py ADDON.zip BIN_DIR WORK_DIR
"""

import json
import math
import os
import subprocess
import sys

import bpy
import numpy as np

ZIP, BIN, WORK = (os.path.abspath(a) for a in sys.argv[-3:])
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def fail(why):
    print(f"blender-addon-check: {why}")
    sys.exit(1)


# Installed as Blender installs an extension (its wheel with it).
r = bpy.ops.extensions.package_install_files(filepath=ZIP, repo="user_default", enable_on_install=True)
if r != {"FINISHED"} or not hasattr(bpy.types.Scene, "pcsss"):
    fail(f"the extension did not install and enable ({r})")
import pcsss  # noqa: E402  (the add-on's wheel, now on Blender's path)

if "extensions" not in pcsss.__file__:
    fail(f"pcsss came from {pcsss.__file__}, not the add-on's wheel")

bpy.ops.wm.read_factory_settings(use_empty=True)
# The factory settings dropped the add-on: enable it again.
bpy.ops.preferences.addon_enable(module="bl_ext.user_default.pcsss")
scene = bpy.context.scene
scene.unit_settings.scale_length = 0.1
bpy.ops.mesh.primitive_monkey_add(size=2.0)
head = bpy.context.active_object
mod = head.modifiers.new("subdivide", "SUBSURF")
mod.levels = 1
bpy.ops.object.modifier_apply(modifier=mod.name)
bpy.ops.object.light_add(type="SUN", rotation=(0.5, -0.3, 0.2))
bpy.context.active_object.data.energy = 3.0
bpy.ops.object.light_add(type="POINT", location=(0.0, 2.6, 1.6))
bpy.context.active_object.data.energy = 400.0
bpy.context.active_object.data.shadow_soft_size = 0.0
bpy.ops.object.camera_add(location=(0.0, -6.0, 0.3), rotation=(math.radians(88), 0.0, 0.0))
scene.camera = bpy.context.active_object
scene.render.resolution_x, scene.render.resolution_y = 320, 240
bpy.context.view_layer.objects.active = head
head.select_set(True)

s = scene.pcsss
s.preset, s.count = "skin1", 20000
if bpy.ops.object.pcsss_bake() != {"FINISHED"}:
    fail("the bake operator failed")
me = head.data
n = len(me.vertices)
got = {}
for name in ("ssM", "ssS", "sss"):
    rgba = np.empty(n * 4, np.float32)
    me.color_attributes[name].data.foreach_get("color", rgba)
    got[name] = rgba.reshape(n, 4)[:, :3]

# The binaries' bake of the same mesh, lights and camera.
from bl_ext.user_default.pcsss import bake  # noqa: E402

os.makedirs(WORK, exist_ok=True)
points, faces = bake.world_mesh(head, bpy.context.evaluated_depsgraph_get())
mesh = os.path.join(WORK, "suzanne.ply")
pcsss.write(pcsss.Cloud.from_arrays({"P": points}, faces=faces), mesh)
for name, value in (("lights.json", bake.lights_file(scene)), ("camera.json", bake.camera_file(scene))):
    with open(os.path.join(WORK, name), "w") as f:
        json.dump(value, f)
out = os.path.join(WORK, "out")
subprocess.run(["make", "-s", "-C", os.path.join(ROOT, "pipelines"), "bake", f"BIN={BIN}", f"MESH={mesh}",
                f"LIGHTS={os.path.join(WORK, 'lights.json')}", f"CAMERA={os.path.join(WORK, 'camera.json')}",
                f"OUT={out}", "MATERIAL=skin1", f"METERS_PER_UNIT={scene.unit_settings.scale_length!r}", "UP_AXIS=z", "COUNT=20000",
                "PROGRESS=0"], check=True)
want = pcsss.read(os.path.join(out, "suzanne_vertices.ply"))
same = all(np.array_equal(got[k], want[k]) for k in ("ssM", "ssS"))
same = same and np.array_equal(got["sss"], bake.beauty(want["ssM"], want["ssS"]))
lit = int((want["ssM"][:, 0] > 0).sum())
if not same:
    for k in ("ssM", "ssS"):
        d = np.abs(got[k] - want[k])
        print(f"blender-addon-check: {k} differs at {int((d > 0).any(axis=1).sum())} vertices, "
              f"by at most {d.max():.3g} (of {np.abs(want[k]).max():.3g})")

# The Cycles material of the bake's medium.
if bpy.ops.object.pcsss_cycles_material() != {"FINISHED"}:
    fail("the Cycles material operator failed")
from bl_ext.user_default.pcsss import cycles_fit  # noqa: E402

bsdf = next(nd for nd in head.active_material.node_tree.nodes if nd.type == "BSDF_PRINCIPLED")
colour = list(bsdf.inputs["Base Color"].default_value)[:3]
radius = list(bsdf.inputs["Subsurface Radius"].default_value)
albedo = [cycles_fit.cycles_alpha(c, 0.0) for c in colour]
sp, sa = (0.74, 0.88, 1.01), (0.032, 0.17, 0.48)
want_albedo = [x / (x + y) for x, y in zip(sp, sa)]
want_radius = [4 * math.pi / (x + y) / 100.0 for x, y in zip(sp, sa)]
medium_ok = all(abs(a / b - 1) < 1e-6 for a, b in zip(albedo, want_albedo)) and all(
    abs(a / b - 1) < 1e-5 for a, b in zip(radius, want_radius)) and bsdf.subsurface_method == "RANDOM_WALK"
print(f"blender-addon-check: Suzanne, {n} vertices, {lit} lit: the colour attributes equal the binaries' "
      f"bake: {same}; the Cycles material is the medium (albedo and radius read back): {medium_ok}")
sys.exit(0 if same and medium_ok and lit > n // 4 else 1)
