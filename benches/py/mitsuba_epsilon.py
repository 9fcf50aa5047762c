"""How much of a medium Mitsuba's ray offset skips (docs/PERFORMANCE.md,
race_split.py): Mitsuba 3 in f32 starts a ray that leaves a surface
`(1 + max|p|) * RayEpsilon` off it along the normal, so a camera ray
that crosses a null boundary into a medium skips that layer. The light
that single scattering brings from below is then darker by about
`exp(-sigma_t * offset / cos_i)`: 2-4% where the mean free path is a
hundredth of a unit (Suzanne's skin1, the dragon's medium), whatever the
samples.

Here: a cube of side 4 (a half-space for a mean free path of 0.01), its
top face seen straight down, lit by a distant light at cos_i = 0.85,
single scattering only (`max_depth` 2), against the closed form
`albedo / (4 pi) * E * cos_i / (cos_i + cos_o)`, with the whole scene
moved by 0, 10 and 100 units (which grows the offset), beside the
predicted loss.

    python mitsuba_epsilon.py [SPP]
"""
import math
import pathlib
import sys
import tempfile

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

ALBEDO = [0.9585, 0.838, 0.678]
MFP = [0.013, 0.0095, 0.0067]


def cube(path):
    """A closed cube of side 4 about the origin, outward winding."""
    v = [(x, y, z) for x in (-2, 2) for y in (-2, 2) for z in (-2, 2)]
    i = {p: k + 1 for k, p in enumerate(v)}
    quads = [[(-2, -2, 2), (2, -2, 2), (2, 2, 2), (-2, 2, 2)], [(-2, -2, -2), (-2, 2, -2), (2, 2, -2), (2, -2, -2)],
             [(-2, -2, -2), (2, -2, -2), (2, -2, 2), (-2, -2, 2)], [(-2, 2, -2), (-2, 2, 2), (2, 2, 2), (2, 2, -2)],
             [(-2, -2, -2), (-2, -2, 2), (-2, 2, 2), (-2, 2, -2)], [(2, -2, -2), (2, 2, -2), (2, 2, 2), (2, -2, 2)]]
    lines = [f"v {x} {y} {z}" for x, y, z in v]
    for a, b, c, d in quads:
        lines += [f"f {i[a]} {i[b]} {i[c]}", f"f {i[a]} {i[c]} {i[d]}"]
    path.write_text("\n".join(lines) + "\n")


def main():
    spp = int(sys.argv[1]) if len(sys.argv) > 1 else 256
    d = np.array([-0.35, -0.45, -1.0])
    d /= np.linalg.norm(d)
    ci = -d[2]
    top = max(1.0 / m for m in MFP)
    closed = np.array(ALBEDO) / (4 * math.pi) * ci / (ci + 1.0)
    print(f"Mitsuba {mi.__version__}, RayEpsilon {mi.math.RayEpsilon:.3g}; single scattering over the closed form, "
          "per channel (sigma_t " + ", ".join(f"{1 / m:.0f}" for m in MFP) + "), and the predicted ratio")
    with tempfile.TemporaryDirectory() as dd:
        obj = pathlib.Path(dd) / "cube.obj"
        cube(obj)
        for shift in (0.0, 10.0, 100.0):
            move = mi.ScalarTransform4f().translate([shift] * 3)
            s = {"type": "scene", "integrator": {"type": "volpath", "max_depth": 2, "rr_depth": 1000},
                 "cube": {"type": "obj", "filename": str(obj), "face_normals": True, "bsdf": {"type": "null"},
                          "to_world": move,
                          "interior": {"type": "homogeneous", "albedo": {"type": "rgb", "value": ALBEDO},
                                       "sigma_t": {"type": "rgb", "value": [1 / m / top for m in MFP]},
                                       "scale": top, "phase": {"type": "hg", "g": 0.0}}},
                 "sun": {"type": "directional", "direction": d.tolist(),
                         "irradiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}},
                 "camera": {"type": "perspective", "fov": 10,
                            "to_world": mi.ScalarTransform4f().look_at(origin=[shift, shift, shift + 7],
                                                                       target=[shift, shift, shift + 2],
                                                                       up=[0, 1, 0]),
                            "film": {"type": "hdrfilm", "width": 16, "height": 16, "rfilter": {"type": "box"}},
                            "sampler": {"type": "independent", "sample_count": spp}}}
            img = np.array(mi.render(mi.load_dict(s), spp=spp))[:, :, :3]
            got = img.mean(axis=(0, 1)) / closed
            # The top face's points lie about (shift + 2) from the origin.
            offset = (1 + shift + 2) * mi.math.RayEpsilon
            want = [math.exp(-offset / m / ci) for m in MFP]
            print(f"moved by {shift:5.0f}: offset {offset:.2e}; got " + ", ".join(f"{x:.3f}" for x in got)
                  + "; predicted " + ", ".join(f"{x:.3f}" for x in want))


if __name__ == "__main__":
    main()
