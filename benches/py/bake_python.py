"""The bunny bake in plain Python, for benches/bake.rs: trimesh (mesh,
sampling, barycentrics), embreex (shadow and camera rays), numpy + scipy
cKDTree (the ssmulti sum, the filter). The same stages and parameters as
the Rust run: scatter with per-face areas (ptarea prim), smooth normals,
distant lights with shadows, ssmulti (smooth, seed normalisation, t_rgb)
on a random subset of receivers (its time scaled to every point, and
said so), and the render: one ray a pixel, pcfilter over the cloud points
within the radius, using the Rust run's ssM (so that the two images can be
compared pixel by pixel).

Usage: bake_python.py MESH LIGHTS CAMERA N SD RD_R RD_G RD_B RADIUS SUBSET DIR
DIR holds cloud_P.npy and cloud_ssM.npy (the Rust cloud) and receives
image.npy (H x W x 3, the Python render). Prints one JSON line with
seconds per stage.
"""
import json
import sys
import time

import numpy as np
import trimesh
from embreex import rtcore_scene
from embreex.mesh_construction import TriangleMesh
from scipy.spatial import cKDTree


def smoothstep(e, x):
    t = np.clip(x / e, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def main():
    (mesh_path, lights_path, camera_path, n, sd, rr, rg, rb, radius, subset, out) = sys.argv[1:12]
    n, sd, radius, subset = int(n), float(sd), float(radius), int(subset)
    rd = np.array([float(rr), float(rg), float(rb)])
    times = {}

    t = time.perf_counter()
    mesh = trimesh.load(mesh_path, process=False, force="mesh")
    tarea = mesh.area_faces.sum()
    times["measure + promote"] = time.perf_counter() - t

    t = time.perf_counter()
    p, face = trimesh.sample.sample_surface(mesh, n, seed=0)
    counts = np.bincount(face, minlength=len(mesh.faces))
    ptarea = mesh.area_faces[face] / counts[face]
    times["scatter"] = time.perf_counter() - t

    t = time.perf_counter()
    bary = trimesh.triangles.points_to_barycentric(mesh.triangles[face], p)
    vn = mesh.vertex_normals[mesh.faces[face]]
    nrm = (vn * bary[:, :, None]).sum(axis=1)
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    times["facet"] = time.perf_counter() - t

    t = time.perf_counter()
    ptarea *= tarea / ptarea.sum()
    times["promote --normalize"] = time.perf_counter() - t

    t = time.perf_counter()
    scene = rtcore_scene.EmbreeScene(robust=False)
    TriangleMesh(scene, mesh.triangles.astype(np.float32))
    lights = json.load(open(lights_path))["lights"]
    illum = np.zeros((n, 3))
    eps = 1e-4 * np.abs(mesh.bounds).max()
    for light in lights:
        assert light["type"] == "distant"
        to_light = -np.asarray(light["direction"], dtype=float)
        to_light /= np.linalg.norm(to_light)
        cos = nrm @ to_light
        lit = np.nonzero(cos > 0)[0]
        o = (p[lit] + eps * nrm[lit]).astype(np.float32)
        d = np.repeat(to_light[None, :], len(lit), axis=0).astype(np.float32)
        blocked = np.asarray(scene.run(o, d, query="OCCLUDED")) != -1
        cl = np.asarray(light.get("color", [1, 1, 1])) * light.get("intensity", 1.0)
        vis = lit[~blocked]
        illum[vis] += cos[vis][:, None] * cl[None, :]
    times["illum"] = time.perf_counter() - t

    t = time.perf_counter()
    rng = np.random.default_rng(0)
    recv = np.sort(rng.choice(n, size=min(subset, n), replace=False))
    src = np.nonzero(illum.any(axis=1))[0]
    tree_s = cKDTree(p[src])
    tree_r = cKDTree(p[recv])
    ld = sd * rd
    ld1 = ld.max()
    m = tree_r.sparse_distance_matrix(tree_s, ld1, output_type="ndarray")
    q = illum[src] * ptarea[src][:, None]
    ssm = np.zeros((len(recv), 3))
    for c in range(3):
        if ld[c] <= 0:
            continue
        w = np.where(m["v"] <= ld[c], 1.0 - smoothstep(ld[c], m["v"]), 0.0)
        ssm[:, c] = np.bincount(m["i"], weights=w * q[m["j"], c], minlength=len(recv))
    ssm /= 3.0 * np.pi * ld1 * ld1 / 10.0
    dt = time.perf_counter() - t
    times["ssmulti (scaled from %d receivers)" % len(recv)] = dt * n / len(recv)

    # The render, filtering the Rust cloud's ssM.
    cp = np.load(f"{out}/cloud_P.npy")
    cssm = np.load(f"{out}/cloud_ssM.npy")
    cam = json.load(open(camera_path))
    t = time.perf_counter()
    w, h = cam.get("width", 512), cam.get("height", 512)
    eye = np.asarray(cam["position"], dtype=float)
    f = np.asarray(cam["look_at"], dtype=float) - eye
    f /= np.linalg.norm(f)
    r = np.cross(f, np.asarray(cam.get("up", [0, 1, 0]), dtype=float))
    r /= np.linalg.norm(r)
    u_ = np.cross(r, f)
    th = np.tan(np.radians(cam.get("fov", 40.0)) / 2)
    ys, xs = np.mgrid[0:h, 0:w]
    u = (2 * (xs + 0.5) / w - 1) * th * w / h
    v = (1 - 2 * (ys + 0.5) / h) * th
    d = f[None, None, :] + u[..., None] * r + v[..., None] * u_
    d /= np.linalg.norm(d, axis=2)[..., None]
    d = d.reshape(-1, 3).astype(np.float32)
    o = np.repeat(eye[None, :], len(d), axis=0).astype(np.float32)
    res = scene.run(o, d, output=1)
    prim = np.asarray(res["primID"])
    hit = np.nonzero(prim != -1)[0]
    hp = o[hit] + d[hit] * np.asarray(res["tfar"])[hit][:, None]
    tree_c = cKDTree(cp)
    nbs = tree_c.query_ball_point(hp, radius)
    img = np.zeros((h * w, 3))
    for j, (k, nb) in enumerate(zip(hit, nbs)):
        if not nb:
            continue
        dist = np.linalg.norm(cp[nb] - hp[j], axis=1)
        wts = 1.0 - smoothstep(1.1 * dist.max(), dist) if dist.max() > 0 else np.ones(len(nb))
        img[k] = (wts[:, None] * cssm[nb]).sum(axis=0) / wts.sum()
    times["render (rays + filter)"] = time.perf_counter() - t
    np.save(f"{out}/image.npy", img.reshape(h, w, 3))
    print(json.dumps(times))


if __name__ == "__main__":
    main()
