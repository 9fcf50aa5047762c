"""The peer of `scatter --blue` beside benches/geometry.rs: point-cloud-utils'
sample_mesh_poisson_disk (VCG's Poisson-disk sampling of a mesh, 40x
oversampling, geodesic distances; its count is within 4% of the request):
load the mesh, sample, write the points as binary PLY (whole process)."""
import sys

import numpy as np
import point_cloud_utils as pcu
from plyfile import PlyData, PlyElement

mesh_path, n, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
v, f = pcu.load_mesh_vf(mesh_path)
fid, bc = pcu.sample_mesh_poisson_disk(v, f, num_samples=n, random_seed=1)
pts = pcu.interpolate_barycentric_coords(f, fid, bc, v)
p = np.empty(len(pts), dtype=[(k, "f8") for k in ("x", "y", "z")])
p["x"], p["y"], p["z"] = pts.T
PlyData([PlyElement.describe(p, "vertex")]).write(out)
