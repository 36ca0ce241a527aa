"""isoc.dask: bricks meshed on a 2-worker dask.distributed LocalCluster
equal the local bricked mesh exactly, streamed or not, and a worker lost
mid-run changes nothing."""

import os
import pickle

import numpy as np
import pytest

import isoc

distributed = pytest.importorskip("dask.distributed")
import isoc.dask  # noqa: E402  (after the skip: needs dask)

from conftest import ROOT  # noqa: E402

TWOTORUS = (ROOT / "corpus" / "twotorus.iso").read_text()

# Figures that do not depend on where or when the bricks ran.
FIGURES = ["triangles", "vertices", "components", "euler", "genus", "manifold", "watertight",
           "boundary_edges", "ambiguous_cells", "guaranteed", "octree_nodes", "dual_cells", "aspect_good"]


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=50)
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def same_mesh(a, b):
    assert np.array_equal(a.vertices, b.vertices)
    assert np.array_equal(a.faces, b.faces)
    assert np.array_equal(a.normals, b.normals)
    for k in FIGURES:
        assert a.stats[k] == b.stats[k], k


def test_surfaces_pickle_as_their_source():
    s = isoc.compile(TWOTORUS, params={}, domain=[-2, 2])
    r = pickle.loads(pickle.dumps(s))
    assert (r.source, r.domain, r.params, r.ir) == (s.source, s.domain, s.params, s.ir)


@pytest.mark.parametrize("smooth,creases", [(0, False), (3, True)])
def test_dask_mesh_is_the_local_bricked_mesh(client, smooth, creases):
    s = isoc.compile(TWOTORUS)
    local = s.mesh(level=5, bricks=1, smooth=smooth, creases=creases)
    remote = isoc.dask.mesh(s, level=5, bricks=1, client=client, smooth=smooth, creases=creases)
    same_mesh(remote, local)
    assert remote.stats["parts"] == 8 and remote.stats["bricks"] == 1
    if smooth == 0:
        whole = s.mesh(level=5, smooth=0, creases=False)
        assert sorted(map(tuple, np.sort(whole.faces, axis=1).tolist())) and \
            whole.stats["triangles"] == remote.stats["triangles"]
        key = lambda m: sorted(tuple(sorted(map(tuple, m.vertices[f].tolist()))) for f in m.faces)  # noqa: E731
        assert key(whole) == key(remote), "bricked with smoothing off is the whole mesh"


def test_dask_streams_to_a_file(client, tmp_path):
    s = isoc.compile(TWOTORUS)
    stats = isoc.dask.mesh(s, level=5, bricks=1, client=client, path=tmp_path / "d.ply")
    s.mesh(level=5, bricks=1).save(tmp_path / "l.ply")
    assert (tmp_path / "d.ply").read_bytes() == (tmp_path / "l.ply").read_bytes()
    assert stats["manifold"] and stats["triangles"] > 0
    assert sorted(os.listdir(tmp_path)) == ["d.ply", "l.ply"], "no temporary file left"


class _KillOnce(distributed.WorkerPlugin):
    """Kills its worker's process when the first brick task starts (once
    per cluster: a marker file says it happened)."""

    def __init__(self, marker):
        self.marker = marker

    def transition(self, key, start, finish, **kwargs):
        if finish == "executing" and "mesh_brick" in str(key) and not os.path.exists(self.marker):
            open(self.marker, "w").close()
            os._exit(1)


def test_a_killed_worker_changes_nothing(client, tmp_path):
    s = isoc.compile(TWOTORUS)
    local = s.mesh(level=5, bricks=1)
    marker = str(tmp_path / "killed")
    client.register_plugin(_KillOnce(marker), name="kill-once")
    try:
        remote = isoc.dask.mesh(s, level=5, bricks=1, client=client, smooth=3)
    finally:
        client.unregister_worker_plugin("kill-once")
    assert os.path.exists(marker), "a worker was killed mid-run"
    same_mesh(remote, local)


def test_bad_bricks_are_errors(client):
    s = isoc.compile(TWOTORUS)
    with pytest.raises(ValueError):
        isoc.dask.mesh(s, bricks=7, client=client)
    with pytest.raises(ValueError):
        s.mesh(level=5, bricks=1, tolerance=0.01)
    with pytest.raises(TypeError):
        s.mesh(level=5, bricks=1.5)
