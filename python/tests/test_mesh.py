"""Meshes of the corpus, their stats, 3MF round trips, animation, Ctrl-C."""

import _thread
import json
import os
import subprocess
import threading
import time

import numpy as np
import pytest

import isoc
from conftest import CORPUS, ROOT, expected

trimesh = pytest.importorskip("trimesh")


@pytest.mark.parametrize("path", CORPUS, ids=lambda p: p.name)
def test_corpus_mesh_topology_and_3mf(path, tmp_path):
    """As tests/mesh/corpus_mesh.rs: a guaranteed mesh has the file's
    topology; every mesh survives a 3MF round trip through trimesh."""
    s = isoc.load(path)
    want = expected(path)
    for level in (5, 6):
        m = s.mesh(level=level, smooth=0)
        st = m.stats
        assert m.vertices.shape == (st["vertices"], 3) and m.vertices.dtype == np.float64
        assert m.faces.shape == (st["triangles"], 3) and m.faces.dtype == np.uint32
        assert m.normals.shape == m.vertices.shape and m.ambiguous.shape == (len(m.vertices),)
        assert m.guaranteed == st["guaranteed"]
        if m.guaranteed:
            assert want is not None, f"{path.name}: a singular surface was called guaranteed"
            assert st["watertight"] and st["manifold"]
            assert (st["components"], sum(st["genus"])) == want
    # 3MF: an independent reader loads it with the same counts, watertight
    # exactly when the mesher says so.
    out = tmp_path / (path.stem + ".3mf")
    m.save(out)
    t = trimesh.load(str(out), force="mesh", process=False)
    assert (len(t.vertices), len(t.faces)) == (len(m.vertices), len(m.faces))
    np.testing.assert_allclose(t.vertices, m.vertices, rtol=0, atol=0)
    assert t.is_watertight == st["watertight"]


def test_stats_are_the_cli_stats(isoc_bin, tmp_path):
    path = ROOT / "corpus" / "torus.iso"
    out = subprocess.run([isoc_bin, "mesh", str(path), "--level", "5", "-o", str(tmp_path / "t.ply"),
                          "--stats", "json"], check=True, capture_output=True, text=True).stdout
    cli = json.loads(out)
    # The CLI's process figure: the Python process is the caller's.
    assert cli.pop("peak_rss_bytes") > 0
    m = isoc.load(path).mesh(level=5)
    assert set(m.stats) == set(cli)
    assert set(m.stats["timings_ms"]) == set(cli["timings_ms"])
    for k in cli:
        if k != "timings_ms":
            assert m.stats[k] == cli[k], k
    tol = isoc.load(path).mesh(tolerance=1e-2, level=6)
    assert tol.stats["tolerance_met"] is True and "max_deviation" in tol.stats


def test_save_formats_and_units(tmp_path):
    m = isoc.load(ROOT / "corpus" / "sphere.iso").mesh(level=4)
    for ext in ("ply", "obj", "stl", "glb", "3mf"):
        m.save(tmp_path / f"s.{ext}")
        assert (tmp_path / f"s.{ext}").stat().st_size > 0
    import zipfile
    m.save(tmp_path / "inch.3mf", unit="inch")
    with zipfile.ZipFile(tmp_path / "inch.3mf") as z:
        assert {"[Content_Types].xml", "_rels/.rels", "3D/3dmodel.model"} <= set(z.namelist())
        assert b'unit="inch"' in z.read("3D/3dmodel.model")
    with zipfile.ZipFile(tmp_path / "s.3mf") as z:
        assert b'unit="millimeter"' in z.read("3D/3dmodel.model")
    with pytest.raises(ValueError):
        m.save(tmp_path / "s.xyz")
    with pytest.raises(ValueError):
        m.save(tmp_path / "s.3mf", unit="furlong")
    with pytest.raises(OSError):
        m.save(tmp_path / "missing" / "s.3mf")
    t = m.to_trimesh()
    assert t.is_watertight and len(t.faces) == len(m.faces)


def test_threads_and_progress_give_the_same_mesh():
    s = isoc.load(ROOT / "corpus" / "genus2.iso")
    seen = []
    a = s.mesh(level=5, threads=1, progress=lambda *a: seen.append(a))
    b = s.mesh(level=5)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.faces, b.faces)
    assert seen and seen[-1][0] == "smooth"


