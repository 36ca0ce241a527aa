"""The expression builder compiles to the same IR as the .iso text."""

import numpy as np
import pytest

import isoc
from isoc import t, x, y, z
from conftest import ROOT

CASES = [
    # (builder expression, the same formula as .iso text)
    (x**2 + y**2 + z**2 - 1, "x^2 + y^2 + z^2 - 1"),
    ((isoc.sqrt(x**2 + y**2) - 1) ** 2 + z**2 - 0.1, "(sqrt(x^2 + y^2) - 1)^2 + z^2 - 0.1"),
    ((2 * x**2 + y**2 + z**2 - 1) ** 3 - (0.1 * x**2 + y**2) * z**3,
     "(2*x^2 + y^2 + z^2 - 1)^3 - (0.1*x^2 + y^2)*z^3"),
    (isoc.min(x**2 + y**2 + z**2 - 0.5, isoc.max(abs(x), abs(y), abs(z)) - 0.6),
     "min(x^2 + y^2 + z^2 - 0.5, max(abs(x), abs(y), abs(z)) - 0.6)"),
    (-x**2 + 1 / (1 + y**2) - isoc.exp(-z) * isoc.sin(x - t) / 3,
     "-x^2 + 1/(1 + y^2) - exp(-z)*sin(x - t)/3"),
    (x - (y - z) - x / (y / 2), "x - (y - z) - x/(y/2)"),
    (isoc.atan2(y, x) + isoc.cos(z) * isoc.log(2 + x) - isoc.pow(y + 2, 0.5) + isoc.tan(isoc.acos(x / 2)) + isoc.asin(y / 3) + isoc.atan(z),
     "atan2(y, x) + cos(z)*log(2 + x) - pow(y + 2, 0.5) + tan(acos(x/2)) + asin(y/3) + atan(z)"),
    (np.float64(2.5) * x + np.int32(3) * y ** np.int64(2) + z ** -2, "2.5*x + 3*y^2 + z^(-2)"),
    (2 ** x - x ** 0.5 + isoc.pi * y, "2^x - x^0.5 + pi*y"),
]


@pytest.mark.parametrize("expr,text", CASES, ids=[c[1] for c in CASES])
def test_builder_is_the_iso_text(expr, text):
    built = isoc.compile(expr, domain=(-2, 2))
    written = isoc.compile(f"domain [-2, 2]^3;\nsurface {text};\n")
    assert built.ir == written.ir
    pts = np.random.default_rng(2).uniform(-2, 2, (64, 4))
    np.testing.assert_array_equal(built.eval(pts), written.eval(pts))
    # The surface prints its .iso source, which compiles to the same IR.
    assert isoc.compile(str(built)).ir == built.ir


def test_builder_matches_corpus_files():
    heart = isoc.load(ROOT / "corpus" / "heart.iso")
    a = 2 * x**2 + y**2 + z**2 - 1
    built = isoc.compile(a**3 - (0.1 * x**2 + y**2) * z**3, domain=(-1.5, 1.5))
    assert built.ir == heart.ir
    np.testing.assert_array_equal(built.eval(np.eye(3) * 0.7), heart.eval(np.eye(3) * 0.7))


def test_builder_refuses_nonsense():
    with pytest.raises(TypeError):
        x + "1"
    with pytest.raises(ValueError):
        x + float("nan")
    with pytest.raises(TypeError):
        bool(x < 1) if False else bool(x)
    with pytest.raises(TypeError):
        isoc.min(x)
    assert isoc.min(1, 2) == 1 and isoc.abs(-3) == 3
    with pytest.raises(ValueError):
        isoc.compile(x, params={"r": 1})


def test_params_of_an_expression_are_the_files_params():
    R, r = isoc.param("R", 1), isoc.param("r", 0.4)
    torus = (isoc.sqrt(x**2 + y**2) - R) ** 2 + z**2 - r**2
    assert torus.params == {"R": 1.0, "r": 0.4}
    assert "param R = 1.0;" in isoc._source_of(torus, None)[0]
    for overrides in (None, {"r": 0.3}, {"R": 1.2, "r": 0.25}):
        built = isoc.compile(torus, domain=(-1.6, 1.6), params=overrides)
        written = isoc.load(ROOT / "corpus" / "torus.iso", params=overrides)
        assert built.ir == written.ir, overrides
        assert built.params == written.params
        pts = np.random.default_rng(3).uniform(-1.6, 1.6, (64, 3))
        np.testing.assert_array_equal(built.eval(pts), written.eval(pts))
    # The source prints the param lines and compiles to the same IR.
    s = isoc.compile(torus, domain=(-1.6, 1.6), params={"r": 0.3})
    assert isoc.compile(str(s), params={"r": 0.3}).ir == s.ir


def test_params_refuse_nonsense():
    for name in ("x", "pi", "surface", "2r", "r-1", "", 3):
        with pytest.raises(ValueError):
            isoc.param(name, 1.0)
    with pytest.raises(ValueError):
        isoc.param("r", float("inf"))
    with pytest.raises(ValueError):
        isoc.param("r", 1) + isoc.param("r", 2)
    # One name with one default, used twice, is one param.
    r = isoc.param("r", 2)
    assert (r * x + isoc.sin(r)).params == {"r": 2.0}
    with pytest.raises(ValueError):
        isoc.compile(x + r, params={"q": 1})
