"""The Python OpenEXR package as an independent reader and writer.

dump IN.exr
    Prints JSON: the header attributes (as strings) and, per channel, its
    type, shape and values (floats as their 32-bit patterns, so that the
    comparison is bit-exact).
shade OUT.exr [--spelling x|X|R|red] [--no-alpha] [--tiled]
    Writes a renderer-style image: 64 x 48 pixels, data window offset to
    (10, 20) in a 100 x 80 display window, P and N passes of a sphere of
    radius 1 at the origin seen along -z, alpha 1 where it is hit.
"""

import json
import sys

import numpy as np
import OpenEXR


def dump(path):
    with OpenEXR.File(path, separate_channels=True) as f:
        header = {k: str(v) for k, v in f.header().items()}
        chans = {}
        for name, ch in f.channels().items():
            px = np.asarray(ch.pixels)
            if px.dtype == np.float32:
                vals = px.view(np.uint32).ravel().tolist()
                kind = "float"
            elif px.dtype == np.float16:
                vals = px.view(np.uint16).ravel().tolist()
                kind = "half"
            else:
                vals = px.ravel().tolist()
                kind = "uint"
            chans[name] = {"type": kind, "shape": list(px.shape), "bits": vals}
    print(json.dumps({"header": header, "channels": chans}))


def shade(path, args):
    w, h = 64, 48
    x0, y0 = 10, 20
    spelling = "x"
    if "--spelling" in args:
        spelling = args[args.index("--spelling") + 1]
    names = {
        "x": ("x", "y", "z"),
        "X": ("X", "Y", "Z"),
        "R": ("R", "G", "B"),
        "red": ("red", "green", "blue"),
    }[spelling]
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    u = (xs + 0.5) / w * 2.0 - 1.0
    v = (ys + 0.5) / h * 2.0 - 1.0
    r2 = u * u + v * v
    hit = r2 < 1.0
    z = np.sqrt(np.clip(1.0 - r2, 0.0, None))
    P = np.stack([u, v, z], axis=-1) * hit[..., None]
    N = P.copy()
    chans = {}
    for k, c in enumerate(names):
        chans["P." + c] = np.ascontiguousarray(P[..., k], dtype=np.float32)
        chans["N." + c] = np.ascontiguousarray(N[..., k], dtype=np.float32)
    if "--no-alpha" not in args:
        chans["A"] = hit.astype(np.float32)
    header = {
        "compression": OpenEXR.ZIP_COMPRESSION,
        "dataWindow": ((x0, y0), (x0 + w - 1, y0 + h - 1)),
        "displayWindow": ((0, 0), (99, 79)),
    }
    if "--tiled" in args:
        header["type"] = OpenEXR.tiledimage
        tiles = OpenEXR.TileDescription()
        tiles.xSize, tiles.ySize, tiles.mode = 16, 16, OpenEXR.ONE_LEVEL
        header["tiles"] = tiles
    with OpenEXR.File(header, chans) as f:
        f.write(path)


if __name__ == "__main__":
    cmd = sys.argv[1]
    if cmd == "dump":
        dump(sys.argv[2])
    elif cmd == "shade":
        shade(sys.argv[2], sys.argv[3:])
    else:
        sys.exit("unknown command " + cmd)
