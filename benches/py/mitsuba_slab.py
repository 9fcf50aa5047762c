"""The path-traced truth for the physical model on a flat slab: Mitsuba 3's
volpath, a homogeneous medium of single-scattering albedo ALPHA and mean
free path 1 filling a box 2000 x 2000 x 1000 mean free paths (a
semi-infinite slab to the light that comes back), under a smooth
dielectric of relative index ETA (a null boundary at 1).

The model's figure is the slab's total diffuse reflectance for light
arriving along the normal. By reciprocity that is the radiance leaving
along the normal under a uniform sky of radiance 1, which is what is
measured here: a radiance meter looking straight down, the sky a constant
emitter (reached through the dielectric by the path's own refraction, as
no light sampling can). The mirror reflection of the sky at the top
surface, `F(0)`, is not diffuse and is taken off. Single scattering alone
is the same with the path cut after one event in the medium
(`max_depth`: the sensor's ray, the boundary crossings and the event each
count one), and the multiple-scattering part is the rest.

Beside it, the physical model's own values, `R_m + R_s` and `R_m`, as
`ssmulti --model physical` records them (`ssmulti_colour`,
`ssmulti_reflectance`) on a one-point cloud (the release binaries, `cargo
build --release`).

    python mitsuba_slab.py SPP [ETA,..] [G,..] [ALPHA,..] [--mu MU]

With `--mu MU` the meter looks down at cosine MU with the normal: by
reciprocity, the reflectance for light arriving at that cosine (the
mirror reflection taken off is then `F(MU)`). The model's multiple
scattering is then `ssM` of a one-point cloud whose `illum_cos` is MU
(its total is not printed: sssingle's single scattering depends on a
camera).

Mitsuba's figures are kept in benches/results/mitsuba_slab.json (by case
and sample count) and read from there when present, so that the model's
side can be measured again without the path tracer's hours.
"""
import json
import pathlib
import subprocess
import sys
import tempfile
import time

import mitsuba as mi

mi.set_variant("scalar_rgb")


def fresnel(mu, eta):
    """Unpolarised Fresnel reflectance from outside at cosine mu."""
    if eta == 1.0:
        return 0.0
    st2 = (1 - mu * mu) / (eta * eta)
    ct = (1 - st2) ** 0.5
    rs = (mu - eta * ct) / (mu + eta * ct)
    rp = (eta * mu - ct) / (eta * mu + ct)
    return 0.5 * (rs * rs + rp * rp)


def measure(alpha, eta, g, spp, max_depth, mu=1.0):
    bsdf = ({"type": "null"} if eta == 1.0 else
            {"type": "dielectric", "int_ior": eta, "ext_ior": 1.0})
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": max_depth, "rr_depth": 1_000_000},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}},
        "slab": {
            "type": "cube",
            "to_world": mi.ScalarTransform4f().translate([0, 0, -1000]).scale([1000, 1000, 1000]),
            "bsdf": bsdf,
            "interior": {"type": "homogeneous", "albedo": {"type": "rgb", "value": alpha},
                         "sigma_t": 1.0, "phase": {"type": "hg", "g": g}},
        },
        "meter": {
            "type": "radiancemeter",
            "origin": [(1 - mu * mu) ** 0.5, 0, mu],
            "direction": [-((1 - mu * mu) ** 0.5), 0, -mu],
            "film": {"type": "hdrfilm", "width": 1, "height": 1,
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": spp},
        },
    })
    img = mi.render(scene, spp=spp)
    return float(mi.TensorXf(img).numpy().ravel()[0])


ROOT = pathlib.Path(__file__).resolve().parents[2]
BIN = ROOT / "target" / "release"
CACHE = ROOT / "benches" / "results" / "mitsuba_slab.json"


def load():
    return json.loads(CACHE.read_text()) if CACHE.exists() else {}


def cached(key, compute):
    """Mitsuba's figure for `key`, measured once."""
    if key in load():
        return load()[key]
    t = time.time()
    entry = {"value": compute(), "seconds": round(time.time() - t, 1)}
    data = load()  # (another run may have added some meanwhile)
    data[key] = entry
    CACHE.write_text(json.dumps(dict(sorted(data.items())), indent=1) + "\n")
    return entry


