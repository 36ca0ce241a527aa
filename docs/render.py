#!/usr/bin/env python3
"""Render an isoc PLY mesh to PNG with its per-vertex ambiguity colours
(green: topology guaranteed, red: ambiguous cell), flat-shaded.

    python3 docs/render.py mesh.ply out.png [--elev 20 --azim -60] [--edges]
        [--box x0,x1,y0,y1,z0,z1] [--plain]

`--box` draws only the triangles whose centroid lies in the box and zooms
on it; `--plain` shades in grey (no ambiguity colours), to show the shape.

Needs numpy and matplotlib (pip install numpy matplotlib). It reads the
binary PLY layout that `isoc mesh` writes (SPEC §3) and nothing else.
"""
import argparse
import struct

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from mpl_toolkits.mplot3d.art3d import Poly3DCollection


def read_ply(path):
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode()
    nv = int(header.split("element vertex ")[1].split()[0])
    nf = int(header.split("element face ")[1].split()[0])
    vdt = np.dtype([("p", "<f4", 3), ("n", "<f4", 3), ("c", "u1", 3)])
    verts = np.frombuffer(data, vdt, nv, end)
    fdt = np.dtype([("k", "u1"), ("i", "<i4", 3)])
    faces = np.frombuffer(data, fdt, nf, end + nv * vdt.itemsize)
    return verts, faces["i"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("ply")
    ap.add_argument("png")
    ap.add_argument("--elev", type=float, default=20)
    ap.add_argument("--azim", type=float, default=-60)
    ap.add_argument("--edges", action="store_true", help="draw triangle edges")
    ap.add_argument("--box", help="x0,x1,y0,y1,z0,z1: draw and zoom on this box")
    ap.add_argument("--plain", action="store_true", help="grey, no ambiguity colours")
    a = ap.parse_args()
    v, f = read_ply(a.ply)
    p = v["p"].astype(float)
    if a.box:
        b = np.array([float(x) for x in a.box.split(",")]).reshape(3, 2)
        cen = p[f].mean(axis=1)
        keep = np.all((cen >= b[:, 0]) & (cen <= b[:, 1]), axis=1)
        f = f[keep]
    tri = p[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-300
    light = np.array([0.4, -0.5, 0.75])
    light /= np.linalg.norm(light)
    shade = 0.35 + 0.65 * np.clip(n @ light, 0, 1)
    col = v["c"][f].astype(float).mean(axis=1) / 255.0
    if a.plain:
        col = np.full_like(col, 0.85)
    fc = np.clip(col * shade[:, None], 0, 1)
    fig = plt.figure(figsize=(6, 6), dpi=110)
    ax = fig.add_subplot(projection="3d")
    edges = (0, 0, 0, 0.6) if a.edges else "none"
    ax.add_collection3d(
        Poly3DCollection(tri, facecolors=fc, edgecolors=edges, linewidths=0.2)
    )
    lo, hi = (b[:, 0], b[:, 1]) if a.box else (p.min(axis=0), p.max(axis=0))
    c, r = (lo + hi) / 2, (hi - lo).max() / 2
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(c[2] - r, c[2] + r)
    ax.view_init(elev=a.elev, azim=a.azim)
    ax.set_axis_off()
    fig.savefig(a.png, bbox_inches="tight")


if __name__ == "__main__":
    main()