def test_animate_yields_one_mesh_per_frame():
    s = isoc.load(ROOT / "corpus" / "blobs_pass.iso")
    frames = list(s.animate(0.0, 0.2, 3))
    assert len(frames) == 3
    for f in frames:
        assert len(f.faces) > 0 and f.stats["watertight"]
        assert "geometric_triangles" in f.stats["frame"]


def _interrupt_after(seconds):
    """Ctrl-C in `seconds`, as a terminal would send it; returns the time it
    was sent (filled in when the timer fires)."""
    sent = []

    def fire():
        sent.append(time.perf_counter())
        _thread.interrupt_main()

    threading.Timer(seconds, fire).start()
    return sent


def _interrupt_latency(work, sent):
    """Runs `work`, which the interrupt recorded in `sent` must stop with
    `KeyboardInterrupt`; returns the seconds from the interrupt to it."""
    with pytest.raises(KeyboardInterrupt):
        work()
        time.sleep(30)
    return time.perf_counter() - sent[0]


def _os_threads():
    """Threads of this process as the OS counts them (Rust's included)."""
    try:
        return len(os.listdir("/proc/self/task"))
    except OSError:
        return threading.active_count()


def _threads_after_warm_up(s):
    """The thread count once rayon's pool exists (a small mesh of `s`)."""
    s.mesh(level=3)
    return _os_threads()


def test_ctrl_c_interrupts_a_long_mesh():
    s = isoc.load(ROOT / "corpus" / "decocube.iso")
    before = _threads_after_warm_up(s)
    finished = []

    def work():
        s.mesh(level=10, kmax=0.05, smooth=0)
        finished.append(True)

    latency = _interrupt_latency(work, _interrupt_after(0.3))
    assert not finished, "the level-10 mesh ended before the interrupt"
    assert latency < 0.5, f"{latency:.3f} s after the interrupt"
    print(f"Ctrl-C latency: {latency * 1e3:.1f} ms")
    assert _os_threads() <= before
    # The surface is still usable afterwards.
    assert s.mesh(level=4).stats["triangles"] > 0


@pytest.mark.parametrize("stage", ["polygonize", "smooth"])
def test_ctrl_c_interrupts_extraction_and_smoothing(stage):
    """Ctrl-C sent when a stage starts (from the progress callback) stops
    that stage: each polls the cancel token inside its loops, not only
    between stages. A gyroid of 0.4 M triangles here spends about 0.8 s
    in extraction and 1.3 s in smoothing."""
    g = isoc.sin(isoc.x) * isoc.cos(isoc.y) + isoc.sin(isoc.y) * isoc.cos(isoc.z) + isoc.sin(isoc.z) * isoc.cos(isoc.x)
    s = isoc.compile(g, domain=(-15.7, 15.7))
    sent = []

    def progress(name, level, cells):
        if name == stage and not sent:
            sent.append(time.perf_counter())
            _thread.interrupt_main()

    latency = _interrupt_latency(lambda: s.mesh(level=6, progress=progress), sent)
    print(f"Ctrl-C in {stage}: {latency * 1e3:.1f} ms")
    assert latency < 0.5, f"{latency:.3f} s after the interrupt in {stage}"


def test_some_corpus_meshes_are_guaranteed():
    """The topology check above is not vacuous."""
    for name in ("torus.iso", "sphere.iso"):
        m = isoc.load(ROOT / "corpus" / name).mesh(level=6, smooth=0)
        assert m.guaranteed, name


@pytest.mark.parametrize("edge,first", [(0.0064, True), (0.16, False)], ids=["first-frame", "later-frame"])
def test_ctrl_c_interrupts_an_animation(edge, first):
    """Ctrl-C stops the tracker inside a frame (the first one of a fine
    tracker takes minutes here: its robust mesh has millions of triangles
    and its remeshing sweeps are cancelled) and leaves no thread behind."""
    s = isoc.load(ROOT / "corpus" / "blobs_pass.iso")
    before = _threads_after_warm_up(s)
    frames = []

    def work():
        for m in s.animate(0.0, 1.0, 10_000, edge=edge):
            frames.append(len(m.faces))

    latency = _interrupt_latency(work, _interrupt_after(0.3))
    assert latency < 0.5, f"{latency:.3f} s after the interrupt"
    assert (len(frames) == 0) == first, len(frames)
    print(f"animation Ctrl-C latency: {latency * 1e3:.1f} ms after {len(frames)} frame(s)")
    # The worker has ended (closed and joined when the interrupt arrived).
    assert _os_threads() <= before
