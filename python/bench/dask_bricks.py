"""The Dask figure of docs/bricks.md: `isoc.dask.mesh` on a LocalCluster of
2 worker processes (1 thread each) against the local bricked run
`Surface.mesh(bricks=...)` on 2 threads — same gyroid, same options, both
welded in memory; best wall time of 3, and whether the meshes are
identical. Needs the `dask` extra (pip install ./python[dask]).

    python python/bench/dask_bricks.py [LEVEL] [BRICKS]
"""

import sys
import time

import numpy as np
from dask.distributed import Client, LocalCluster

import isoc
import isoc.dask

GYROID = "domain [-31.4, 31.4]^3; surface sin(x)*cos(y) + sin(y)*cos(z) + sin(z)*cos(x);"


def best(f, n=3):
    out, times = None, []
    for _ in range(n):
        t0 = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t0)
    return min(times), out


def main():
    level = int(sys.argv[1]) if len(sys.argv) > 1 else 8
    bricks = int(sys.argv[2]) if len(sys.argv) > 2 else 2
    s = isoc.compile(GYROID)
    local_s, local = best(lambda: s.mesh(level=level, bricks=bricks, threads=2))
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    with Client(cluster) as client:
        client.run(lambda: isoc.compile(GYROID))  # workers import isoc first
        dask_s, remote = best(lambda: isoc.dask.mesh(s, level=level, bricks=bricks, client=client))
    cluster.close()
    same = (np.array_equal(local.vertices, remote.vertices) and np.array_equal(local.faces, remote.faces)
            and np.array_equal(local.normals, remote.normals))
    print(f"gyroid level {level}, bricks {bricks}: {local.stats['triangles']} triangles")
    print(f"| local bricked (2 threads) | {local_s:.2f} s |")
    print(f"| Dask LocalCluster (2 workers x 1 thread) | {dask_s:.2f} s |")
    print(f"ratio {dask_s / local_s:.2f}, identical: {same}")


if __name__ == "__main__":
    main()
