"""Reads a PLY with Python's plyfile (a file path, or stdin when '-') and
touches every property of every element, like `pcinfo` does: the
comparison run beside our reader in benches/ply_io.rs."""
import sys

from plyfile import PlyData

src = sys.argv[1]
ply = PlyData.read(sys.stdin.buffer if src == "-" else src)
total = 0.0
for el in ply.elements:
    for p in el.properties:
        col = el.data[p.name]
        total += float(col.min()) + float(col.max()) + float(col.mean())
print(ply.elements[0].count, total)
