"""Embree (through embreex) on the same rays as a Rust benchmark.

Usage: embree_rays.py TRIS RAYS QUERY
TRIS: float32 triangles (n x 3 x 3), RAYS: float32 rays (m x 7: origin,
direction, tmax; inf for none), both in the BVH's unit frame, written by
the Rust benchmark (benches/illum.rs: shadow rays, QUERY occluded;
benches/sssingle.rs: nearest hits, QUERY intersect). Prints one JSON line:
build seconds; the rays blocked (occluded) or that hit, with the sum of
their hit distances (intersect); trace seconds on 1 and 2 processes (each
process traces half the rays on its own copy of the scene: embreex traces
on one thread per call); the same in Embree's robust mode (its watertight
triangle test, as the project's), `_robust`.
"""
import json
import multiprocessing as mp
import sys
import time

import numpy as np
from embreex import rtcore_scene
from embreex.mesh_construction import TriangleMesh


def load(tris_path, robust=False):
    tris = np.fromfile(tris_path, dtype=np.float32).reshape(-1, 3, 3)
    t = time.perf_counter()
    scene = rtcore_scene.EmbreeScene(robust=robust)
    TriangleMesh(scene, tris)
    # Commit happens on the first run: force it with one ray.
    scene.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32), query="OCCLUDED")
    return scene, time.perf_counter() - t


def trace(args):
    tris_path, rays, query, robust = args
    scene, _ = load(tris_path, robust)
    o = np.ascontiguousarray(rays[:, 0:3])
    d = np.ascontiguousarray(rays[:, 3:6])
    tmax = np.where(np.isinf(rays[:, 6]), np.float32(1e30), rays[:, 6]).astype(np.float32)
    t = time.perf_counter()
    if query == "occluded":
        hit = np.asarray(scene.run(o, d, dists=tmax, query="OCCLUDED")) != -1
        dt = time.perf_counter() - t
        return dt, int(hit.sum()), 0.0
    res = scene.run(o, d, dists=tmax, query="INTERSECT", output=1)
    dt = time.perf_counter() - t
    hit = np.asarray(res["primID"]) != -1
    tfar = np.asarray(res["tfar"])
    return dt, int(hit.sum()), float(tfar[hit].astype(np.float64).sum())


def main():
    tris_path, rays_path, query = sys.argv[1], sys.argv[2], sys.argv[3]
    rays = np.fromfile(rays_path, dtype=np.float32).reshape(-1, 7)
    _, build = load(tris_path)
    out = {"rays": len(rays), "build": build}
    for robust in (False, True):
        one, hits, dist = trace((tris_path, rays, query, robust))
        halves = np.array_split(rays, 2)
        with mp.get_context("fork").Pool(2) as pool:
            res = pool.map(trace, [(tris_path, h, query, robust) for h in halves])
        two = max(r[0] for r in res)
        tag = "_robust" if robust else ""
        out.update({f"hits{tag}": hits, f"blocked{tag}": hits, f"dist{tag}": dist, f"seconds_1{tag}": one,
                    f"seconds_2{tag}": two})
    print(json.dumps(out))


if __name__ == "__main__":
    main()
