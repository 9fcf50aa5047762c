"""Point-cloud subsurface scattering: the toolkit's stages on clouds held in
Python, with their attributes as NumPy arrays.

    import pcsss
    mesh = pcsss.read("bunny.obj")
    cloud = pcsss.scatter(mesh, count=100_000)
    cloud = pcsss.facet(cloud, mesh="bunny.obj")
    cloud = pcsss.illum(cloud, lights="lights.json", mesh="bunny.obj")
    cloud = pcsss.ssmulti(cloud, rd=(0.9, 0.5, 0.3), sd=0.6, rgb=True)
    ssm = cloud["ssM"]                  # N x 3 float32
    pcsss.write(cloud, "baked.ply")

Every stage takes the keywords its command line takes (`--sd` is `sd=`,
`--per-point rd=Cd` is `per_point="rd=Cd"`, a flag is `=True`), runs the
library's code for it with the GIL released, and returns a new cloud; the
input is left as it was. Numbers may be NumPy numbers or arrays, and an
option that takes a file (`mesh=`, `rest=`, ...) also takes a Cloud in
memory. `render(cloud, mesh=..., camera=...)` returns the picture as a
cloud (a point a pixel), and writes `output=`/`png=` where given. A
failure raises `pcsss.ParameterError` (a
`ValueError`) or `pcsss.Error` with the binary's one-line message.
"""

from ._pcsss import (  # noqa: F401
    Cloud,
    Error,
    ParameterError,
    __version__,
    facet,
    filter,
    follow,
    illum,
    measure,
    promote,
    read,
    render,
    scatter,
    ssmulti,
    sssingle,
    texture,
    write,
)
