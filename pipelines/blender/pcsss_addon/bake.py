"""The add-on's bake, without its panel: the active mesh baked by the
pcsss Python module as `make bake MODEL=physical` bakes it (the same
stages, options and defaults, docs/GUIDE.md), from the scene's own
lights and camera, in Blender's units, and the result written on the
mesh as colour attributes.

Blender is Z up, in metres times the scene's unit scale: the cloud
records that frame (`up_axis` z, `meters_per_unit` the scale), so a
preset's millimetres are the scene's. The lights convert by
formats/LIGHTS.md's table (a sun of strength S is a distant light of
intensity S, a point light of P watts one of P / (4 pi), with a radius a
sphere light); other lights are refused, naming them.
"""

import math
import os
import tempfile

import numpy as np

import pcsss

# The measured media (formats/MATERIAL.md#presets).
PRESETS = ["apple", "chicken1", "chicken2", "cream", "ketchup", "marble", "potato", "skimmilk",
           "wholemilk", "skin1", "skin2"]

# The colour attributes a bake writes on the mesh (linear, one a vertex).
ATTRIBUTES = ("ssM", "ssS", "sss")


class BakeError(Exception):
    """What stops a bake, in one line naming what is at fault."""


def lights_file(scene):
    """The scene's visible lights as a lights file (formats/LIGHTS.md)."""
    out = []
    for ob in scene.objects:
        if ob.type != "LIGHT" or ob.hide_render:
            continue
        light, m = ob.data, np.array(ob.matrix_world)
        colour = list(light.color)
        if light.type == "SUN":
            out.append({"name": ob.name, "type": "distant", "color": colour,
                        "intensity": light.energy, "direction": (-m[:3, 2]).tolist()})
        elif light.type == "POINT" and light.shadow_soft_size == 0:
            out.append({"name": ob.name, "type": "point", "color": colour,
                        "intensity": light.energy / (4 * math.pi), "position": m[:3, 3].tolist()})
        elif light.type == "POINT":
            out.append({"name": ob.name, "type": "sphere", "color": colour,
                        "intensity": light.energy / (4 * math.pi), "position": m[:3, 3].tolist(),
                        "radius": light.shadow_soft_size})
        else:
            raise BakeError(f"light {ob.name}: a {light.type} light; the bake takes suns and point lights")
    if not out:
        raise BakeError("the scene has no sun or point light to bake with")
    return {"up_axis": "z", "meters_per_unit": scene.unit_settings.scale_length, "lights": out}


def camera_file(scene):
    """The scene's camera as a camera file (formats/CAMERA.md): its eye,
    its view down local -Z with +Y up, and the vertical field of view its
    lens and sensor give the render's size."""
    cam = scene.camera
    if cam is None or cam.type != "CAMERA":
        raise BakeError("the scene has no camera: single scattering is seen from one (or untick it)")
    if cam.data.type != "PERSP":
        raise BakeError(f"camera {cam.name}: {cam.data.type}; the bake's camera is a pinhole")
    r = scene.render
    w = max(1, round(r.resolution_x * r.resolution_percentage / 100))
    h = max(1, round(r.resolution_y * r.resolution_percentage / 100))
    d = cam.data
    fit = d.sensor_fit
    if fit == "AUTO":
        # The sensor's width spans the picture's longer side.
        half = d.sensor_width / (2 * d.lens)
        tan_v = half if h >= w else half * h / w
    elif fit == "HORIZONTAL":
        tan_v = d.sensor_width / (2 * d.lens) * h / w
    else:
        tan_v = d.sensor_height / (2 * d.lens)
    m = np.array(cam.matrix_world)
    eye = m[:3, 3]
    return {"position": eye.tolist(), "look_at": (eye - m[:3, 2]).tolist(), "up": m[:3, 1].tolist(),
            "fov": math.degrees(2 * math.atan(tan_v)), "width": w, "height": h,
            "up_axis": "z", "meters_per_unit": scene.unit_settings.scale_length}


def world_mesh(obj, depsgraph):
    """The object's mesh in world space: (points N x 3, faces). Its
    modifiers apply when they keep its vertices (an armature, a
    displacement); one that changes them (a subdivision) is refused, as
    the colours go on the mesh's own vertices."""
    if obj is None or obj.type != "MESH":
        raise BakeError("the active object is not a mesh")
    me = obj.data
    ev = obj.evaluated_get(depsgraph).data if depsgraph is not None else me
    if len(ev.vertices) != len(me.vertices) or len(ev.polygons) != len(me.polygons):
        raise BakeError(f"{obj.name}: its modifiers change its vertices: apply them first")
    if len(me.polygons) == 0:
        raise BakeError(f"{obj.name}: the mesh has no faces")
    n = len(ev.vertices)
    co = np.empty(n * 3, np.float32)
    ev.vertices.foreach_get("co", co)
    m = np.array(obj.matrix_world)
    p = (co.reshape(-1, 3).astype(np.float64) @ m[:3, :3].T + m[:3, 3]).astype(np.float32)
    return p, [list(poly.vertices) for poly in ev.polygons]


def material_option(preset, path):
    """The stages' `material` option: a preset's name, or a material file
    (formats/MATERIAL.md)."""
    if path:
        path = os.path.abspath(os.path.expanduser(path))
        if not os.path.isfile(path):
            raise BakeError(f"material file {path}: no such file")
        return path
    if preset not in PRESETS:
        raise BakeError(f"material {preset}: not a preset ({', '.join(PRESETS)})")
    return preset


