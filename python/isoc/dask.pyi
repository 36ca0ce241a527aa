"""Type stubs of isoc.dask (see dask.py for the documentation)."""

import os
from typing import Any, Optional, Sequence, Union

from . import Mesh, Surface

def mesh(
    surface: Surface,
    level: Optional[int] = ...,
    bricks: int = ...,
    client: Any = ...,
    *,
    path: Union[None, str, os.PathLike[str]] = ...,
    smooth: int = ...,
    creases: bool = ...,
    kmax: Optional[float] = ...,
    coarse: bool = ...,
    min_level: int = ...,
    certify: bool = ...,
    prune: bool = ...,
    t: float = ...,
    domain: Optional[Sequence[float]] = ...,
    unit: str = ...,
    threads: int = ...,
) -> Union[Mesh, dict]: ...
