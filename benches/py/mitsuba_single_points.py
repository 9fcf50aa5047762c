"""sssingle's single scattering at single points against Mitsuba 3's,
with shadows on and off: the check behind issue 61 (shadow rays that
darkened points nothing shadows, and shadows of the medium).

Each case is a closed mesh filled with the medium (eta 1, so a point
light is reachable through Mitsuba's null boundary), COUNT points on it
with their smooth normals, an eye and a point light. The bake's figure is
`sssingle --model physical` at each point (SAMPLES depth samples), with
its default shadow rays and with `--no-shadows`. Mitsuba's is `volpath`
with `max_depth` 2 (one scattering event: single scattering alone) and no
Russian roulette, from a ray that starts just inside the point along the
view direction with the interior medium as its medium, averaged over SPP
rays a point; one grey pass per distinct mean free path.

Cases:
- `sphere`: an icosphere (trimesh, 5 subdivisions, 20,480 faces), a point
  light; g 0.8 and -0.3. Nothing shadows anything.
- `torus`: a thin torus (R 1, r 0.2), the point light behind it; g 0.4
  and -0.3. The torus's far side lies in the way of some light: Mitsuba
  carries it through that medium.
- `ball`: the torus with a ball of the same medium (radius 0.25) between
  it and the light; mean free paths 0.1, 0.2, 0.4 per channel. The
  figure is the shadowed points' light with the ball against without,
  per channel.

    python mitsuba_single_points.py [SPP] [COUNT] [CASES]
    PCSSS_BIN=/other/target/release PCSSS_LABEL=before python mitsuba_single_points.py ...

Prints, per case, each bake against Mitsuba: the ratio of their sums
less 1 per channel, and the RMS of the per-point relative error over the
points Mitsuba sees lit (every channel above a tenth of its mean), beside
the RMS noise expected from both tools (the bake's from two seeds,
Mitsuba's standard error); writes benches/results/mitsuba_single_points.json
(keyed by case and the stages' folder). Mitsuba runs vectorised
(llvm_ad_rgb, Debian's LLVM 19: `make llvm`).
"""
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
if os.path.exists(LLVM):
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402
import numpy as np  # noqa: E402
import trimesh  # noqa: E402
from plyfile import PlyData, PlyElement  # noqa: E402

mi.set_variant("llvm_ad_rgb")
ROOT = pathlib.Path(__file__).resolve().parents[2]
# The stages measured: this checkout's, or another build's (PCSSS_BIN,
# its rows named by PCSSS_LABEL).
BIN = pathlib.Path(os.environ.get("PCSSS_BIN", ROOT / "target" / "release"))
LABEL = os.environ.get("PCSSS_LABEL", "after" if "PCSSS_BIN" not in os.environ else str(BIN))
RESULTS = ROOT / "benches" / "results" / "mitsuba_single_points.json"
SAMPLES = 256


def torus(R=1.0, r=0.2, nu=192, nv=48):
    """A torus about Z, wound outwards."""
    u = np.linspace(0, 2 * np.pi, nu, endpoint=False)
    v = np.linspace(0, 2 * np.pi, nv, endpoint=False)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    x = (R + r * np.cos(vv)) * np.cos(uu)
    y = (R + r * np.cos(vv)) * np.sin(uu)
    z = r * np.sin(vv)
    verts = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    idx = lambda i, j: (i % nu) * nv + (j % nv)
    faces = []
    for i in range(nu):
        for j in range(nv):
            a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
            faces += [[a, b, c], [a, c, d]]
    m = trimesh.Trimesh(verts, np.array(faces), process=False)
    if m.volume < 0:
        m.invert()
    return m


def cases():
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=1.0)
    t = torus()
    ball = trimesh.creation.icosphere(subdivisions=4, radius=0.25)
    ball.apply_translation([0.0, 1.0, 0.8])
    with_ball = trimesh.util.concatenate([t, ball])
    behind = [0.3, 1.0, 2.2]
    return {
        "sphere g 0.8": dict(mesh=sphere, points=sphere, light=[2.5, -1.0, 2.0], eye=[0.0, -4.0, 1.0],
                             g=0.8, mfp=[0.2] * 3, albedo=0.9),
        "sphere g -0.3": dict(mesh=sphere, points=sphere, light=[2.5, -1.0, 2.0], eye=[0.0, -4.0, 1.0],
                              g=-0.3, mfp=[0.2] * 3, albedo=0.9),
        "torus g 0.4": dict(mesh=t, points=t, light=behind, eye=[0.2, -0.5, -3.0],
                            g=0.4, mfp=[0.2] * 3, albedo=0.9),
        "torus g -0.3": dict(mesh=t, points=t, light=behind, eye=[0.2, -0.5, -3.0],
                             g=-0.3, mfp=[0.2] * 3, albedo=0.9),
        "ball": dict(mesh=with_ball, points=t, light=behind, eye=[0.2, -0.5, -3.0],
                     g=0.4, mfp=[0.1, 0.2, 0.4], albedo=0.9, ball=True),
    }