def bake_points(points, faces, lights, camera, material, count=100_000, method="diffusion", walks=16,
                single=True, seed=0, meters_per_unit=1.0):
    """The bake of the mesh (`points`, `faces`) under `lights` (a lights
    file's dict) seen from `camera` (a camera file's dict; for `ssS`):
    `make bake MODEL=physical MATERIAL=material` step by step (walks:
    `METHOD=walk WALKS=walks EXIT=sky`, the exitance, which serves every
    view). Returns the mesh's vertices' cloud (`ssM`, `ssS`) and the
    bake's cloud (its detail records the medium)."""
    import json
    with tempfile.TemporaryDirectory() as d:
        lights_path = os.path.join(d, "lights.json")
        with open(lights_path, "w") as f:
            json.dump(lights, f)
        mesh = pcsss.measure(pcsss.Cloud.from_arrays({"P": points}, faces=faces))
        mesh = pcsss.promote(mesh, **{"class": "face", "attr": "area", "method": "sum", "as": "Tarea"})
        mesh_path = os.path.join(d, "mesh.ply")
        pcsss.write(mesh, mesh_path)
        c = pcsss.scatter(mesh, count=count, seed=seed, blue=True, ptarea="centroid", relax=0, up_axis="z",
                          meters_per_unit=meters_per_unit)
        c = pcsss.facet(c, mesh=mesh_path, mode="smooth", cusp=60)
        c = pcsss.promote(c, normalize=True)
        medium = {"model": "physical", "material": material}
        c = pcsss.illum(c, lights=lights_path, mesh=mesh_path, lmask="*", thickness=True, **medium)
        walk = {}
        if method == "walk":
            walk = {"method": "walk", "mesh": mesh_path, "walks": walks, "denoise": True,
                    "lights": lights_path, "lmask": "*"}
        elif method != "diffusion":
            raise BakeError(f"method {method}: diffusion or walk")
        c = pcsss.ssmulti(c, **medium, **walk)
        if single:
            cam_path = os.path.join(d, "camera.json")
            with open(cam_path, "w") as f:
                json.dump(camera, f)
            c = pcsss.sssingle(c, mesh=mesh_path, lights=lights_path, lmask="*", camera=cam_path,
                               samples=16, **medium)
        vertices = pcsss.filter(mesh, cloud=c, exposure=1.2)
    return vertices, c


def beauty(ssm, sss):
    """The physical model's beauty, a radiance: `ssM` is an exitance (pi
    times the radiance), `ssS` a radiance (render's sum)."""
    return ssm / np.float32(math.pi) + sss


def write_colours(me, values):
    """Colour attributes `ssM` (the exitance), `ssS` (the radiance of
    single scattering) and `sss` (the beauty, a radiance: `ssM / pi +
    ssS`, what an Emission shader shows) on mesh `me`, one linear float
    colour a vertex; `sss` made active."""
    n = len(me.vertices)
    ssm = values["ssM"]
    sss_ = values["ssS"] if "ssS" in values else np.zeros_like(ssm)
    for name, v in (("ssM", ssm), ("ssS", sss_), ("sss", beauty(ssm, sss_))):
        attr = me.color_attributes.get(name)
        if attr is not None and (attr.data_type != "FLOAT_COLOR" or attr.domain != "POINT"):
            me.color_attributes.remove(attr)
            attr = None
        if attr is None:
            attr = me.color_attributes.new(name, "FLOAT_COLOR", "POINT")
        rgba = np.concatenate([np.asarray(v, np.float32).reshape(n, 3), np.ones((n, 1), np.float32)], axis=1)
        attr.data.foreach_set("color", rgba.ravel())
    me.color_attributes.active_color = me.color_attributes["sss"]


def bake_object(context, obj, material, count=100_000, method="diffusion", walks=16, single=True, seed=0):
    """Bakes `obj` in `context`'s scene and writes its colour attributes;
    records the medium on the object (`pcsss_albedo`, `pcsss_mfp`,
    `pcsss_g`, `pcsss_eta`: per channel, in the scene's units) for the
    Cycles material. Returns the vertices' cloud."""
    scene = context.scene
    points, faces = world_mesh(obj, context.evaluated_depsgraph_get())
    lights = lights_file(scene)
    camera = camera_file(scene) if single else None
    vertices, cloud = bake_points(points, faces, lights, camera, material, count=count, method=method,
                                  walks=walks, single=single, seed=seed,
                                  meters_per_unit=scene.unit_settings.scale_length)
    write_colours(obj.data, vertices)
    detail = cloud.detail
    for key in ("albedo", "mfp", "g", "eta"):
        v = detail.get(f"ssmulti_{key}")
        if v is not None:
            obj[f"pcsss_{key}"] = list(v) if isinstance(v, (list, tuple)) else [float(v)]
    return vertices


def cycles_material(obj):
    """A Principled BSDF with Cycles' Random Walk given the medium the
    last bake recorded on `obj` (cycles_fit.py: the colour whose Cycles
    albedo is the medium's, radius `4 pi mfp / (1 - g)`, IOR eta), as the
    object's material `pcsss_cycles`, for a side-by-side render."""
    import bpy
    from . import cycles_fit
    try:
        albedo = list(obj["pcsss_albedo"])
        mfp = list(obj["pcsss_mfp"])
        g = float(obj["pcsss_g"][0])
        eta = float(obj["pcsss_eta"][0])
    except KeyError:
        raise BakeError(f"{obj.name}: bake it first (the material is the bake's medium)") from None
    if len(albedo) == 1:
        albedo = albedo * 3
    if len(mfp) == 1:
        mfp = mfp * 3
    colour, radius = cycles_fit.medium(albedo, mfp, g)
    mat = bpy.data.materials.get("pcsss_cycles") or bpy.data.materials.new("pcsss_cycles")
    mat.use_nodes = True
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    cycles_fit.random_walk(bsdf, colour, radius, g, eta)
    if obj.data.materials:
        obj.data.materials[0] = mat
    else:
        obj.data.materials.append(mat)
    return mat
