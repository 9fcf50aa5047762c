"""The comparison run beside benches/geometry.rs: trimesh loads the mesh,
samples N points on it (sample_surface) and takes their faces' normals,
then writes them as binary PLY (whole process, like scatter | facet)."""
import sys

import numpy as np
import trimesh
from plyfile import PlyData, PlyElement

mesh_path, n, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
m = trimesh.load(mesh_path, process=False)
pts, face = trimesh.sample.sample_surface(m, n, seed=1)
nrm = m.face_normals[face]
v = np.empty(n, dtype=[(k, "f4") for k in ("x", "y", "z", "nx", "ny", "nz")])
v["x"], v["y"], v["z"] = pts.T
v["nx"], v["ny"], v["nz"] = nrm.T
PlyData([PlyElement.describe(v, "vertex")]).write(out)
