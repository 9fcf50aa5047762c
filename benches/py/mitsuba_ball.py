"""The lit pole of a ball against Mitsuba 3 and against a half-space:
where the walk method's light taken from the cloud goes wrong, and the
walks that sample the lights do not (docs/DESIGN.md, "The light a walk
takes").

A ball of radius 1 (Mitsuba's exact sphere; the bake's 256 x 128
latitude-longitude mesh of mitsuba_sphere.py) of a medium of albedo
ALBEDO, mean free path MFP, g 0, eta 1:

1. Under a constant dome of radiance 1, Mitsuba's radiance at the pole
   along its normal, beside a half-space's, Chandrasekhar's
   `1 - H(1) sqrt(1 - alpha)`.
2. Under a sun of irradiance 1 along the pole's normal, Mitsuba's
   multiple-scattering exitance at the pole (its radiance at six view
   angles, all orders minus single scattering, Gauss-Legendre in the
   cosine), beside a half-space's `rm(1)` (Chandrasekhar's `H`, less
   single scattering), and the bake's `ssM` over `illum` at the points
   within 0.1 of the pole (`make MODEL=physical METHOD=walk EXIT=sky`,
   COUNT points, WALKS walks), the light taken from the cloud
   (`SAMPLE_LIGHTS=0`) and sampled. (The pole faces +z: the mesh's
   regular equator.)

    python mitsuba_ball.py [SPP] [COUNT] [WALKS]
"""
import json
import os
import pathlib
import subprocess
import sys
import tempfile

import mitsuba as mi
import numpy as np
import plyfile

from mitsuba_sphere import sphere_obj
from mitsuba_images import RR_DEPTH

mi.set_variant("scalar_rgb")
ROOT = pathlib.Path(__file__).resolve().parents[2]
BIN = os.environ.get("BIN", str(ROOT / "target" / "release"))
ALBEDO, MFP = 0.95, 0.05


def render(emitter, eye, target, spp, max_depth=-1):
    """Mitsuba's mean radiance over a patch about 0.3 mean free paths
    wide at `target`, seen from `eye`."""
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": max_depth, "rr_depth": RR_DEPTH},
        "light": emitter,
        "ball": {
            "type": "sphere", "radius": 1.0, "bsdf": {"type": "null"},
            "interior": {"type": "homogeneous", "albedo": {"type": "rgb", "value": ALBEDO},
                         "sigma_t": 1.0 / MFP, "phase": {"type": "hg", "g": 0.0}},
        },
        "camera": {"type": "perspective", "fov": 0.2,
                   "to_world": mi.ScalarTransform4f().look_at(origin=eye, target=target, up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 4, "height": 4, "pixel_format": "rgb",
                            "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": spp}},
    })
    return float(np.array(mi.render(scene, spp=spp))[:, :, :3].mean())


def chandrasekhar_h(alpha):
    """H(mu) of isotropic scattering at `alpha`, by iteration on a
    Gauss-Legendre grid."""
    x, w = np.polynomial.legendre.leggauss(200)
    mu, w = (x + 1) / 2, w / 2
    h = np.ones_like(mu)
    for _ in range(3000):
        h = 1 / (1 - mu * np.array([np.sum(w * alpha / 2 * h / (m + mu)) for m in mu]))
    return lambda m: 1 / (1 - m * np.sum(w * alpha / 2 * h / (m + mu)))


def bake(count, walks, sample):
    """The bake's `ssM / illum` at the points within 0.1 of the pole."""
    with tempfile.TemporaryDirectory() as dd:
        d = pathlib.Path(dd)
        sphere_obj(d / "ball.obj")
        (d / "sun.json").write_text(json.dumps({"lights": [
            {"name": "sun", "type": "distant", "intensity": 1.0, "direction": [0, 0, -1]}]}))
        (d / "cam.json").write_text(json.dumps({"position": [0, 0, 4], "look_at": [0, 0, 0],
                                                "up": [0, 1, 0], "fov": 20, "width": 16, "height": 16}))
        subprocess.run(["make", "-s", "-C", ROOT / "pipelines", f"BIN={BIN}", f"MESH={d / 'ball.obj'}",
                        f"LIGHTS={d / 'sun.json'}", f"CAMERA={d / 'cam.json'}", f"OUT={d / 'out'}",
                        f"COUNT={count}", "MODEL=physical", f"ALBEDO={ALBEDO}", f"MFP={MFP}", "ETA=1", "G=0",
                        "METHOD=walk", f"WALKS={walks}", "EXIT=sky", f"SAMPLE_LIGHTS={int(sample)}",
                        f"{d / 'out' / 'ball_ss.ply'}"], check=True, stdout=subprocess.DEVNULL)
        v = plyfile.PlyData.read(str(d / "out" / "ball_ss.ply"))["vertex"].data
        col = {n: np.asarray(v[n], float) for n in ("x", "y", "z", "ssM_r", "illum_r")}
        pole = (col["z"] > 0) & (np.hypot(col["x"], col["y"]) < 0.1)
        return float(np.mean(col["ssM_r"][pole] / col["illum_r"][pole])), int(pole.sum())


def main():
    spp = int(sys.argv[1]) if len(sys.argv) > 1 else 2048
    count = int(sys.argv[2]) if len(sys.argv) > 2 else 100000
    walks = int(sys.argv[3]) if len(sys.argv) > 3 else 256
    h = chandrasekhar_h(ALBEDO)
    dome = {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}}
    ball = render(dome, [0, 0, 4], [0, 0, 0], spp)
    half = 1 - h(1.0) * np.sqrt(1 - ALBEDO)
    print(f"dome, radiance along the pole's normal: ball {ball:.4f}, half-space {half:.4f}, "
          f"ratio {ball / half:.4f}", flush=True)
    sun = {"type": "directional", "direction": [0, 0, -1], "irradiance": {"type": "rgb", "value": 1.0}}
    x, w = np.polynomial.legendre.leggauss(6)
    mus, w = (x + 1) / 2, w / 2
    radiance = []
    for m in mus:
        s = np.sqrt(1 - m * m)
        eye = [4 * s, 0, 1 + 4 * m]
        radiance.append(render(sun, eye, [0, 0, 1], spp) - render(sun, eye, [0, 0, 1], spp, max_depth=2))
    exitance = 2 * np.pi * float(np.sum(w * np.array(radiance) * mus))
    # The half-space: all orders' albedo at mu 1 less single scattering's.
    rm1 = (1 - h(1.0) * np.sqrt(1 - ALBEDO)) - ALBEDO / 2 * (1 - np.log(2))
    print(f"sun, multiple scattering's exitance at the pole over the irradiance: Mitsuba {exitance:.4f}, "
          f"half-space rm(1) {rm1:.4f}", flush=True)
    for sample in (False, True):
        v, n = bake(count, walks, sample)
        how = "lights sampled" if sample else "light from the cloud"
        print(f"  bake, {how}: {v:.4f} ({n} points; {v / exitance - 1:+.3f} of Mitsuba's)", flush=True)


if __name__ == "__main__":
    main()
