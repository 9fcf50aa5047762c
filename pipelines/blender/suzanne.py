"""Blender's Suzanne, baked from both of Blender's exports with one line
of the guide each, giving the same picture.

Blender (bpy from PyPI) makes the scene as an artist would: Suzanne with
a level of subdivision and its UVs, a sun and a point light, a camera.
It exports the mesh twice, as Blender's exporters write it by default:
an OBJ (Y-up) and a PLY (Z-up). The lights and camera are written once,
in Blender's own frame and units (`"up_axis": "z"`, metres), the lights
converted as formats/LIGHTS.md#light-units says (a sun of strength S is a
distant light of intensity S, a point light of P watts one of P / (4 pi)).
Then

    make bake MESH=suzanne.obj UP_AXIS=y LIGHTS=... CAMERA=... MATERIAL=...
    make bake MESH=suzanne.ply UP_AXIS=z LIGHTS=... CAMERA=... MATERIAL=...

and the two pictures are compared. It also prints how far apart facet
puts the normals of the vertices the OBJ export split at its UV seams,
with and without the weld. Run by `make suzanne` (outside
`make test`); exits 1 when they differ by more than 1% of the picture's
mean, and prints the two bakes' times.

Usage: python suzanne.py ROOT OUT
"""

import json
import math
import os
import struct
import subprocess
import sys
import time

import bpy
import mathutils

ROOT, OUT = sys.argv[-2], sys.argv[-1]
os.makedirs(OUT, exist_ok=True)

bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
bpy.ops.mesh.primitive_monkey_add(size=2.0, location=(0, 0, 0))
monkey = bpy.context.object
mod = monkey.modifiers.new("subsurf", "SUBSURF")
mod.levels = 1
bpy.ops.object.modifier_apply(modifier=mod.name)
bpy.ops.object.shade_smooth()

# A sun from the upper left front and a point light behind the right ear.
sun = bpy.data.objects.new("key", bpy.data.lights.new("key", "SUN"))
sun.data.energy = 3.0
sun.rotation_euler = (math.radians(50), 0, math.radians(-35))
point = bpy.data.objects.new("rim", bpy.data.lights.new("rim", "POINT"))
point.data.energy = 400.0
point.location = (1.5, 2.5, 1.2)
cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
cam.location = (0.0, -4.2, 0.45)
cam.rotation_euler = (math.radians(86), 0, 0)
for ob in (sun, point, cam):
    sc.collection.objects.link(ob)
bpy.context.view_layer.update()

obj_path = os.path.join(OUT, "suzanne.obj")
ply_path = os.path.join(OUT, "suzanne.ply")
bpy.ops.object.select_all(action="DESELECT")
monkey.select_set(True)
bpy.context.view_layer.objects.active = monkey
bpy.ops.wm.obj_export(filepath=obj_path, export_selected_objects=True, export_materials=False,
                      export_uv=True, export_normals=True)
bpy.ops.wm.ply_export(filepath=ply_path, export_selected_objects=True, export_uv=True,
                      export_normals=True, ascii_format=False)


def axis(ob, v):
    return list(ob.matrix_world.to_3x3() @ mathutils.Vector(v))


lights = {
    "up_axis": "z",
    "meters_per_unit": 1.0,
    "lights": [
        {"name": "key", "type": "distant", "intensity": sun.data.energy,
         "direction": axis(sun, (0, 0, -1))},
        {"name": "rim", "type": "point", "intensity": point.data.energy / (4 * math.pi),
         "position": list(point.location)},
    ],
}
size = 256
camera = {
    "up_axis": "z",
    "meters_per_unit": 1.0,
    "position": list(cam.location),
    "look_at": [a + b for a, b in zip(cam.location, axis(cam, (0, 0, -1)))],
    "up": axis(cam, (0, 1, 0)),
    "fov": math.degrees(cam.data.angle),
    "width": size,
    "height": size,
}
with open(os.path.join(OUT, "lights.json"), "w") as f:
    json.dump(lights, f, indent=1)
with open(os.path.join(OUT, "camera.json"), "w") as f:
    json.dump(camera, f, indent=1)
# Skin scaled so that Suzanne is a few centimetres across: translucent.
with open(os.path.join(OUT, "material.json"), "w") as f:
    json.dump({"preset": "skin1", "unit_length": 15}, f)


def bake(mesh, up):
    out = os.path.join(OUT, os.path.splitext(os.path.basename(mesh))[1][1:])
    t = time.time()
    subprocess.run(["make", "-s", "-C", ROOT, "bake", f"MESH={mesh}", f"UP_AXIS={up}",
                    f"LIGHTS={OUT}/lights.json", f"CAMERA={OUT}/camera.json",
                    f"MATERIAL={OUT}/material.json", f"OUT={out}", "COUNT=100000"],
                   check=True)
    return os.path.join(out, "suzanne.png"), time.time() - t


def beauty(png):
    """The picture's colour channels (0 to 1), through Blender's reader."""
    img = bpy.data.images.load(png)
    px = list(img.pixels)
    return [px[i] for i in range(len(px)) if i % 4 != 3], px[3::4]


def seam_angles(weld):
    """The angles (degrees) between the normals facet gives the copies of
    a vertex the OBJ export split at a UV seam: the largest and the mean."""
    out = os.path.join(OUT, "facet.ply")
    args = [os.path.join(ROOT, "target", "release", "facet"), "-q", obj_path, "--format", "ascii", "-o", out]
    subprocess.run(args + ([] if weld else ["--no-weld"]), check=True)
    with open(out) as f:
        head, body = f.read().split("end_header\n", 1)
    names, nv = [], 0
    for line in head.splitlines():
        if line.startswith("element vertex"):
            nv = int(line.split()[-1])
        elif line.startswith("element"):
            break
        elif line.startswith("property"):
            names.append(line.split()[-1])
    at = {}
    angles = []
    for line in body.splitlines()[:nv]:
        v = [float(x) for x in line.split()]
        p = tuple(v[names.index(k)] for k in "xyz")
        n = [v[names.index(k)] for k in ("nx", "ny", "nz")]
        if p in at:
            d = max(-1.0, min(1.0, sum(a * b for a, b in zip(at[p], n))))
            angles.append(math.degrees(math.acos(d)))
        else:
            at[p] = n
    return max(angles), sum(angles) / len(angles), len(angles)


for weld in (False, True):
    top, mean, count = seam_angles(weld)
    print(f"facet {'welded' if weld else '--no-weld'}: {count} seam copies, normals up to {top:.2f} degrees apart (mean {mean:.2f})")

(a, ta), (b, tb) = bake(obj_path, "y"), bake(ply_path, "z")
(va, alpha), (vb, _) = beauty(a), beauty(b)
mean = sum(va) / len(va)
diff = sum(abs(x - y) for x, y in zip(va, vb)) / len(va)
covered = sum(1 for x in alpha if x > 0) / len(alpha)
print(f"OBJ (Y-up) bake {ta:.1f} s, PLY (Z-up) bake {tb:.1f} s; "
      f"mean |difference| {diff:.2e} = {diff / mean:.2%} of the mean; {covered:.0%} of the picture covered")
sys.exit(0 if covered > 0.1 and diff <= 0.01 * mean else 1)
