"""The figures of docs/python.md. Run single-threaded and briefly:

    RAYON_NUM_THREADS=1 python python/bench/measure.py target/release/isoc

1. `Surface.eval` on 10^6 points against the library's batch point kernel
   alone on the same points (already split into columns, one call): the
   binding's overhead.
2. `Surface.mesh` against `isoc mesh` with the same options: the wall time
   of compile + mesh + writing a PLY, and the mesher's own `total` timing.
"""

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import isoc

ROOT = Path(__file__).resolve().parents[2]
cli = sys.argv[1] if len(sys.argv) > 1 else str(ROOT / "target/release/isoc")


def best(f, n=5):
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


print("| formula | eval 10^6 (ms) | kernel, one call (ms) | ratio | kernel, 1024-point calls (ms) | ratio |")
print("|---|---|---|---|---|---|")
pts = np.random.default_rng(0).uniform(-1.2, 1.2, (1_000_000, 3))
for name in ("sphere", "heart", "twotorus", "decocube"):
    s = isoc.load(ROOT / "corpus" / f"{name}.iso")
    s.eval(pts[:10])
    e = best(lambda: s.eval(pts))
    k = min(s._core._kernel_seconds(pts) for _ in range(5))
    c = min(s._core._kernel_seconds(pts, 1024) for _ in range(5))
    print(f"| {name} | {e * 1e3:.1f} | {k * 1e3:.1f} | {e / k:.2f} | {c * 1e3:.1f} | {e / c:.2f} |")

print()
print("| surface, options | `isoc mesh` wall (ms) | Python wall (ms) | ratio | mesher total CLI / Python (ms) |")
print("|---|---|---|---|---|")
with tempfile.TemporaryDirectory() as d:
    for name, level in (("heart", 7), ("twotorus", 7), ("decocube", 8)):
        path = ROOT / "corpus" / f"{name}.iso"
        args = [cli, "mesh", str(path), "--level", str(level), "-o", f"{d}/c.ply", "--stats", "json"]
        walls, totals = [], []
        for _ in range(3):
            t0 = time.perf_counter()
            out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
            walls.append(time.perf_counter() - t0)
            totals.append(json.loads(out)["timings_ms"]["total"])
        pwalls, ptotals = [], []
        for _ in range(3):
            t0 = time.perf_counter()
            m = isoc.load(path).mesh(level=level)
            m.save(f"{d}/p.ply")
            pwalls.append(time.perf_counter() - t0)
            ptotals.append(m.stats["timings_ms"]["total"])
        c, p = min(walls), min(pwalls)
        print(f"| {name} level {level} | {c * 1e3:.0f} | {p * 1e3:.0f} | {p / c:.3f} | {min(totals):.0f} / {min(ptotals):.0f} |")
