"""Bakes subsurface scattering onto Blender's active mesh object and adds
the result as its colour attribute `sss` (per vertex, linear float
colour), from Blender's own lights. Run it in Blender's Text Editor or
with `blender --python`, the `pcsss` wheel installed in Blender's Python
(`python -m pip install pcsss-*.whl`). Blender is Z up, in metres times
the scene's unit scale; the lights convert by formats/LIGHTS.md's table
(a sun of strength S is a distant light of intensity S, a point light of
P watts one of P / (4 pi)); others are refused.

`bake(obj, count, rd, sd)` is the recipe; run as a script it bakes the
active object with the defaults below. `make blender-bake` runs it on a
sphere under a sun and a point light in Blender (bpy from PyPI) and
holds the attribute against the same bake by the binaries.
"""

import json
import math
import os
import tempfile

import bpy
import numpy as np

import pcsss


def lights_file(scene):
    out = []
    for ob in scene.objects:
        if ob.type != "LIGHT" or ob.hide_render:
            continue
        light, m = ob.data, np.array(ob.matrix_world)
        colour = list(light.color)
        if light.type == "SUN":
            down = -m[:3, 2]
            out.append({"name": ob.name, "type": "distant", "color": colour,
                        "intensity": light.energy, "direction": down.tolist()})
        elif light.type == "POINT" and light.shadow_soft_size == 0:
            out.append({"name": ob.name, "type": "point", "color": colour,
                        "intensity": light.energy / (4 * math.pi), "position": m[:3, 3].tolist()})
        elif light.type == "POINT":
            out.append({"name": ob.name, "type": "sphere", "color": colour,
                        "intensity": light.energy / (4 * math.pi), "position": m[:3, 3].tolist(),
                        "radius": light.shadow_soft_size})
        else:
            raise ValueError(f"{ob.name}: a {light.type} light; the recipe converts suns and point lights")
    return {"up_axis": "z", "meters_per_unit": scene.unit_settings.scale_length, "lights": out}


def bake(obj, count=100_000, rd=(0.9, 0.5, 0.3), sd=0.05, seed=0):
    """The object's mesh in world space, baked; returns the `sss` values."""
    scene = bpy.context.scene
    me = obj.data
    n = len(me.vertices)
    co = np.empty(n * 3, np.float32)
    me.vertices.foreach_get("co", co)
    m = np.array(obj.matrix_world)
    p = (co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]).astype(np.float32)
    faces = [list(poly.vertices) for poly in me.polygons]
    with tempfile.TemporaryDirectory() as d:
        mesh = os.path.join(d, "mesh.ply")
        lights = os.path.join(d, "lights.json")
        cloud_path = os.path.join(d, "sss.ply")
        pcsss.write(pcsss.Cloud.from_arrays({"P": p}, faces=faces), mesh)
        with open(lights, "w") as f:
            json.dump(lights_file(scene), f)
        cloud = pcsss.scatter(pcsss.read(mesh), count=count, blue=True, seed=seed, up_axis="z",
                              meters_per_unit=scene.unit_settings.scale_length)
        cloud = pcsss.facet(cloud, mesh=mesh)
        cloud = pcsss.illum(cloud, lights=lights, mesh=mesh)
        cloud = pcsss.ssmulti(cloud, rd=rd, sd=sd, rgb=True)
        pcsss.write(cloud, cloud_path)
        baked = pcsss.filter(pcsss.read(mesh), cloud=cloud_path)
    ssm = baked["ssM"]
    attr = me.color_attributes.get("sss") or me.color_attributes.new("sss", "FLOAT_COLOR", "POINT")
    rgba = np.concatenate([ssm, np.ones((n, 1), np.float32)], axis=1)
    attr.data.foreach_set("color", rgba.ravel())
    me.color_attributes.active_color = attr
    return ssm


if __name__ == "__main__":
    bake(bpy.context.active_object)
