"""The path-traced truth for the physical model on a flat slab: Mitsuba 3's
volpath, a homogeneous medium of single-scattering albedo ALPHA and mean
free path 1 in a box 400 x 400 x 200 mean free paths, a directional light
of irradiance 1 straight down, and an invisible irradiance meter (a
300 x 300 square just above the surface, facing it) that measures the
exitance: the slab's total diffuse reflectance at normal incidence.

Beside it, the physical model's own value of that reflectance, `R_m +
R_s`, as `ssmulti --model physical` records it (`ssmulti_colour`) on a
one-point cloud (the release binaries, `cargo build --release`).

Only an index-matched boundary (eta 1, a null BSDF) for now: through a
smooth dielectric a delta light cannot be reached by next-event estimation.

    python mitsuba_slab.py ETA G SPP ALPHA[,ALPHA...]
"""
import pathlib
import subprocess
import sys
import tempfile
import time

import mitsuba as mi

mi.set_variant("scalar_rgb")


def reflectance(alpha, eta, g, spp):
    if eta != 1.0:
        raise SystemExit("only eta 1 (an index-matched boundary) for now")
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": -1, "rr_depth": 100000},
        "light": {"type": "directional", "direction": [0, 0, -1],
                  "irradiance": {"type": "rgb", "value": 1.0}},
        "slab": {
            "type": "cube",
            "to_world": mi.ScalarTransform4f().translate([0, 0, -100]).scale([200, 200, 100]),
            "bsdf": {"type": "null"},
            "interior": {"type": "homogeneous", "albedo": {"type": "rgb", "value": alpha},
                         "sigma_t": 1.0, "phase": {"type": "hg", "g": g}},
        },
        "meter": {
            "type": "rectangle",
            "to_world": mi.ScalarTransform4f().translate([0, 0, 0.5]).scale(150).rotate([1, 0, 0], 180),
            "bsdf": {"type": "null"},
            "sensor": {"type": "irradiancemeter",
                       "film": {"type": "hdrfilm", "width": 1, "height": 1,
                                "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                       "sampler": {"type": "independent", "sample_count": spp}},
        },
    })
    img = mi.render(scene, spp=spp)
    return float(mi.TensorXf(img).numpy().ravel()[0])


BIN = pathlib.Path(__file__).resolve().parents[2] / "target" / "release"


def model(alpha, eta, g):
    """The model's slab reflectance, as ssmulti records it."""
    with tempfile.TemporaryDirectory() as d:
        cloud = pathlib.Path(d) / "one.ply"
        cloud.write_text(
            "ply\nformat ascii 1.0\nelement vertex 1\n"
            + "".join(f"property float {n}\n" for n in
                      ["x", "y", "z", "nx", "ny", "nz", "ptarea", "illum_r", "illum_g", "illum_b"])
            + "end_header\n0 0 0 0 0 1 1 1 1 1\n")
        out = pathlib.Path(d) / "out.ply"
        subprocess.run([BIN / "ssmulti", "-q", cloud, "--model", "physical", "--albedo", str(alpha),
                        "--mfp", "1", "--eta", str(eta), "--g", str(g), "-o", out], check=True)
        info = subprocess.run([BIN / "pcinfo", out], check=True, capture_output=True, text=True).stdout
        line = next(x for x in info.splitlines() if "ssmulti_colour" in x)
        return float(line.split("(")[1].split(",")[0])


if __name__ == "__main__":
    eta, g, spp = float(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3])
    for a in [float(x) for x in sys.argv[4].split(",")]:
        t = time.time()
        r = reflectance(a, eta, g, spp)
        m = model(a, eta, g)
        print(f"alpha {a} eta {eta} g {g}: Mitsuba {r:.5f} ({time.time() - t:.1f} s), "
              f"model {m:.5f}, model / Mitsuba {m / r:.2f}", flush=True)
