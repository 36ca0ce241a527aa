"""Renders the README's Python example (a torus meshed from Python) with
matplotlib: `python docs/python_example.py` (needs `pip install ./python
matplotlib`) writes docs/python_torus.png."""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import isoc  # noqa: E402
from isoc import x, y, z  # noqa: E402

torus = isoc.compile((isoc.sqrt(x**2 + y**2) - 1) ** 2 + z**2 - 0.1, domain=(-2, 2))
mesh = torus.mesh(level=6)

v, f = mesh.vertices, mesh.faces
# Lambert shading from the per-vertex normals (the unit gradient).
light = np.array([0.4, -0.5, 0.77])
light /= np.linalg.norm(light)
shade = 0.25 + 0.75 * np.clip(mesh.normals[f].mean(axis=1) @ light, 0, 1)
colour = np.where(mesh.ambiguous[f].any(axis=1)[:, None], [0.85, 0.2, 0.2], [0.3, 0.7, 0.35])

fig = plt.figure(figsize=(6, 4), dpi=110)
ax = fig.add_subplot(projection="3d")
poly = ax.plot_trisurf(v[:, 0], v[:, 1], v[:, 2], triangles=f, linewidth=0.1, edgecolor=(0, 0, 0, 0.15))
poly.set_facecolor(colour * shade[:, None])
ax.set_box_aspect((1, 1, 0.35))
ax.set_axis_off()
ax.view_init(elev=35, azim=-60)
s = mesh.stats
ax.set_title(f"isoc from Python: {s['triangles']} triangles, genus {s['genus'][0]}, "
             f"{'guaranteed' if mesh.guaranteed else 'not guaranteed'}", fontsize=9)
out = Path(__file__).with_name("python_torus.png")
fig.savefig(out, bbox_inches="tight")
print(out)
