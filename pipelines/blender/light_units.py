"""Blender's light units against the toolkit's, on a lit white plane.

Cycles renders a white diffuse plane (albedo 1) under one light at a
time: a sun, a point light, a spot and a square area light, each of
Blender's own units (W/m^2 for the sun, W for the others). The toolkit's
`illum` is run at the plane's centre under the light converted as
formats/LIGHTS.md#light-units says, and its irradiance over pi (the
radiance of a white Lambertian surface, the physical model's beauty) is
held against Blender's pixel. Run by `make blender-check` (bpy from PyPI,
outside `make test`); prints one line a light and exits 1 on a miss.

Usage: python light_units.py BIN_DIR WORK_DIR
"""

import json
import math
import os
import struct
import subprocess
import sys

import bpy

BIN, WORK = sys.argv[-2], sys.argv[-1]
os.makedirs(WORK, exist_ok=True)


def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.samples = 1024
    sc.cycles.use_denoising = False
    sc.cycles.max_bounces = 0  # the plane sees only the light
    sc.render.resolution_x = sc.render.resolution_y = 4
    sc.render.film_transparent = False
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    sc.view_settings.exposure = 0
    sc.view_settings.gamma = 1
    # A black world (a new world's background is 0.05 grey).
    sc.world = bpy.data.worlds.new("black")
    sc.world.color = (0, 0, 0)
    if sc.world.node_tree is not None:
        for node in sc.world.node_tree.nodes:
            if node.type == "BACKGROUND":
                node.inputs["Strength"].default_value = 0.0
    # The white plane.
    bpy.ops.mesh.primitive_plane_add(size=20)
    mat = bpy.data.materials.new("white")
    if not getattr(mat, "node_tree", None):
        mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    diff = nt.nodes.new("ShaderNodeBsdfDiffuse")
    diff.inputs["Color"].default_value = (1, 1, 1, 1)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(diff.outputs[0], out.inputs[0])
    bpy.context.object.data.materials.append(mat)
    # An orthographic camera straight down on a small patch at the centre.
    cam = bpy.data.cameras.new("cam")
    cam.type = "ORTHO"
    cam.ortho_scale = 0.01
    ob = bpy.data.objects.new("cam", cam)
    ob.location = (0, 0, 1)
    sc.collection.objects.link(ob)
    sc.camera = ob
    return sc


def render(sc):
    path = os.path.join(WORK, "plane.exr")
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    sc.render.filepath = path
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(path)
    px = list(img.pixels)
    n = len(px) // 4
    return sum(px[4 * i] for i in range(n)) / n


def toolkit(light):
    """illum's irradiance at the plane's centre (normal +z), over pi."""
    cloud = os.path.join(WORK, "point.ply")
    with open(cloud, "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex 1\n")
        for p in ["x", "y", "z", "nx", "ny", "nz"]:
            f.write(f"property float {p}\n")
        f.write("end_header\n0 0 0 0 0 1\n")
    lights = os.path.join(WORK, "lights.json")
    with open(lights, "w") as f:
        json.dump({"up_axis": "z", "meters_per_unit": 1, "lights": [light]}, f)
    out = os.path.join(WORK, "lit.ply")
    subprocess.run(
        [os.path.join(BIN, "illum"), cloud, "--lights", lights, "--no-shadows", "--format", "ascii", "-o", out],
        check=True,
    )
    with open(out) as f:
        lines = f.read().split("end_header\n")
    header, body = lines[0], lines[1].split()
    names = [l.split()[-1] for l in header.splitlines() if l.startswith("property")]
    return float(body[names.index("illum_r")]) / math.pi


def add_light(kind, **kw):
    data = bpy.data.lights.new(kind, kind)
    for k, v in kw.items():
        if k not in ("location", "rotation"):
            setattr(data, k, v)
    ob = bpy.data.objects.new(kind, data)
    ob.location = kw.get("location", (0, 0, 0))
    ob.rotation_euler = kw.get("rotation", (0, 0, 0))
    bpy.context.scene.collection.objects.link(ob)


misses = 0


def check(name, blender, ours, tol):
    global misses
    ratio = ours / blender
    ok = abs(ratio - 1) <= tol
    misses += not ok
    print(f"{name:6s} Blender {blender:.6f}  toolkit {ours:.6f}  ratio {ratio:.4f}  {'ok' if ok else 'MISS'}")


# Sun: strength S (W/m^2) at 60 degrees from the normal -> distant, intensity S.
S, tilt = 3.0, math.radians(60)
sc = reset()
add_light("SUN", energy=S, angle=0.0, rotation=(tilt, 0, 0))
# Blender's sun shines along its local -Z: rotated by tilt about X.
d = [0.0, math.sin(tilt), -math.cos(tilt)]
check("sun", render(sc), toolkit({"name": "sun", "type": "distant", "intensity": S, "direction": d}), 0.01)

# Point: power P (W) at height h -> point, intensity P / (4 pi).
P, h = 100.0, 2.0
sc = reset()
add_light("POINT", energy=P, shadow_soft_size=0.0, location=(0, 0, h))
check("point", render(sc), toolkit({"name": "bulb", "type": "point", "intensity": P / (4 * math.pi), "position": [0, 0, h]}), 0.01)

# Spot: the same inside its cone (size 60 degrees, blend 0).
sc = reset()
add_light("SPOT", energy=P, shadow_soft_size=0.0, spot_size=math.radians(60), spot_blend=0.0, location=(0, 0, h))
check("spot", render(sc), toolkit({"name": "spot", "type": "spot", "intensity": P / (4 * math.pi), "position": [0, 0, h],
                                    "direction": [0, 0, -1], "cone_angle": 30, "cone_delta": 0}), 0.01)

# Area: a square of side a, power P, facing down -> rect, intensity P / pi.
a = 1.0
sc = reset()
add_light("AREA", energy=P, shape="SQUARE", size=a, location=(0, 0, h))
check("area", render(sc), toolkit({"name": "panel", "type": "rect", "intensity": P / math.pi, "position": [0, 0, h],
                                    "u": [a, 0, 0], "v": [0, -a, 0], "samples": 4096}), 0.01)

sys.exit(1 if misses else 0)