def vertex_normals(mesh):
    """Area-weighted vertex normals (without trimesh's scipy path)."""
    fn = np.cross(mesh.triangles[:, 1] - mesh.triangles[:, 0], mesh.triangles[:, 2] - mesh.triangles[:, 0])
    vn = np.zeros((len(mesh.vertices), 3))
    for k in range(3):
        np.add.at(vn, mesh.faces[:, k], fn)
    return vn / np.linalg.norm(vn, axis=1, keepdims=True)


def sample_points(mesh, count, eye, seed=7):
    """COUNT points on `mesh` the eye sees (by their normal), with the
    mesh's smooth normals there."""
    rng = np.random.default_rng(seed)
    pts, nrm = [], []
    while len(pts) < count:
        p, f = trimesh.sample.sample_surface(mesh, 4 * count, seed=int(rng.integers(1 << 30)))
        bary = trimesh.triangles.points_to_barycentric(mesh.triangles[f], p)
        n = (vertex_normals(mesh)[mesh.faces[f]] * bary[:, :, None]).sum(axis=1)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        seen = ((np.asarray(eye) - p) * n).sum(axis=1) > 0.05 * np.linalg.norm(np.asarray(eye) - p, axis=1)
        pts += list(p[seen])
        nrm += list(n[seen])
    return np.array(pts[:count]), np.array(nrm[:count])


def write_cloud(path, p, n):
    v = np.zeros(len(p), dtype=[(k, "f8") for k in ["x", "y", "z", "nx", "ny", "nz"]])
    for k, c in zip(["x", "y", "z"], p.T):
        v[k] = c
    for k, c in zip(["nx", "ny", "nz"], n.T):
        v[k] = c
    PlyData([PlyElement.describe(v, "vertex")], text=False).write(str(path))


def bake(case, d, p, n, shadows, seed=0):
    write_cloud(d / "pts.ply", p, n)
    case["mesh"].export(d / "mesh.ply")
    (d / "lights.json").write_text(json.dumps({"lights": [
        {"name": "key", "type": "point", "position": case["light"], "intensity": 1.0}]}))
    mfp = ",".join(str(x) for x in case["mfp"])
    cmd = [BIN / "sssingle", d / "pts.ply", "--mesh", d / "mesh.ply", "--lights", d / "lights.json",
           "--eye", ",".join(str(x) for x in case["eye"]), "--model", "physical",
           "--albedo", str(case["albedo"]), "--mfp", mfp, "--g", str(case["g"]), "--eta", "1",
           "--samples", str(SAMPLES), "--seed", str(seed), "-o", d / "out.ply", "-q"]
    if not shadows:
        cmd.append("--no-shadows")
    t = time.time()
    subprocess.run(cmd, check=True)
    took = time.time() - t
    out = PlyData.read(str(d / "out.ply"))["vertex"]
    return np.stack([out[f"ssS_{c}"] for c in "rgb"], axis=1).astype(float), took


