"""The bunny scene of mitsuba_bunny.py in Blender Cycles (bpy from PyPI),
for race.py: the same mesh (flat facets), the two distant lights, the
camera, a Gaussian pixel filter of the same width, and the medium given
to Cycles' Random Walk subsurface method.

How the medium is given. Cycles' Random Walk does not take a medium's
coefficients: it takes a surface colour `A` and a radius `r`, and its
kernel turns them into a single-scattering albedo by a fit,
`alpha(A, g)`, and an extinction `sigma_t = 4 pi / (r (1 - g))` (the
radius over 4 pi is the reduced mean free path). So the colour is found
by inverting Cycles' fit (bisection on `A`: `alpha` rises with it) for
the medium's own albedo per channel, and the radius is `4 pi mfp / (1 -
g)`; `check()` reads the medium back through the same formulas.
Checked in pictures too: `--check` prints the ratio of Cycles' picture
to Mitsuba's over the bunny, per channel (the mean over the pixels both
light).

What is not the same medium. Cycles' walk enters half the time through
a diffuse (cosine) bounce and half through a rough refraction, and the
light leaving is a diffuse (Lambertian) surface at the exit point; the
walk counts single scattering too. Mitsuba (and the bake) refract
exactly at the index-matched boundary. So Cycles' converged picture is
not Mitsuba's, and race.py measures each tool against each path
tracer's own reference.

    python cycles_bunny.py [SIZE] [SPP]          # one picture, its CPU and means
    python cycles_bunny.py --check [SIZE] [SPP]  # beside Mitsuba (SPP; Cycles 4 x SPP)
"""
import math
import pathlib
import resource
import sys
import tempfile

import numpy as np

from mitsuba_bunny import ALBEDO, LIGHTS, MESH, MFP

# The fit lives with the Blender add-on, which sets the same material up.
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "pipelines" / "blender" / "pcsss_addon"))
import cycles_fit  # noqa: E402

G = 0.0
# Cycles' Gaussian pixel filter is exp(-2 (6 v / width)^2): a standard
# deviation of width / 12 pixels. Mitsuba's (and render's) is 0.5.
FILTER_WIDTH = 6.0


def medium(albedo=ALBEDO, mfp=MFP, g=G):
    """(base colour, radius) per channel for Cycles' Random Walk."""
    mfps = mfp if isinstance(mfp, (list, tuple)) else [mfp] * 3
    return cycles_fit.medium(albedo, mfps, g)


def check(albedo=ALBEDO, mfp=MFP, g=G):
    """The medium read back through Cycles' formulas: the largest
    relative difference of albedo and extinction from the medium's."""
    colour, radius = medium(albedo, mfp, g)
    mfps = mfp if isinstance(mfp, (list, tuple)) else [mfp] * 3
    da = max(abs(cycles_fit.cycles_alpha(c, g) / a - 1) for c, a in zip(colour, albedo))
    ds = max(abs((4 * math.pi / (r * (1 - g))) * m - 1) for r, m in zip(radius, mfps))
    return da, ds


def _cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _read_mesh(path):
    """(vertices, triangles) of an OBJ or a PLY, as they are (no axis
    change)."""
    path = pathlib.Path(path)
    if path.suffix == ".ply":
        from plyfile import PlyData
        p = PlyData.read(str(path))
        v = np.stack([p["vertex"][k] for k in "xyz"], 1).astype(np.float32)
        return v, np.vstack(p["face"]["vertex_indices"]).astype(np.int32)
    verts, faces = [], []
    for line in path.read_text().splitlines():
        w = line.split()
        if w[:1] == ["v"]:
            verts.append(tuple(float(x) for x in w[1:4]))
        elif w[:1] == ["f"]:
            faces.append(tuple(int(x.split("/")[0]) - 1 for x in w[1:]))
    return np.array(verts, np.float32), np.array(faces, np.int32)


def _mesh(bpy, path, flat):
    """The mesh as a Blender object, flat or smooth."""
    v, f = _read_mesh(path)
    me = bpy.data.meshes.new("mesh")
    me.vertices.add(len(v))
    me.vertices.foreach_set("co", v.ravel())
    me.loops.add(f.size)
    me.loops.foreach_set("vertex_index", f.ravel())
    me.polygons.add(len(f))
    me.polygons.foreach_set("loop_start", np.arange(0, f.size, 3, dtype=np.int32))
    me.update()
    me.validate()
    me.polygons.foreach_set("use_smooth", np.full(len(f), not flat))
    return bpy.data.objects.new("mesh", me)


def _look_at(mathutils, position, target, up):
    p, t, u = (mathutils.Vector(v) for v in (position, target, up))
    back = (p - t).normalized()
    right = u.cross(back).normalized()
    up2 = back.cross(right)
    m = mathutils.Matrix.Identity(4)
    for i in range(3):
        m[i][0], m[i][1], m[i][2], m[i][3] = right[i], up2[i], back[i], p[i]
    return m


