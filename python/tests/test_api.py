"""Compile errors, eval/grad/interval against the CLI, bad arrays, speed."""

import json
import subprocess
import time

import numpy as np
import pytest

import isoc
from conftest import CORPUS, ROOT


def cli_json(isoc_bin, *args):
    out = subprocess.run([isoc_bin, "eval", *map(str, args), "--json"], check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out)


def num(v):
    return float("nan") if v is None else v


# -- compile errors ---------------------------------------------------------

def test_compile_error_has_location_and_caret():
    src = "domain [-1, 1]^3;\nsurface x^2 + w = 1;\n"
    with pytest.raises(isoc.CompileError) as info:
        isoc.compile(src, file="bad.iso")
    e = info.value
    assert (e.line, e.column) == (2, 15)
    assert "w" in e.message
    text = str(e)
    assert text.startswith("bad.iso:2:15: error:")
    assert "surface x^2 + w = 1;" in text and "^" in text
    assert isinstance(e, ValueError)


def test_compile_error_from_file(tmp_path):
    p = tmp_path / "broken.iso"
    p.write_text("domain [-1, 1]^3;\nsurface x^2 +;\n")
    with pytest.raises(isoc.CompileError) as info:
        isoc.load(p)
    assert info.value.line == 2 and str(p) in str(info.value)


def test_unknown_param_is_a_compile_error():
    with pytest.raises(isoc.CompileError) as info:
        isoc.compile("domain [-1,1]^3; param r = 1; surface x^2 - r;", params={"q": 2})
    assert info.value.line is None and "q" in info.value.message


def test_vm_model_loads():
    models = sorted((ROOT.parent / "shared" / "models").glob("*.vm"))
    src = "_0 var-x\n_1 var-y\n_2 var-z\n_3 square _0\n_4 square _1\n_5 add _3 _4\n_6 square _2\n_7 add _5 _6\n_8 const 0.25\n_9 sub _7 _8\n"
    s = isoc.compile(src, file="ball.vm")
    assert s.domain == (-1.0, 1.0, -1.0, 1.0, -1.0, 1.0)
    assert s.eval([0.5, 0.0, 0.0]) == 0.0
    if models:
        assert isoc.load(models[0]).eval(np.zeros((2, 3))).shape == (2,)


def test_surface_prints_its_source():
    src = "domain [-1, 1]^3;\nsurface x^2 + y^2 + z^2 = 0.5;\n"
    s = isoc.compile(src)
    assert str(s) == src
    assert "domain" in repr(s)
    p = isoc.compile("domain [-1,1]^3; param r = 1; surface x - r;", params={"r": 0.5}).params
    assert p == {"r": 0.5}


# -- values against the CLI -------------------------------------------------

POINTS = [(0.3, -0.2, 0.1), (0.71, 0.05, -0.4), (-0.5, 0.5, 0.5)]


@pytest.mark.parametrize("path", CORPUS[::3], ids=lambda p: p.name)
def test_eval_and_grad_match_the_cli(path, isoc_bin):
    s = isoc.load(path)
    pts = np.array(POINTS)
    vals = s.eval(pts)
    grads = s.grad(pts)
    for p, v, g in zip(POINTS, vals, grads):
        j = cli_json(isoc_bin, path, *p)
        np.testing.assert_array_equal(v, num(j["value"]))
        np.testing.assert_array_equal(g, [num(c) for c in j["grad"]])


