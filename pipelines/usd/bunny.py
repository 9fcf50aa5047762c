"""The bunny bake from a USD stage against the same bake from PLY and JSON
(issue 45's "must show"), with Pixar's library (usd-core) on both ends.

    make usd-bunny        (runs: target/pyenv/bin/python pipelines/usd/bunny.py)

1. Writes out/usd/bunny.usda with Pixar's library, as a studio's asset
   would be: Y up in centimetres; the bunny's points as authored in
   fixtures/mesh/bunny.obj under /World, which is scaled by 10 (so the
   world is ten times the OBJ's size, in cm), turned 30 degrees about Y and
   moved; the two lights of fixtures/lights/bunny.json as UsdLux
   DistantLights and the camera of fixtures/cameras/bunny.json as a
   UsdGeomCamera, all under /World.
2. Writes the same scene as an exporter that flattens transforms would:
   a PLY of the mesh's world-space points (Pixar's
   ComputeLocalToWorldTransform, rounded to float), and JSON lights and
   camera from Pixar's world transforms by the table of
   formats/LIGHTS.md, all stating Y up in centimetres.
   Bakes both with the guide's `make bake` line, the distances ten times
   the default bake's (SD, MFP), as the stage's world is ten times the
   OBJ's: once from the PLY and the JSON files, once from the stage alone
   (MESH, LIGHTS and CAMERA all bunny.usda).
3. Compares the two pictures (the beauty of out/usd/*/bunny.exr).
4. Writes the bake back onto the stage (`filter bunny.usda ... -o
   bake.usda`, a layer of overs) and the cloud as `.usda`, and opens both
   with Pixar's library: the bake's ssM on /World/bunny, one value a
   point, with no validation error.
"""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdValidation

import pcsss

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "out" / "usd"
BIN = ROOT / "target" / "release"
SCALE = 10.0


def obj(path):
    v, f = [], []
    for line in open(path):
        t = line.split()
        if not t:
            continue
        if t[0] == "v":
            v.append([float(x) for x in t[1:4]])
        elif t[0] == "f":
            f.append([int(x.split("/")[0]) - 1 for x in t[1:]])
    return v, f


def orient_to(d):
    """The rotation that takes -Z to the direction d."""
    r = Gf.Rotation(Gf.Vec3d(0, 0, -1), Gf.Vec3d(*d).GetNormalized())
    return Gf.Quatf(r.GetQuat())


def stage(path, lights, camera):
    st = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(st, 0.01)
    world = UsdGeom.Xform.Define(st, "/World")
    world.AddTranslateOp().Set(Gf.Vec3d(30.0, 0.0, -20.0))
    world.AddRotateYOp().Set(30.0)
    world.AddScaleOp().Set(Gf.Vec3f(SCALE, SCALE, SCALE))
    st.SetDefaultPrim(world.GetPrim())
    v, f = obj(ROOT / "fixtures" / "mesh" / "bunny.obj")
    mesh = UsdGeom.Mesh.Define(st, "/World/bunny")
    mesh.CreatePointsAttr([Gf.Vec3f(*p) for p in v])
    mesh.CreateFaceVertexCountsAttr([len(x) for x in f])
    mesh.CreateFaceVertexIndicesAttr([i for x in f for i in x])
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    for light in lights["lights"]:
        assert light["type"] == "distant"
        d = UsdLux.DistantLight.Define(st, "/World/" + light["name"])
        d.AddOrientOp().Set(orient_to(light["direction"]))
        d.CreateIntensityAttr(light["intensity"])
        d.CreateColorAttr(Gf.Vec3f(*light["color"]))
        d.CreateNormalizeAttr(True)
    cam = UsdGeom.Camera.Define(st, "/World/camera")
    look = Gf.Matrix4d().SetLookAt(Gf.Vec3d(*camera["position"]), Gf.Vec3d(*camera["look_at"]),
                                   Gf.Vec3d(*camera["up"]))
    cam.AddTransformOp().Set(look.GetInverse())
    focal = 50.0
    aperture = 2 * focal * math.tan(math.radians(camera["fov"]) / 2)
    cam.CreateFocalLengthAttr(focal)
    cam.CreateHorizontalApertureAttr(aperture)
    cam.CreateVerticalApertureAttr(aperture)
    st.GetRootLayer().Save()