def setup(cam, spp, seed=0, denoise=False, threads=2, scn=None):
    """A fresh Blender scene of the bunny (or race_scenes.py's scene `scn`,
    its mesh given as a path) for Cycles; returns bpy."""
    if scn is None:
        scn = dict(mesh=MESH, flat=True, lights=LIGHTS, albedo=ALBEDO, mfp=[MFP] * 3)
    import bpy
    import mathutils
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    cy = sc.cycles
    cy.device = "CPU"
    cy.samples = spp
    cy.use_adaptive_sampling = False
    cy.seed = seed
    cy.use_denoising = denoise
    if denoise:
        cy.denoiser = "OPENIMAGEDENOISE"
    cy.pixel_filter_type = "GAUSSIAN"
    cy.filter_width = FILTER_WIDTH
    # Every path followed as far as a walk goes: no bounce caps below the
    # walk's own, caustics on (the light of a refracting entry).
    cy.max_bounces = 1024
    cy.diffuse_bounces = 1024
    cy.transmission_bounces = 1024
    cy.min_light_bounces = 1024
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.use_light_tree = True
    sc.render.threads_mode = "FIXED"
    sc.render.threads = threads
    sc.render.resolution_x = cam["width"]
    sc.render.resolution_y = cam["height"]
    sc.render.resolution_percentage = 100
    sc.render.film_transparent = False
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    sc.view_settings.exposure = 0.0
    sc.view_settings.gamma = 1.0
    world = bpy.data.worlds.new("black")
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    sc.world = world

    obj = _mesh(bpy, scn["mesh"], scn["flat"])
    sc.collection.objects.link(obj)
    mat = bpy.data.materials.new("medium")
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    colour, radius = medium(scn["albedo"], scn["mfp"])
    # Index-matched as in Mitsuba: no specular layer, no bend at entry
    # (Random Walk refracts by the main IOR, clamped just above 1).
    cycles_fit.random_walk(bsdf, colour, radius, G, 1.0)
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    obj.data.materials.append(mat)

    for l in scn["lights"]:
        if l["type"] == "distant":
            d = mathutils.Vector(l["direction"]).normalized()
            data = bpy.data.lights.new(l["name"], type="SUN")
            data.energy = l.get("intensity", 1.0)
            data.angle = 0.0
            lo = bpy.data.objects.new(l["name"], data)
            # A sun shines along its local -Z.
            lo.rotation_euler = d.to_track_quat("-Z", "Y").to_euler()
        elif l["type"] == "point":
            # A point light of power P watts has a radiant intensity of
            # P / (4 pi) (formats/LIGHTS.md).
            data = bpy.data.lights.new(l["name"], type="POINT")
            data.energy = 4 * math.pi * l.get("intensity", 1.0)
            data.shadow_soft_size = 0.0
            data.use_soft_falloff = False
            lo = bpy.data.objects.new(l["name"], data)
            lo.location = l["position"]
        else:
            raise SystemExit(f"light {l['name']}: only distant and point lights go to Cycles here")
        data.color = l.get("color", [1, 1, 1])
        sc.collection.objects.link(lo)

    cd = bpy.data.cameras.new("camera")
    cd.sensor_fit = "VERTICAL"
    cd.angle_y = math.radians(cam["fov"])
    co = bpy.data.objects.new("camera", cd)
    co.matrix_world = _look_at(mathutils, cam["position"], cam["look_at"], cam["up"])
    sc.collection.objects.link(co)
    sc.camera = co
    return bpy


def render(cam, spp, seed=0, denoise=False, threads=2, scn=None):
    """Cycles' picture (linear RGB, rows from the top) and the CPU seconds
    the render took."""
    bpy = setup(cam, spp, seed, denoise, threads, scn)
    sc = bpy.context.scene
    with tempfile.TemporaryDirectory() as d:
        out = pathlib.Path(d) / "c.exr"
        sc.render.image_settings.file_format = "OPEN_EXR"
        sc.render.image_settings.color_depth = "32"
        sc.render.filepath = str(out)
        c0 = _cpu()
        bpy.ops.render.render(write_still=True)
        took = _cpu() - c0
        img = bpy.data.images.load(str(out))
        w, h = img.size
        px = np.array(img.pixels[:], dtype=np.float32).reshape(h, w, 4)[::-1, :, :3]
        bpy.data.images.remove(img)
    return px.copy(), took


def compare(cam, spp):
    """Cycles' picture (4 x `spp`) over Mitsuba's (`spp`), per channel:
    the ratio of their means over the pixels both light."""
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    from mitsuba_bunny import scene
    m = np.array(mi.render(mi.load_dict(scene(cam, spp)), spp=spp, seed=3))[:, :, :3]
    c, _ = render(cam, 4 * spp, seed=3)
    lit = (m.min(axis=2) > 1e-3) & (c.min(axis=2) > 1e-3)
    return c[lit].mean(axis=0) / m[lit].mean(axis=0), int(lit.sum())


if __name__ == "__main__":
    import json
    args = sys.argv[1:]
    beside = args[:1] == ["--check"]
    args = args[1:] if beside else args
    size = int(args[0]) if args else 128
    spp = int(args[1]) if len(args) > 1 else (256 if beside else 16)
    root = pathlib.Path(__file__).resolve().parents[2]
    cam = dict(json.loads((root / "fixtures/cameras/bunny.json").read_text()), width=size, height=size)
    print("medium:", medium(), "read back:", check())
    if beside:
        ratio, n = compare(cam, spp)
        print(f"Cycles / Mitsuba, mean over {n} pixels: {np.round(ratio, 4)}")
    else:
        img, t = render(cam, spp)
        print(f"{size} x {size}, {spp} spp: {t:.1f} s of CPU; mean {img.reshape(-1, 3).mean(axis=0)}")
