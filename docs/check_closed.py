#!/usr/bin/env python3
"""Check a binary isoc PLY (SPEC §3 layout) for closedness and 2-manifold
edges, independently of isoc's own tally: every undirected edge is used
by exactly two triangles in opposite directions, except edges with both
ends on one face of the domain box (the surface cut by the domain), used
once. Prints the counts; exits 1 on any bad edge.

    python3 docs/check_closed.py mesh.ply a,b,c,d,e,f

Needs numpy; memory about 40 bytes a triangle.
"""
import sys

import numpy as np


def main():
    path, box = sys.argv[1], [float(v) for v in sys.argv[2].split(",")]
    data = np.memmap(path, dtype=np.uint8, mode="r")
    end = bytes(data[:4096]).index(b"end_header\n") + len(b"end_header\n")
    header = bytes(data[:end]).decode()
    nv = int(header.split("element vertex ")[1].split()[0])
    nf = int(header.split("element face ")[1].split()[0])
    vdt = np.dtype([("p", "<f4", 3), ("n", "<f4", 3), ("c", "u1", 3)])
    fdt = np.dtype([("k", "u1"), ("i", "<i4", 3)])
    p = np.frombuffer(data, vdt, nv, end)["p"]
    f = np.frombuffer(data, fdt, nf, end + nv * vdt.itemsize)["i"].astype(np.int64)
    assert (np.frombuffer(data, fdt, nf, end + nv * vdt.itemsize)["k"] == 3).all()
    a = f.reshape(-1)
    b = np.roll(f, -1, axis=1).reshape(-1)
    del f
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = (lo << 32) | hi
    fwd = (a < b).astype(np.int8)
    del a, b, lo, hi
    order = np.argsort(key, kind="stable")
    key, fwd = key[order], fwd[order]
    del order
    starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    uses = np.diff(np.r_[starts, len(key)])
    forward = np.add.reduceat(fwd, starts)
    edges = key[starts]
    two = uses == 2
    misoriented = int((two & (forward != 1)).sum())
    over = int((uses > 2).sum())
    once = edges[uses == 1]
    u, v = p[once >> 32], p[once & 0xFFFFFFFF]
    tol = 1e-5 * max(box[1] - box[0], box[3] - box[2], box[5] - box[4])
    on_face = np.zeros(len(once), bool)
    for k in range(3):
        for plane in (box[2 * k], box[2 * k + 1]):
            on_face |= (np.abs(u[:, k] - plane) <= tol) & (np.abs(v[:, k] - plane) <= tol)
    open_ = int((~on_face).sum())
    print(f"{nv} vertices, {nf} triangles, {len(edges)} edges: {int(two.sum())} used twice "
          f"({misoriented} misoriented), {len(once)} once ({int(on_face.sum())} on the domain "
          f"boundary, {open_} open), {over} used 3+ times; euler {nv - len(edges) + nf}")
    sys.exit(1 if misoriented or over or open_ else 0)


if __name__ == "__main__":
    main()