def flat(usd, out):
    """The stage as a PLY mesh and JSON lights and camera in world space."""
    st = Usd.Stage.Open(str(usd))
    time = Usd.TimeCode.Default()
    world = lambda prim: UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(time)
    mesh = UsdGeom.Mesh(st.GetPrimAtPath("/World/bunny"))
    m = world(mesh.GetPrim())
    p = np.array([list(m.Transform(Gf.Vec3d(*q))) for q in mesh.GetPointsAttr().Get()], np.float32)
    counts, idx = mesh.GetFaceVertexCountsAttr().Get(), list(mesh.GetFaceVertexIndicesAttr().Get())
    faces, k = [], 0
    for c in counts:
        faces.append(idx[k:k + c])
        k += c
    pcsss.write(pcsss.Cloud.from_arrays({"P": p}, faces=faces), out / "bunny.ply")
    lights = []
    for prim in st.Traverse():
        if prim.GetTypeName() != "DistantLight":
            continue
        light = UsdLux.DistantLight(prim)
        d = world(prim).TransformDir(Gf.Vec3d(0, 0, -1))
        lights.append({"name": prim.GetName(), "type": "distant", "direction": list(d),
                       "color": list(light.GetColorAttr().Get()),
                       # normalize on: the illuminance is the intensity.
                       "intensity": light.GetIntensityAttr().Get()})
    (out / "lights.json").write_text(json.dumps({"up_axis": "y", "meters_per_unit": 0.01, "lights": lights}))
    cam = UsdGeom.Camera(st.GetPrimAtPath("/World/camera"))
    c = world(cam.GetPrim())
    eye = c.Transform(Gf.Vec3d(0, 0, 0))
    ahead = c.TransformDir(Gf.Vec3d(0, 0, -1)).GetNormalized()
    up = c.TransformDir(Gf.Vec3d(0, 1, 0))
    gf = cam.GetCamera(time)
    fov = 2 * math.degrees(math.atan(gf.verticalAperture / (2 * gf.focalLength)))
    (out / "camera.json").write_text(json.dumps({
        "up_axis": "y", "meters_per_unit": 0.01, "position": list(eye), "look_at": list(eye + ahead),
        "up": list(up), "fov": fov, "width": 512, "height": 512}))


def bake(out, **kw):
    args = ["make", "-s", "-C", str(ROOT / "pipelines"), f"OUT={out}"] + [f"{k}={v}" for k, v in kw.items()]
    subprocess.run(args, check=True)


def validate(st):
    ctx = UsdValidation.ValidationContext(UsdValidation.ValidationRegistry().GetOrLoadAllValidators())
    return [str(e.GetMessage()) for e in ctx.Validate(st) if e.GetType() == UsdValidation.ValidationErrorType.Error]


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    lights = json.load(open(ROOT / "fixtures" / "lights" / "bunny.json"))
    camera = json.load(open(ROOT / "fixtures" / "cameras" / "bunny.json"))
    usd = OUT / "bunny.usda"
    stage(usd, lights, camera)
    flat(usd, OUT)
    common = dict(SD=0.6 * SCALE, MFP=0.1 * SCALE)
    bake(OUT / "ply", MESH=OUT / "bunny.ply", LIGHTS=OUT / "lights.json", CAMERA=OUT / "camera.json",
         UP_AXIS="y", METERS_PER_UNIT=0.01, **common)
    bake(OUT / "usd", MESH=usd, LIGHTS=usd, CAMERA=usd, **common)
    a = pcsss.read(OUT / "ply" / "bunny.exr")
    b = pcsss.read(OUT / "usd" / "bunny.exr")
    ba, bb = a["beauty"], b["beauty"]
    cov = (a["A"] > 0.99) & (b["A"] > 0.99)
    diff = np.abs(ba - bb)[cov]
    res = {
        "same_bits": bool(np.array_equal(ba, bb) and np.array_equal(a["A"], b["A"])),
        "pixels": int(cov.sum()),
        "coverage_differs": int(((a["A"] > 0.5) != (b["A"] > 0.5)).sum()),
        "max_abs_over_max": float(diff.max() / ba[cov].max()),
        "mean_abs_over_mean": float(diff.mean() / ba[cov].mean()),
    }
    # The bake back onto the stage, and the cloud as USD.
    subprocess.run([str(BIN / "filter"), str(usd), "--cloud", str(OUT / "usd" / "bunny_sss.ply"), "-q",
                    "-o", str(OUT / "bake.usda")], check=True)
    subprocess.run([str(BIN / "pcconvert"), str(OUT / "usd" / "bunny_sss.ply"), "-o", str(OUT / "cloud.usda")],
                   check=True)
    root = Sdf.Layer.CreateNew(str(OUT / "shot.usda"))
    root.subLayerPaths.append("bake.usda")
    root.subLayerPaths.append("bunny.usda")
    root.Save()
    st = Usd.Stage.Open(str(OUT / "shot.usda"))
    st.SetDefaultPrim(st.GetPrimAtPath("/World"))
    UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(st, 0.01)
    prim = st.GetPrimAtPath("/World/bunny")
    ssm = UsdGeom.PrimvarsAPI(prim).GetPrimvar("ssM")
    res["over_ssM_values"] = len(ssm.Get())
    res["over_points"] = len(UsdGeom.Mesh(prim).GetPointsAttr().Get())
    res["over_interpolation"] = ssm.GetInterpolation()
    res["over_errors"] = validate(st)
    cloud = Usd.Stage.Open(str(OUT / "cloud.usda"))
    res["cloud_points"] = len(UsdGeom.Points(cloud.GetDefaultPrim()).GetPointsAttr().Get())
    res["cloud_errors"] = validate(cloud)
    print(json.dumps(res, indent=1))
    ok = (res["same_bits"] and res["over_ssM_values"] == res["over_points"]
          and not res["over_errors"] and not res["cloud_errors"])
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
