"""The scenes of race.py, each given the same way to Mitsuba
(mitsuba_bunny.scene), Cycles (cycles_bunny.setup) and the bake (`make
-C pipelines`): a closed mesh, its lights (the toolkit's lights file:
distant and point lights), a camera and a homogeneous medium under an
index-matched boundary (eta 1, g 0: Mitsuba's light sampling reaches a
delta light only through a null boundary).

- `bunny`: the bunny fixture (flat facets), its key and rim lights, the
  medium of albedo 0.95, 0.85, 0.7 and mean free path 0.1.
- `suzanne`: Blender's monkey head, subdivided twice and remeshed into
  one closed surface (voxels of 0.02: Blender's own mesh is three open
  shells), 75,668 triangles, smooth; skin1 (Jensen et al. 2001, the
  `skin1` preset: albedo and mean free path per channel) at 100 mm a
  unit, so the head is 27 cm across; a sun from the front and a point
  light behind and above the head, which shines through both ears (the
  setup the issue's lighting TD tried).
- `dragon`: the Stanford dragon (the vrip reconstruction, 871,414
  triangles, fetched by `make -C pipelines fetch-dragon`; it has small
  holes underneath, 4,270 open edges, the same for all three tools;
  flat facets: some of its triangles have no area, which gives Mitsuba's
  vertex normals NaNs), its fixture's key and rim lights and camera (a
  vertical field of view of 24 degrees, to fill a square frame), and
  the bunny's albedo at a
  mean free path of 0.004, a fiftieth of its length (its thin parts:
  the claws, horns and crest).
"""
import json
import pathlib
import subprocess

ROOT = pathlib.Path(__file__).resolve().parents[2]
CACHE = ROOT / "target" / "race"


def _skin1(unit_mm):
    """(albedo, mean free path) per channel of Jensen's skin1 (reduced
    scattering and absorption per mm, formats/MATERIAL.md) with a scene
    unit of `unit_mm` millimetres."""
    sp, sa = (0.74, 0.88, 1.01), (0.032, 0.17, 0.48)
    return ([s / (s + a) for s, a in zip(sp, sa)], [1.0 / ((s + a) * unit_mm) for s, a in zip(sp, sa)])


def suzanne_mesh():
    """target/race/suzanne.obj, made once with bpy (Y up, the face towards
    +Z, as Blender's OBJ export gives it)."""
    out = CACHE / "suzanne.obj"
    if out.exists():
        return out
    import bpy
    import bmesh  # after bpy, which puts it on the path
    bpy.ops.wm.read_factory_settings(use_empty=True)
    me = bpy.data.meshes.new("suzanne")
    bm = bmesh.new()
    bmesh.ops.create_monkey(bm)
    bm.to_mesh(me)
    bm.free()
    ob = bpy.data.objects.new("suzanne", me)
    bpy.context.scene.collection.objects.link(ob)
    sub = ob.modifiers.new("subdivide", "SUBSURF")
    sub.levels = sub.render_levels = 2
    rm = ob.modifiers.new("remesh", "REMESH")
    rm.mode = "VOXEL"
    rm.voxel_size = 0.02
    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
    bm = bmesh.new()
    bm.from_mesh(ev)
    bmesh.ops.triangulate(bm, faces=bm.faces)
    if any(not e.is_manifold for e in bm.edges):
        raise SystemExit("suzanne: the remeshed head is not closed")
    CACHE.mkdir(parents=True, exist_ok=True)
    lines = [f"v {v.co.x:.7g} {v.co.z:.7g} {-v.co.y:.7g}" for v in bm.verts]
    lines += ["f " + " ".join(str(v.index + 1) for v in f.verts) for f in bm.faces]
    bm.free()
    tmp = out.with_suffix(".tmp")
    tmp.write_text("\n".join(lines) + "\n")
    tmp.rename(out)
    return out


def dragon_mesh():
    out = ROOT / "out" / "models" / "dragon_vrip.ply"
    if not out.exists():
        subprocess.run(["make", "-s", "-C", ROOT / "pipelines", "fetch-dragon"], check=True)
    return out


def _lights(path):
    return json.loads((ROOT / path).read_text())["lights"]


def _camera(path):
    return json.loads((ROOT / path).read_text())


SKIN_ALBEDO, SKIN_MFP = _skin1(100.0)

SCENES = {
    "bunny": dict(mesh=lambda: ROOT / "fixtures/mesh/bunny.obj", flat=True,
                  lights=_lights("fixtures/lights/bunny.json"), camera=_camera("fixtures/cameras/bunny.json"),
                  albedo=[0.95, 0.85, 0.7], mfp=[0.1] * 3),
    "suzanne": dict(mesh=suzanne_mesh, flat=False,
                    lights=[{"name": "sun", "type": "distant", "color": [1.0, 0.97, 0.92], "intensity": 2.5,
                             "direction": [-0.35, -0.45, -1.0]},
                            {"name": "back", "type": "point", "color": [1.0, 1.0, 1.0], "intensity": 40.0,
                             "position": [0.0, 1.6, -2.6]}],
                    camera={"position": [0.0, 0.3, 5.5], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 1.0, 0.0],
                            "fov": 32, "width": 512, "height": 512},
                    albedo=SKIN_ALBEDO, mfp=SKIN_MFP),
    "dragon": dict(mesh=dragon_mesh, flat=True,
                   lights=_lights("fixtures/lights/dragon.json"),
                   camera=dict(_camera("fixtures/cameras/dragon.json"), fov=24),
                   albedo=[0.95, 0.85, 0.7], mfp=[0.004] * 3),
}
