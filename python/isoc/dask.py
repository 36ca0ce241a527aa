"""Bricked meshing on a Dask cluster (the optional extra ``isoc[dask]``).

:func:`mesh` cuts the domain into ``8**bricks`` bricks (as ``isoc mesh
--bricks``), meshes each brick as one task on a ``dask.distributed``
cluster, and welds the parts on the client as they arrive — in brick
order, so the result is exactly the local bricked mesh
(``Surface.mesh(bricks=...)``), whatever the cluster and the order the
tasks finish in.

Contract and limits
-------------------
- A task sends the surface as its source text (compiled once per worker
  process) and returns one part file's bytes (``isoc mesh --brick I``'s
  format): workers need the ``isoc`` package, not the client's memory.
- The client holds the welded mesh (or, with ``path``, the open seams
  only: the file is streamed) and the parts that arrived ahead of their
  turn.
- A brick is a pure function of its inputs: Dask may run it again (a
  worker lost mid-task) and the mesh is unchanged.

Examples
--------
>>> import isoc, isoc.dask                               # doctest: +SKIP
>>> from dask.distributed import Client, LocalCluster    # doctest: +SKIP
>>> gyroid = isoc.compile("domain [-31.4, 31.4]^3; surface sin(x)*cos(y) + sin(y)*cos(z) + sin(z)*cos(x);")  # doctest: +SKIP
>>> with Client(LocalCluster(n_workers=2, threads_per_worker=1)) as client:  # doctest: +SKIP
...     isoc.dask.mesh(gyroid, level=8, bricks=2, client=client, path="gyroid.ply")
"""

from __future__ import annotations

import functools
import json
import os
from typing import Any, Optional, Sequence, Union

from . import Mesh, Surface, _brick_level, _isoc, _options, _recompile

__all__ = ["mesh"]


@functools.lru_cache(maxsize=8)
def _surface(source: str, file: str, domain: tuple, params: tuple) -> Surface:
    """The task's surface, compiled once per worker process."""
    return _recompile(source, file, domain, dict(params))


def _mesh_brick(spec: tuple, bricks: int, brick: int, options: dict, threads: int) -> bytes:
    """One brick as part-file bytes (runs on a worker)."""
    return _surface(*spec)._core.mesh_part(bricks, brick, options, threads)


def mesh(
    surface: Surface,
    level: Optional[int] = None,
    bricks: int = 1,
    client: Any = None,
    *,
    path: Union[None, str, "os.PathLike[str]"] = None,
    smooth: int = 3,
    creases: bool = True,
    kmax: Optional[float] = None,
    coarse: bool = False,
    min_level: int = 3,
    certify: bool = False,
    prune: bool = True,
    t: float = 0.0,
    domain: Optional[Sequence[float]] = None,
    unit: str = "millimeter",
    threads: int = 1,
) -> Union[Mesh, dict]:
    """Mesh f = 0 brick by brick on a Dask cluster; the same mesh as ``--bricks``.

    Parameters
    ----------
    surface : Surface
        The surface (sent to the workers as its source).
    level : int, optional
        Maximal octree level (default 7), as :meth:`isoc.Surface.mesh`.
    bricks : int, optional
        Brick level: ``8**bricks`` tasks (0 to 6, default 1).
    client : dask.distributed.Client, optional
        The cluster's client; default the current one
        (``dask.distributed.default_client()``).
    path : str or path-like, optional
        Stream the welded mesh into this file (.ply, .obj, .stl, .3mf or
        .glb) instead of returning it; the client's memory then holds the
        open seams, not the mesh.
    smooth, creases, kmax, coarse, min_level, certify, prune, t, domain
        As in :meth:`isoc.Surface.mesh`.
    unit : str, optional
        Unit of a .3mf `path` (default millimetres).
    threads : int, optional
        Threads per brick task (default 1: one brick per worker thread).

    Returns
    -------
    Mesh or dict
        The welded mesh (``stats`` as ``--stats json``, with ``bricks``
        and ``parts``), or with `path` the stats alone.

    Raises
    ------
    ValueError
        A bad option, or no Dask client.
    ImportError
        ``dask.distributed`` is not installed (``pip install isoc[dask]``).
    """
    from dask.distributed import as_completed, default_client

    bricks = _brick_level(bricks)
    if client is None:
        client = default_client()
    level = 7 if level is None else int(level)
    spec = (surface.source, surface._core.file, tuple(surface.domain), tuple(sorted(surface.params.items())))
    options = _options(level, None, kmax, coarse, min_level, smooth, creases, certify, prune, t, domain)
    count = 8**bricks
    merger = _isoc.CoreMerger(None if path is None else os.fspath(path), unit)
    futures = client.map(
        _mesh_brick,
        [spec] * count,
        [bricks] * count,
        range(count),
        [options] * count,
        [int(threads)] * count,
    )
    index = {f.key: i for i, f in enumerate(futures)}
    waiting: dict[int, bytes] = {}
    turn = 0
    for future in as_completed(futures):
        waiting[index[future.key]] = future.result()
        future.release()
        while turn in waiting:
            merger.add(waiting.pop(turn))
            turn += 1
    core, stats = merger.finish()
    if core is None:
        return json.loads(stats)
    return Mesh(core)
