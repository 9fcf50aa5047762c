"""What the image comparisons against Mitsuba 3 share (mitsuba_sphere.py,
mitsuba_bunny.py): a Mitsuba perspective camera from the toolkit's camera
file, the bake's picture read back from its OpenEXR, and the errors."""
import os
import pathlib
import subprocess

import mitsuba as mi
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
# volpath's Russian roulette from this depth on. Its default (5) reads
# dark in media that absorb little, where light arrives through many
# events: the references follow every path to its end.
RR_DEPTH = 1_000_000


def camera(cam, spp):
    """Mitsuba's pinhole camera for the toolkit's camera `cam` (its
    vertical field of view; Mitsuba's Gaussian pixel filter)."""
    return {
        "type": "perspective", "fov": cam["fov"], "fov_axis": "y",
        "to_world": mi.ScalarTransform4f().look_at(origin=cam["position"], target=cam["look_at"],
                                                   up=cam["up"]),
        "film": {"type": "hdrfilm", "width": cam["width"], "height": cam["height"],
                 "pixel_format": "rgb", "rfilter": {"type": "gaussian"}},
        "sampler": {"type": "independent", "sample_count": spp},
    }


# The stages: `BIN`, else this clone's release build.
BIN = pathlib.Path(os.environ.get("BIN", ROOT / "target" / "release"))


def read_image(exr, d, size, pcconvert=BIN / "pcconvert"):
    """(beauty premultiplied, coverage) as size x size arrays (`size` an
    int, or (width, height)), from the render's OpenEXR (through
    `pcconvert` to binary PLY)."""
    width, height = (size, size) if isinstance(size, int) else size
    ply = d / "img.ply"
    subprocess.run([pcconvert, "-q", exr, "--format", "ply", "-o", ply], check=True)
    raw = ply.read_bytes()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    types = {"float": "<f4", "double": "<f8", "int": "<i4", "uint": "<u4", "uchar": "u1", "char": "i1",
             "short": "<i2", "ushort": "<u2"}
    props, count = [], 0
    for line in raw[:end].decode().splitlines():
        w = line.split()
        if w[:2] == ["element", "vertex"]:
            count = int(w[2])
        elif w and w[0] == "element":
            break
        elif w and w[0] == "property" and count:
            props.append((w[2], types[w[1]]))
    rows = np.frombuffer(raw, dtype=np.dtype(props), count=count, offset=end)
    img, a = np.zeros((height, width, 3)), np.zeros((height, width))
    x, y = rows["pixel_x"].astype(int), rows["pixel_y"].astype(int)
    for c, n in enumerate(["beauty_r", "beauty_g", "beauty_b"]):
        img[y, x, c] = rows[n]
    a[y, x] = rows["A"]
    return img, a


def errors(img, ref, mask):
    """RMS and mean relative error of `img` against `ref` over `mask`,
    each channel a sample."""
    rel = (img[mask] - ref[mask]) / np.maximum(ref[mask], 1e-6)
    return float(np.sqrt(np.mean(rel ** 2))), float(np.mean(rel))


def render_attr(out, name, cam, attr, exr):
    """The bake's `attr` alone (ssM as its radiance, ssS), 16 rays a
    pixel under Mitsuba's Gaussian pixel filter, from the bake's directory
    `out` and its mesh `name` (the stages from `BIN`, else target/release)."""
    subprocess.run([BIN / "render", "-q", "--mesh", out / f"{name}_mesh.ply",
                    "--camera", cam, "--cloud", out / f"{name}_sss.ply", "--attr", attr, "--spp", "16", "--pixel-filter", "gaussian",
                    "-o", exr], check=True)