@pytest.mark.parametrize("path", CORPUS[1::4], ids=lambda p: p.name)
def test_interval_matches_the_cli(path, isoc_bin):
    s = isoc.load(path)
    lo, hi = np.array([0.1, -0.3, 0.0]), np.array([0.2, -0.1, 0.25])
    j = cli_json(isoc_bin, path, "--box", "0.1,0.2,-0.3,-0.1,0,0.25")
    e = s.interval(lo, hi, grad=True)
    assert (e.lo, e.hi) == (num(j["value"][0]), num(j["value"][1]))
    assert e.defined == j["defined"]
    np.testing.assert_array_equal(e.grad, [[num(a), num(b)] for a, b in j["grad"]])
    # The batch gives the same enclosures, and the plain interval kernel
    # encloses the same range (it may be tighter or looser, never wrong).
    many = s.interval(np.tile(lo, (5, 1)), np.tile(hi, (5, 1)))
    assert many.lo.shape == (5,) and many.defined.dtype == bool
    v = s.eval(np.random.default_rng(1).uniform(lo, hi, (200, 3)))
    v = v[~np.isnan(v)]
    assert np.all(many.lo[0] <= v) and np.all(v <= many.hi[0])


def test_time_column():
    s = isoc.compile("domain [-1,1]^3; surface x + t;")
    pts = np.array([[0.5, 0, 0, 0.0], [0.5, 0, 0, 1.0], [0.5, 0, 0, 1.0], [0.0, 0, 0, -2.0]])
    np.testing.assert_array_equal(s.eval(pts), [0.5, 1.5, 1.5, -2.0])
    np.testing.assert_array_equal(s.grad(pts)[:, 0], 1.0)
    e = s.interval([0, 0, 0, 1], [1, 0, 0, 2])
    assert (e.lo, e.hi, e.defined) == (1.0, 3.0, True)


def test_undefined_box_is_flagged():
    s = isoc.compile("domain [-1,1]^3; surface sqrt(x) - 0.5;")
    assert s.interval([-1, 0, 0], [1, 0, 0]).defined is False
    assert s.interval([0.5, 0, 0], [1, 0, 0]).defined is True
    assert np.isnan(s.eval([-1.0, 0, 0]))


# -- bad arrays -------------------------------------------------------------

def test_bad_arrays_raise():
    s = isoc.compile("domain [-1,1]^3; surface x^2 + y^2 + z^2 - 1;")
    with pytest.raises(ValueError):
        s.eval(np.zeros((4, 2)))
    with pytest.raises(ValueError):
        s.eval(np.zeros((2, 3, 3)))
    with pytest.raises(TypeError):
        s.eval(np.array([["a", "b", "c"]]))
    with pytest.raises(TypeError):
        s.eval(np.zeros((3, 3), dtype=complex))
    with pytest.raises(ValueError):
        s.interval([0, 0, np.nan], [1, 1, 1])
    with pytest.raises(ValueError):
        s.interval([1, 0, 0], [0, 1, 1])
    with pytest.raises(ValueError):
        s.interval(np.zeros((3, 3)), np.ones((4, 3)))
    with pytest.raises(ValueError):
        s.mesh(level=3, domain=(0, np.nan))
    with pytest.raises(ValueError):
        s.mesh(level=4, tolerance=-1.0)
    with pytest.raises(ValueError):
        isoc.compile("domain [-1,1]^3; surface x;", domain=(1, -1))
    # Empty input, non-contiguous and other dtypes are fine.
    assert s.eval(np.zeros((0, 3))).shape == (0,)
    a = np.asfortranarray(np.ones((5, 3), dtype=np.float32))
    np.testing.assert_array_equal(s.eval(a), 2.0)
    assert s.eval(np.ones((6, 3))[::2]).shape == (3,)


# -- speed ------------------------------------------------------------------

def test_a_million_points_in_under_a_second():
    s = isoc.load(ROOT / "corpus" / "heart.iso")
    pts = np.random.default_rng(0).uniform(-1.5, 1.5, (1_000_000, 3))
    s.eval(pts[:10])  # the point kernel compiles on first use
    t0 = time.perf_counter()
    v = s.eval(pts)
    dt = time.perf_counter() - t0
    assert v.shape == (1_000_000,)
    np.testing.assert_array_equal(v[:1000], [s.eval(p) for p in pts[:1000]])
    assert dt < 1.0, f"{dt:.3f} s"