def model(alpha, eta, g, mu=1.0):
    """The model's (R_m + R_s, R_m), as ssmulti records them; at cosine
    mu, (None, ssM of one point lit at mu)."""
    with tempfile.TemporaryDirectory() as d:
        cloud = pathlib.Path(d) / "one.ply"
        cloud.write_text(
            "ply\nformat ascii 1.0\nelement vertex 1\n"
            + "".join(f"property float {n}\n" for n in
                      ["x", "y", "z", "nx", "ny", "nz", "ptarea", "illum_r", "illum_g", "illum_b",
                       "illum_cos"])
            + f"end_header\n0 0 0 0 0 1 1 1 1 1 {mu!r}\n")
        out = pathlib.Path(d) / "out.ply"
        subprocess.run([BIN / "ssmulti", "-q", cloud, "--model", "physical", "--albedo", str(alpha),
                        "--mfp", "1", "--eta", str(eta), "--g", str(g), "-o", out], check=True)
        if mu != 1.0:
            text = subprocess.run([BIN / "pcconvert", "-q", out, "--format", "ply-ascii"],
                                  check=True, capture_output=True, text=True).stdout
            header, body = text.split("end_header\n")
            names = [x.split()[-1] for x in header.splitlines() if x.startswith("property")]
            return None, float(body.split()[names.index("ssM_r")])
        info = subprocess.run([BIN / "pcinfo", out], check=True, capture_output=True, text=True).stdout

        def first(name):
            line = next(x for x in info.splitlines() if x.split()[:1] == [name])
            return float(line.split("(")[1].split(",")[0])
        return first("ssmulti_colour"), first("ssmulti_reflectance")


if __name__ == "__main__":
    model_too = "--mitsuba-only" not in sys.argv
    sys.argv = [x for x in sys.argv if x != "--mitsuba-only"]
    mu = 1.0
    if "--mu" in sys.argv:
        i = sys.argv.index("--mu")
        mu = float(sys.argv[i + 1])
        del sys.argv[i:i + 2]
    spp = int(sys.argv[1])
    etas = [float(x) for x in (sys.argv[2] if len(sys.argv) > 2 else "1,1.33").split(",")]
    gs = [float(x) for x in (sys.argv[3] if len(sys.argv) > 3 else "0,0.8").split(",")]
    alphas = [float(x) for x in
              (sys.argv[4] if len(sys.argv) > 4 else "0.3,0.6,0.8,0.9,0.95,0.99").split(",")]
    print("| eta | g | albedo | Mitsuba total | model total | ratio | Mitsuba multiple | model multiple | ratio | s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for eta in etas:
        # Depths: the sensor's ray (1), in through the boundary (1 with a
        # dielectric), the event (1), out (1 with a dielectric).
        single_depth = 2 if eta == 1.0 else 4
        f0 = fresnel(mu, eta)
        for g in gs:
            for a in alphas:
                key = f"eta {eta} g {g} albedo {a} spp {spp}" + (f" mu {mu}" if mu != 1.0 else "")
                tot = cached(key + " all", lambda: measure(a, eta, g, spp, -1, mu))
                one = cached(key + " single", lambda: measure(a, eta, g, spp, single_depth, mu))
                total, single = tot["value"] - f0, one["value"] - f0
                if model_too and mu != 1.0:
                    ms = total - single
                    _, mm = model(a, eta, g, mu)
                    print(f"| {eta} | {g} | {a} | {total:.4f} | - | - | "
                          f"{ms:.4f} | {mm:.4f} | {mm / ms:.3f} | {tot['seconds']:.0f} |", flush=True)
                elif model_too:
                    mt, mm = model(a, eta, g)
                    ms = total - single
                    print(f"| {eta} | {g} | {a} | {total:.4f} | {mt:.4f} | {mt / total:.3f} | "
                          f"{ms:.4f} | {mm:.4f} | {mm / ms:.3f} | {tot['seconds']:.0f} |", flush=True)
                else:
                    print(key, total, single, tot["seconds"], flush=True)