def mitsuba(case, d, p, spp, mfp):
    """Mitsuba's single scattering at each point for one grey mean free
    path: the mean over `spp` rays and their standard error."""
    case["mesh"].export(d / "mi.ply")
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": 2, "rr_depth": 100000, "hide_emitters": True},
        "light": {"type": "point", "position": case["light"], "intensity": {"type": "rgb", "value": 1.0}},
        "body": {"type": "ply", "filename": str(d / "mi.ply"), "face_normals": True,
                 "bsdf": {"type": "null"},
                 "interior": {"type": "homogeneous", "albedo": {"type": "rgb", "value": case["albedo"]},
                              "sigma_t": 1.0 / mfp, "phase": {"type": "hg", "g": case["g"]}}},
    })
    integrator = scene.integrator()
    medium = scene.shapes()[0].interior_medium()
    eye = np.asarray(case["eye"], dtype=float)
    dirs = p - eye
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    origins = p + dirs * 1e-6
    # Rays in batches of about a million: point i's rays are rows i of
    # a (points, spp) block.
    per = max(1, (1 << 20) // len(p))
    total, total2, done = np.zeros(len(p)), np.zeros(len(p)), 0
    batch = 0
    while done < spp:
        k = min(per, spp - done)
        o = np.repeat(origins, k, axis=0)
        d = np.repeat(dirs, k, axis=0)
        sampler = mi.load_dict({"type": "independent"})
        sampler.seed(7919 * batch + int(1000 * mfp), len(o))
        ray = mi.RayDifferential3f(mi.Point3f(*[mi.Float(o[:, j]) for j in range(3)]),
                       mi.Vector3f(*[mi.Float(d[:, j]) for j in range(3)]))
        spec, _, _ = integrator.sample(scene, sampler, ray, medium, mi.Bool(True))
        v = np.array(spec[0]).reshape(len(p), k)
        total += v.sum(axis=1)
        total2 += (v * v).sum(axis=1)
        done += k
        batch += 1
    mean = total / spp
    var = np.maximum(total2 / spp - mean * mean, 0.0)
    return mean, np.sqrt(var / spp)


def compare(v, mi_v, keep):
    """The bake `v` against Mitsuba's `mi_v` over the points `keep`: the
    mean of the ratio of sums less 1 (per channel), and the RMS of the
    per-point relative error."""
    rel = (v[keep] - mi_v[keep]) / mi_v[keep]
    return {"mean": [round(float(x), 4) for x in v[keep].sum(axis=0) / mi_v[keep].sum(axis=0) - 1],
            "per_point_rms": round(float(np.sqrt((rel ** 2).mean())), 4)}


def run(name, case, spp, count):
    with tempfile.TemporaryDirectory() as dd:
        d = pathlib.Path(dd)
        p, n = sample_points(case["points"], count, case["eye"])
        on, t_on = bake(case, d, p, n, True)
        on2, _ = bake(case, d, p, n, True, seed=1)
        off, t_off = bake(case, d, p, n, False)
        mfps = sorted(set(case["mfp"]))
        t = time.time()
        ref = {m: mitsuba(case, d, p, spp, m) for m in mfps}
        t_mi = time.time() - t
        mi_v = np.stack([ref[m][0] for m in case["mfp"]], axis=1)
        mi_e = np.stack([ref[m][1] for m in case["mfp"]], axis=1)
        # Per-point errors over the points Mitsuba sees lit (a tenth of
        # the mean and more, every channel): a relative error of a point
        # near black is all noise.
        keep = (mi_v > 0.1 * mi_v.mean(axis=0)).all(axis=1)
        bake_noise = np.abs(on - on2) / np.sqrt(2)
        noise = np.sqrt(((bake_noise[keep] ** 2 + mi_e[keep] ** 2) / mi_v[keep] ** 2).mean())
        row = {"points": count, "compared": int(keep.sum()), "spp": spp, "samples": SAMPLES,
               "wall_seconds": {"shadows": round(t_on, 2), "no_shadows": round(t_off, 2),
                               "mitsuba": round(t_mi, 1)},
               "shadows": compare(on, mi_v, keep), "no_shadows": compare(off, mi_v, keep),
               "expected_noise_rms": round(float(noise), 4),
               "shadows_changed_points": int((np.abs(on - off).max(axis=1) > 0).sum())}
        if case.get("ball"):
            # The points the ball shadows: where Mitsuba's light falls by
            # a fifth or more against the same scene without the ball.
            free = dict(case, mesh=case["points"])
            ref0 = {m: mitsuba(free, d, p, spp, m) for m in mfps}
            mi0 = np.stack([ref0[m][0] for m in case["mfp"]], axis=1)
            bare, _ = bake(free, d, p, n, True)
            drop = 1 - mi_v.sum(axis=1) / np.maximum(mi0.sum(axis=1), 1e-30)
            sh = drop > 0.2
            row["ball"] = {
                "shadowed_points": int(sh.sum()),
                "mitsuba_change": [round(float(x), 4) for x in mi_v[sh].sum(axis=0) / mi0[sh].sum(axis=0) - 1],
                "sssingle_change": [round(float(x), 4) for x in on[sh].sum(axis=0) / bare[sh].sum(axis=0) - 1],
                "shadowed_points_against_mitsuba": compare(on, mi_v, sh & keep),
            }
        return row


if __name__ == "__main__":
    spp = int(sys.argv[1]) if len(sys.argv) > 1 else 256
    count = int(sys.argv[2]) if len(sys.argv) > 2 else 400
    all_cases = cases()
    names = sys.argv[3].split(",") if len(sys.argv) > 3 else list(all_cases)
    results = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
    for name in names:
        row = run(name, all_cases[name], spp, count)
        results[f"{name} ({LABEL})"] = row
        print(name, json.dumps(row), flush=True)
    RESULTS.write_text(json.dumps(results, indent=1) + "\n")
