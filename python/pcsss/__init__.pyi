"""Type stubs for pcsss (the module is compiled: python/src/lib.rs)."""

from os import PathLike
from typing import Any, Dict, List, Mapping, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Path = Union[str, PathLike[str]]
_Value = Union[bool, int, float, str, PathLike[str], Tuple[float, ...], List[float], npt.ArrayLike, "Cloud", None]

class Error(Exception):
    """A stage or file failed (the binary's exit status 1)."""

class ParameterError(ValueError):
    """A bad parameter or option (the binary's exit status 2)."""

class Cloud:
    """A point cloud: points with typed attributes, other elements (faces),
    and a detail of the parameters the stages recorded."""

    @staticmethod
    def from_arrays(
        arrays: Mapping[str, npt.ArrayLike],
        faces: Optional[Union[npt.ArrayLike, List[List[int]]]] = None,
    ) -> Cloud:
        """Points from arrays of N (a scalar) or N x 3 (a 3-vector; `P` a
        point, `N` a normal, `Cd`, `illum`, `ssM`, `ssS` colours), each
        copied into the toolkit's columns with its dtype; with `faces`
        (F x k point indices, or a list of index lists) a mesh.

        Points, normals and colours given as integers are converted to
        float64. Other integers wider than 32 bits become int32 when
        every value fits and are refused (ValueError) when one does not;
        float16 becomes float32 and longdouble float64."""
    def __len__(self) -> int: ...
    def __contains__(self, name: str) -> bool: ...
    def __getitem__(self, name: str) -> np.ndarray:
        """An attribute as a read-only view of the toolkit's own memory
        (no copy): a scalar's column; a 3-vector as N x 3 (the rows the
        module keeps a 3-vector in, or a binary file's records where its
        x, y, z are neighbours; gathered into a new array only where
        they are not)."""
    def components(self, name: str) -> List[np.ndarray]:
        """A 3-vector's x, y and z columns as read-only views of the
        toolkit's own memory (no copy); a scalar's column alone."""
    def __setitem__(self, name: str, value: npt.ArrayLike) -> None: ...
    def keys(self) -> List[str]: ...
    def elements(self) -> List[Tuple[str, int]]: ...
    @property
    def detail(self) -> Dict[str, Any]: ...

def read(path: _Path) -> Cloud:
    """A cloud or mesh: PLY, OBJ, OpenEXR, or a USD stage (`scene.usda`,
    `scene.usda:/World/Bunny`)."""

def write(cloud: Cloud, path: _Path, format: Optional[str] = None) -> None:
    """Writes atomically; `format` one of ply, ply-ascii, ply-be, exr, usda
    (default: from the extension, else binary PLY)."""

# Each stage takes the keywords of its command line (`--sd 0.6` is
# `sd=0.6`, a flag is `=True`, a vector a tuple) and returns a new cloud.
def measure(input: Cloud, /, **options: _Value) -> Cloud: ...
def scatter(input: Cloud, /, **options: _Value) -> Cloud: ...
def facet(input: Cloud, /, **options: _Value) -> Cloud: ...
def follow(input: Cloud, /, **options: _Value) -> Cloud: ...
def texture(input: Cloud, /, **options: _Value) -> Cloud: ...
def promote(input: Cloud, /, **options: _Value) -> Cloud: ...
def illum(input: Cloud, /, **options: _Value) -> Cloud: ...
def ssmulti(input: Cloud, /, **options: _Value) -> Cloud: ...
def sssingle(input: Cloud, /, **options: _Value) -> Cloud: ...
def filter(input: Cloud, /, **options: _Value) -> Cloud: ...
def render(cloud: Cloud, /, **options: _Value) -> Cloud:
    """The picture of `cloud` on `mesh=` through `camera=` (options as
    `render --help`), as a cloud of a point a pixel; `output=` and `png=`
    write it too."""
