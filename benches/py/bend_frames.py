"""Ten frames of a bending cylinder, for `make frames-bench`: the per-frame
bake time of an animation on one cloud (`make frames`).

A cylinder of radius 0.3 and length 3 along +y (RINGS x SEGS quads, open
ends) bent in the x-y plane from 0 to 90 degrees over FRAMES frames,
written as OUT/bend.0001.obj ...; beside them a distant light and a dim
dome (OUT/lights.json) and a 256 x 256 camera (OUT/camera.json).

    python bend_frames.py OUT [FRAMES] [RINGS] [SEGS]
"""
import json
import math
import os
import sys

out = sys.argv[1]
frames = int(sys.argv[2]) if len(sys.argv) > 2 else 10
rings = int(sys.argv[3]) if len(sys.argv) > 3 else 48
segs = int(sys.argv[4]) if len(sys.argv) > 4 else 64
length = 3.0
os.makedirs(out, exist_ok=True)
for k in range(frames):
    angle = math.pi / 2 * k / max(frames - 1, 1)
    lines = []
    for i in range(rings + 1):
        y = length * i / rings
        for j in range(segs):
            a = 2 * math.pi * j / segs
            x, z = 0.3 * math.cos(a), 0.3 * math.sin(a)
            if angle == 0:
                q = (x, y, z)
            else:
                r = length / angle
                t = y / r
                q = (r - (r - x) * math.cos(t), (r - x) * math.sin(t), z)
            lines.append("v %r %r %r" % q)
    v = lambda i, j: i * segs + j % segs + 1
    for i in range(rings):
        for j in range(segs):
            lines.append("f %d %d %d %d" % (v(i, j), v(i, j + 1), v(i + 1, j + 1), v(i + 1, j)))
    with open(os.path.join(out, "bend.%04d.obj" % (k + 1)), "w") as f:
        f.write("\n".join(lines) + "\n")
with open(os.path.join(out, "lights.json"), "w") as f:
    json.dump({"lights": [
        {"name": "key", "type": "distant", "intensity": 2, "direction": [-0.3, -1, -0.5]},
        {"name": "sky", "type": "dome", "intensity": 0.2, "samples": 16}]}, f)
with open(os.path.join(out, "camera.json"), "w") as f:
    json.dump({"position": [1.5, 1.5, 8], "look_at": [1, 1.5, 0], "fov": 40,
               "width": 256, "height": 256}, f)
