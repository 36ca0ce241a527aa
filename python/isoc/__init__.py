"""isoc — implicit surfaces: sound evaluation and robust adaptive meshes.

A thin numpy layer over the isoc Rust library. Compile a surface from
``.iso`` text, a Fidget ``.vm`` model or a Python expression, evaluate it on
arrays of points (JIT kernels, GIL released), enclose it on boxes (interval
arithmetic with outward rounding), mesh it with the robust adaptive mesher
and save the mesh (PLY, OBJ, STL, GLB, 3MF).

Examples
--------
>>> import isoc
>>> from isoc import x, y, z
>>> s = isoc.compile(x**2 + y**2 + z**2 - 1, domain=(-1.5, 1.5))
>>> float(s.eval([[1.0, 0.0, 0.0]])[0])
0.0
>>> m = s.mesh(level=5)
>>> m.stats["watertight"], m.stats["genus"]
(True, [0])
"""

from __future__ import annotations

import json
import math
import numbers
import os
import re
from typing import Any, Callable, Iterator, NamedTuple, Optional, Sequence, Union

import numpy as np

__all__ = [
    "CompileError",
    "Enclosure",
    "Expr",
    "GradEnclosure",
    "Mesh",
    "Surface",
    "abs",
    "acos",
    "asin",
    "atan",
    "atan2",
    "compile",
    "cos",
    "exp",
    "load",
    "log",
    "max",
    "min",
    "param",
    "pi",
    "pow",
    "sin",
    "sqrt",
    "t",
    "tan",
    "x",
    "y",
    "z",
]

_builtin_abs = abs
_builtin_min = min
_builtin_max = max


class CompileError(ValueError):
    """A source that does not compile.

    Attributes
    ----------
    message : str
        The first problem, without location (e.g. ``unknown name `w```).
    line, column : int or None
        1-based location of the first problem in the source (``None`` for
        errors that are not about the text, e.g. an unknown param).
    rendered : str
        Every problem as ``FILE:LINE:COL: error: MESSAGE`` with the source
        line and a caret under the spot; this is ``str(err)``.
    """

    def __init__(
        self,
        rendered: str,
        message: str,
        line: Optional[int] = None,
        column: Optional[int] = None,
    ) -> None:
        super().__init__(rendered)
        self.rendered = rendered
        self.message = message
        self.line = line
        self.column = column

    def __str__(self) -> str:
        return self.rendered


from . import _isoc  # noqa: E402  (CompileError must exist first)

# ---------------------------------------------------------------------------
# The expression builder.

# Precedence of the .iso operators (higher binds tighter).
_ADD, _MUL, _NEG, _POW, _ATOM = 1, 2, 3, 4, 5


def _number_text(v: Any) -> str:
    if isinstance(v, (bool, np.bool_)):
        raise TypeError("booleans are not numbers in an isoc expression")
    if isinstance(v, numbers.Integral):
        return str(int(v))
    f = float(v)
    if not math.isfinite(f):
        raise ValueError(f"an isoc expression holds finite numbers only, got {f!r}")
    return repr(f)


class Expr:
    """An expression in ``x, y, z, t`` built with Python operators.

    ``+ - * / **``, unary ``-``, ``abs()`` and the functions of this module
    (``isoc.sqrt``, ``isoc.min``, …) build ``.iso`` text; Python numbers and
    numpy scalars mix in freely, and :func:`param` names a value to set at
    compile time. ``str(expr)`` is the text, ``expr.params`` the params it
    uses with their defaults, and ``isoc.compile(expr, domain=...)``
    compiles it (to the same IR as the same formula written in a ``.iso``
    file with those ``param`` lines).

    Examples
    --------
    >>> from isoc import x, y, z
    >>> str((x**2 + y**2 + z**2) ** 0.5 - 1)
    '(x^2 + y^2 + z^2)^0.5 - 1'
    >>> r = isoc.param("r", 1.0)
    >>> (x**2 + y**2 + z**2 - r**2).params
    {'r': 1.0}
    """

    __slots__ = ("_text", "_prec", "_params")
    # Make numpy scalars and arrays defer to Expr's reflected operators.
    __array_ufunc__ = None

    def __init__(self, text: str, prec: int = _ATOM, params: Sequence[tuple[str, float]] = ()) -> None:
        self._text = text
        self._prec = prec
        self._params = tuple(sorted(params))

    @property
    def params(self) -> dict:
        """The params the expression uses, with their default values."""
        return dict(self._params)

    def __str__(self) -> str:
        return self._text

    def __repr__(self) -> str:
        return f"isoc.Expr({self._text!r})"

    def __bool__(self) -> bool:
        raise TypeError("an isoc expression has no truth value (use isoc.min/isoc.max for CSG)")

    def __hash__(self) -> int:
        return hash(self._text)

    def _wrap(self, prec: int) -> str:
        return f"({self._text})" if self._prec < prec else self._text

    @staticmethod
    def lift(v: Any) -> "Expr":
        """An expression from an ``Expr`` or a real number (numpy scalars too)."""
        if isinstance(v, Expr):
            return v
        if isinstance(v, (numbers.Real, np.integer, np.floating)) and not isinstance(
            v, (bool, np.bool_)
        ):
            s = _number_text(v)
            return Expr(s, _NEG if s.startswith("-") else _ATOM)
        raise TypeError(f"cannot use {type(v).__name__} in an isoc expression")

    def _bin(self, other: Any, op: str, prec: int, reflected: bool = False) -> "Expr":
        try:
            o = Expr.lift(other)
        except TypeError:
            return NotImplemented
        a, b = (o, self) if reflected else (self, o)
        # Left-associative: the right operand of - and / needs parentheses at
        # equal precedence.
        right = prec + 1 if op in ("-", "/") else prec
        return Expr(f"{a._wrap(prec)} {op} {b._wrap(right)}", prec, _merged(a, b))

    def __add__(self, o: Any) -> "Expr":
        return self._bin(o, "+", _ADD)

    def __radd__(self, o: Any) -> "Expr":
        return self._bin(o, "+", _ADD, True)

    def __sub__(self, o: Any) -> "Expr":
        return self._bin(o, "-", _ADD)

    def __rsub__(self, o: Any) -> "Expr":
        return self._bin(o, "-", _ADD, True)

    def __mul__(self, o: Any) -> "Expr":
        return self._bin(o, "*", _MUL)

    def __rmul__(self, o: Any) -> "Expr":
        return self._bin(o, "*", _MUL, True)

    def __truediv__(self, o: Any) -> "Expr":
        return self._bin(o, "/", _MUL)

    def __rtruediv__(self, o: Any) -> "Expr":
        return self._bin(o, "/", _MUL, True)

    def _power(self, base: "Expr", exp: "Expr") -> "Expr":
        # ^ is right-associative and binds tighter than unary minus.
        return Expr(f"{base._wrap(_POW + 1)}^{exp._wrap(_POW)}", _POW, _merged(base, exp))

    def __pow__(self, o: Any) -> "Expr":
        try:
            return self._power(self, Expr.lift(o))
        except TypeError:
            return NotImplemented

    def __rpow__(self, o: Any) -> "Expr":
        try:
            return self._power(Expr.lift(o), self)
        except TypeError:
            return NotImplemented

    def __neg__(self) -> "Expr":
        return Expr(f"-{self._wrap(_NEG)}", _NEG, self._params)

    def __pos__(self) -> "Expr":
        return self

    def __abs__(self) -> "Expr":
        return _call("abs", self)


def _merged(*exprs: Expr) -> tuple:
    """The params of several expressions; one name, one default."""
    seen: dict = {}
    for e in exprs:
        for name, value in e._params:
            if seen.get(name, value) != value:
                raise ValueError(f"param {name!r} has two defaults, {seen[name]!r} and {value!r}")
            seen[name] = value
    return tuple(seen.items())


def _call(name: str, *args: Any) -> Expr:
    lifted = [Expr.lift(a) for a in args]
    return Expr(f"{name}({', '.join(a._text for a in lifted)})", _ATOM, _merged(*lifted))


_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_RESERVED = {"x", "y", "z", "t", "pi", "domain", "let", "param", "fn", "surface"}


def param(name: str, default: Any) -> Expr:
    """A named parameter: a number chosen when the expression is compiled.

    The expression compiles to ``.iso`` text with a ``param name =
    default;`` line, so ``isoc.compile(expr, params={name: value})`` and
    ``Surface.params`` work as for a ``.iso`` file's params.

    Parameters
    ----------
    name : str
        An identifier (letters, digits, ``_``; not ``x, y, z, t, pi`` nor a
        keyword).
    default : float
        Its value unless the compile call overrides it (finite).

    Returns
    -------
    Expr

    Raises
    ------
    ValueError
        A name that is not an identifier or is reserved, or a default that
        is not finite.

    Examples
    --------
    >>> from isoc import x, y, z
    >>> r = isoc.param("r", 1)
    >>> s = isoc.compile(x**2 + y**2 + z**2 - r**2, domain=(-2, 2), params={"r": 1.5})
    >>> s.params
    {'r': 1.5}
    """
    if not isinstance(name, str) or not _IDENT.match(name) or name in _RESERVED:
        raise ValueError(f"a param's name must be an identifier other than x, y, z, t, pi and the keywords, got {name!r}")
    value = float(_number_text(default))
    return Expr(name, _ATOM, ((name, value),))


x = Expr("x")
"""The coordinate x."""
y = Expr("y")
"""The coordinate y."""
z = Expr("z")
"""The coordinate z."""
t = Expr("t")
"""Time (0 unless meshed at another ``t`` or animated)."""
pi = Expr("pi")
"""π (the .iso constant, enclosed soundly)."""


def sqrt(a: Any) -> Expr:
    """√a (an expression); NaN where a < 0."""
    return _call("sqrt", a)


def exp(a: Any) -> Expr:
    """eᵃ (an expression)."""
    return _call("exp", a)


def log(a: Any) -> Expr:
    """Natural logarithm (an expression); NaN where a ≤ 0."""
    return _call("log", a)


def sin(a: Any) -> Expr:
    """sin a (an expression)."""
    return _call("sin", a)


def cos(a: Any) -> Expr:
    """cos a (an expression)."""
    return _call("cos", a)


def tan(a: Any) -> Expr:
    """tan a (an expression)."""
    return _call("tan", a)


def asin(a: Any) -> Expr:
    """arcsin a (an expression)."""
    return _call("asin", a)


def acos(a: Any) -> Expr:
    """arccos a (an expression)."""
    return _call("acos", a)


def atan(a: Any) -> Expr:
    """arctan a (an expression)."""
    return _call("atan", a)


def atan2(a: Any, b: Any) -> Expr:
    """atan2(a, b), the angle of the point (b, a) (an expression)."""
    return _call("atan2", a, b)


def pow(a: Any, b: Any) -> Expr:  # noqa: A001 (the .iso function)
    """aᵇ (an expression), as ``a ** b``."""
    return _call("pow", a, b)


def abs(a: Any) -> Any:  # noqa: A001
    """|a|: an expression for an expression, else the builtin ``abs``."""
    if isinstance(a, Expr):
        return _call("abs", a)
    return _builtin_abs(a)


def min(*args: Any) -> Any:  # noqa: A001
    """Minimum of two or more values (CSG union); the builtin for non-expressions."""
    if any(isinstance(a, Expr) for a in args):
        if len(args) < 2:
            raise TypeError("isoc.min takes two or more arguments")
        return _call("min", *args)
    return _builtin_min(*args)


def max(*args: Any) -> Any:  # noqa: A001
    """Maximum of two or more values (CSG intersection); the builtin for non-expressions."""
    if any(isinstance(a, Expr) for a in args):
        if len(args) < 2:
            raise TypeError("isoc.max takes two or more arguments")
        return _call("max", *args)
    return _builtin_max(*args)


# ---------------------------------------------------------------------------
# Arrays.


def _float_array(a: Any, what: str) -> np.ndarray:
    """``a`` as a C-contiguous float64 array (no copy when it already is)."""
    arr = np.asarray(a)
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{what} must hold real numbers, got dtype {arr.dtype}")
    return np.ascontiguousarray(arr, dtype=np.float64)


def _points(points: Any, what: str = "points") -> tuple[np.ndarray, bool]:
    """Points as an ``(N, 3|4)`` array, and whether one point was given."""
    arr = _float_array(points, what)
    single = arr.ndim == 1
    if single:
        arr = arr.reshape(1, -1)
    if arr.ndim != 2 or arr.shape[1] not in (3, 4):
        raise ValueError(f"{what} must have shape (N, 3) or (N, 4) (x, y, z[, t]); got {np.shape(points)}")
    return arr, single


def _domain(domain: Any) -> Optional[list[float]]:
    """A domain as six numbers ``[a, b, c, d, e, f]``."""
    if domain is None:
        return None
    d = np.asarray(domain, dtype=np.float64).ravel()
    if d.size == 2:
        d = np.tile(d, 3)
    if d.size != 6:
        raise ValueError(
            "domain must be (a, b) for [a, b]^3, or six numbers a, b, c, d, e, f "
            f"for [a, b] x [c, d] x [e, f]; got {domain!r}"
        )
    if not np.all(np.isfinite(d)) or np.any(d[0::2] >= d[1::2]):
        raise ValueError(f"domain {d.tolist()}: every side must be finite and non-empty (a < b)")
    return [float(v) for v in d]


class Enclosure(NamedTuple):
    """An enclosure of f over a box (or arrays of them, one per box).

    Attributes
    ----------
    lo, hi : float or ndarray
        Bounds of f over the part of the box where f is defined (outward
        rounded: the true range is inside).
    defined : bool or ndarray of bool
        True when f is defined and continuous on the whole box; False when
        the box leaves f's domain (``sqrt`` of a negative, ``log`` of a
        non-positive, a division by zero), and then the bounds are those of
        the defined part.
    """

    lo: Any
    hi: Any
    defined: Any


class GradEnclosure(NamedTuple):
    """Enclosures of f and of its gradient over a box (``interval(..., grad=True)``).

    Attributes
    ----------
    lo, hi, defined
        As in :class:`Enclosure`.
    grad : ndarray
        ``(3, 2)`` (or ``(N, 3, 2)``): ``[lo, hi]`` of ∂f/∂x, ∂f/∂y, ∂f/∂z.
    """

    lo: Any
    hi: Any
    defined: Any
    grad: Any


# ---------------------------------------------------------------------------
# Meshes.


class Mesh:
    """A triangle mesh made by :meth:`Surface.mesh` or :meth:`Surface.animate`.

    Attributes
    ----------
    vertices : ndarray, shape (V, 3), float64
        Vertex positions (on the surface to bisection precision).
    faces : ndarray, shape (F, 3), uint32
        Triangles as vertex indices, counter-clockwise seen from outside
        (the side where f > 0).
    normals : ndarray, shape (V, 3), float64
        Unit normals (direction of ∇f) per vertex.
    ambiguous : ndarray, shape (V,), bool
        Per vertex, whether it lies in a cell whose topology is not
        guaranteed.
    stats : dict
        The statistics object of ``isoc mesh --stats json`` (triangles,
        vertices, components, euler, genus, watertight, manifold,
        guaranteed, timings_ms, …); for animation frames, the topology and
        the frame's report under ``"frame"``.
    """

    def __init__(self, core: Any) -> None:
        self._core = core
        self.vertices, self.faces, self.normals, self.ambiguous = core.arrays()
        self.stats: dict = json.loads(core.stats)

    @property
    def guaranteed(self) -> Optional[bool]:
        """True when no octree leaf was left ambiguous (the mesh's topology is
        the surface's); ``None`` for animation frames."""
        return self.stats.get("guaranteed")

    def __len__(self) -> int:
        return len(self.faces)

    def __repr__(self) -> str:
        return f"<isoc.Mesh: {len(self.vertices)} vertices, {len(self.faces)} triangles>"

    def save(self, path: Union[str, "os.PathLike[str]"], *, unit: str = "millimeter") -> None:
        """Write the mesh; the format follows the extension.

        Parameters
        ----------
        path : str or path-like
            ``.ply`` (binary, with normals and green/red ambiguity colours),
            ``.obj``, ``.stl`` (binary), ``.glb`` or ``.3mf``. The file is
            written atomically (no partial file on error).
        unit : str, optional
            Unit of one domain unit in a ``.3mf`` file: ``micron``,
            ``millimeter`` (default), ``centimeter``, ``inch``, ``foot`` or
            ``meter``. Other formats carry no unit.

        Raises
        ------
        ValueError
            Unknown extension or unit.
        OSError
            The file could not be written.
        """
        self._core.save(os.fspath(path), unit)

    def to_trimesh(self) -> Any:
        """The mesh as a ``trimesh.Trimesh`` (needs the optional ``trimesh``
        package); vertices, faces and vertex normals are copied, nothing is
        merged or reordered."""
        try:
            import trimesh
        except ImportError as e:  # pragma: no cover - depends on the environment
            raise ImportError("Mesh.to_trimesh needs trimesh: pip install trimesh") from e
        return trimesh.Trimesh(
            vertices=self.vertices.copy(),
            faces=self.faces.astype(np.int64),
            vertex_normals=self.normals.copy(),
            process=False,
        )


# ---------------------------------------------------------------------------
# Surfaces.


def _tqdm_progress() -> Optional[Callable[[str, Optional[int], Optional[int]], None]]:
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return None
    bar = tqdm(total=None, desc="isoc mesh", leave=False)

    def report(stage: str, level: Optional[int], cells: Optional[int]) -> None:
        bar.set_postfix_str(f"{stage} level {level}, {cells} cells" if level is not None else stage)
        bar.update(1)
        if stage == "smooth":
            bar.close()

    return report


class Surface:
    """A compiled implicit surface f(x, y, z[, t]) = 0 over a box domain.

    Made by :func:`isoc.compile` or :func:`isoc.load`. ``str(surface)`` is
    its ``.iso`` source (or the ``.vm`` model's text).

    Attributes
    ----------
    source : str
        The source text.
    ir : str
        The simplified SSA program (what ``isoc compile --emit ir`` prints).
    domain : tuple of float
        ``(a, b, c, d, e, f)``: the domain [a, b] × [c, d] × [e, f].
    params : dict
        The values of the file's ``param``s (after overrides).
    """

    def __init__(self, core: Any, source: str) -> None:
        self._core = core
        self.source = source

    def __str__(self) -> str:
        return self.source

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        # Pickled as what compiles it again (for processes and clusters).
        return (_recompile, (self.source, self._core.file, self.domain, self.params))

    def __repr__(self) -> str:
        return f"<isoc.Surface {self._core.file!r} domain={self.domain}>"

    @property
    def ir(self) -> str:
        return self._core.ir

    @property
    def domain(self) -> tuple:
        return tuple(self._core.domain)

    @property
    def params(self) -> dict:
        return dict(self._core.params)

    def eval(self, points: Any) -> Any:
        """Evaluate f at points (JIT point kernel, batched, GIL released).

        Parameters
        ----------
        points : array_like, shape (N, 3) or (N, 4)
            Rows ``x, y, z`` (t = 0) or ``x, y, z, t``. A C-contiguous
            float64 array is read in place; other real arrays are converted.
            A single point of shape (3,) or (4,) gives a float.

        Returns
        -------
        ndarray, shape (N,)
            f at each point (NaN outside f's domain).

        Raises
        ------
        TypeError
            Not an array of real numbers.
        ValueError
            Wrong shape.
        """
        arr, single = _points(points)
        out = self._core.eval(arr)
        return float(out[0]) if single else out

    def grad(self, points: Any, *, value: bool = False) -> Any:
        """Gradient ∇f at points (forward-mode AD in the JIT, GIL released).

        Parameters
        ----------
        points : array_like, shape (N, 3) or (N, 4)
            As in :meth:`eval`.
        value : bool, optional
            Also return f (default False).

        Returns
        -------
        ndarray, shape (N, 3)
            ``(∂f/∂x, ∂f/∂y, ∂f/∂z)`` per point (NaN where f has no
            derivative); with ``value=True``, ``(values (N,), gradients)``.
        """
        arr, single = _points(points)
        vals, grads = self._core.grad(arr)
        if single:
            vals, grads = float(vals[0]), grads[0]
        return (vals, grads) if value else grads

    def interval(self, lo: Any, hi: Any, *, grad: bool = False) -> Union[Enclosure, GradEnclosure]:
        """Enclose f over boxes (sound interval arithmetic, outward rounded).

        Parameters
        ----------
        lo, hi : array_like, shape (3,), (4,), (N, 3) or (N, 4)
            Lower and upper corners of one box or of N boxes (``t`` as a
            fourth side, else t = 0). Each side must satisfy lo ≤ hi; NaN is
            refused.
        grad : bool, optional
            Also enclose the gradient (interval-gradient kernel).

        Returns
        -------
        Enclosure or GradEnclosure
            ``(lo, hi, defined)`` (and ``grad``): floats for one box, arrays
            for N boxes. ``defined`` is False where the box leaves f's
            domain.

        Raises
        ------
        ValueError
            Wrong or different shapes, NaN, an inverted side.
        TypeError
            Not arrays of real numbers.
        """
        a, single = _points(lo, "lo")
        b, single_b = _points(hi, "hi")
        if single != single_b or a.shape != b.shape:
            raise ValueError(f"lo and hi must have the same shape; got {np.shape(lo)} and {np.shape(hi)}")
        r = self._core.interval(a, b, grad)
        if single:
            r = tuple(v[0] for v in r)
            r = (float(r[0]), float(r[1]), bool(r[2])) + tuple(r[3:])
        return GradEnclosure(*r) if grad else Enclosure(*r)

    def mesh(
        self,
        level: Optional[int] = None,
        tolerance: Optional[float] = None,
        kmax: Optional[float] = None,
        smooth: int = 3,
        creases: bool = True,
        threads: Optional[int] = None,
        *,
        coarse: bool = False,
        min_level: int = 3,
        certify: bool = False,
        prune: bool = True,
        t: float = 0.0,
        domain: Any = None,
        progress: Union[None, bool, Callable[[str, Optional[int], Optional[int]], Any]] = None,
        bricks: Optional[int] = None,
    ) -> Mesh:
        """Mesh f = 0 with the robust adaptive mesher (``isoc mesh``).

        Parameters
        ----------
        level : int, optional
            Maximal octree level (2^level cells per axis at most); default
            7, or 10 when `tolerance` is given. Alone, it is faithful: the
            chord error stays within about 3.5 % of a level cell (as
            ``isoc mesh --level``).
        tolerance : float, optional
            Refine until every measured triangle point lies within this
            distance (domain units) of the surface, `level` being the cap.
        kmax : float, optional
            Geometry criterion: subdivide while the normals' spread exceeds
            it (1.0 when not given; 0 refines uniformly). Given, it replaces
            the faithful default, as `coarse` does.
        smooth : int, optional
            Smoothing passes: edge flips and tangential relaxation onto the
            surface (default 3).
        creases : bool, optional
            Put vertices on sharp creases (CSG edges and corners); default
            True.
        threads : int, optional
            Worker threads (a local pool); default: all cores.
        coarse : bool, optional
            The adaptive minimum: the paper's topology and geometry criteria
            only, without the faithful chord criterion (``--coarse``);
            default False.
        min_level : int, optional
            Uniform subdivision level to start from (default 3).
        certify : bool, optional
            Stricter topology test (Plantinga–Vegter); default False.
        prune : bool, optional
            Per-cell pruning of min/max branches (default True).
        t : float, optional
            Time at which a surface in t is meshed (default 0).
        domain : sequence of float, optional
            ``(a, b)`` or ``(a, b, c, d, e, f)``; default the surface's.
        progress : callable or bool, optional
            Called from this thread as ``progress(stage, level, cells)``
            (``stage`` is ``"octree"``, ``"dual"``, ``"polygonize"`` or
            ``"smooth"``) while the mesher runs; ``True`` shows a ``tqdm``
            bar when tqdm is installed.
        bricks : int, optional
            Mesh the domain as ``8**bricks`` bricks in parallel and weld
            them (``--bricks``; at most 6): the same mesh as without bricks
            with ``smooth=0, creases=False``, closed and 2-manifold across
            the seams otherwise. Not with `tolerance`. See
            :func:`isoc.dask.mesh` to spread the bricks over a cluster.

        Returns
        -------
        Mesh
            The mesh, with ``stats`` the ``--stats json`` object.

        Raises
        ------
        ValueError
            A bad option.
        KeyboardInterrupt
            Ctrl-C (or any signal handler raising) while meshing: the
            mesher stops at its next checkpoint (within milliseconds).

        Examples
        --------
        >>> import isoc
        >>> torus = isoc.compile("domain [-2, 2]^3; surface (sqrt(x^2 + y^2) - 1)^2 + z^2 = 0.1;")
        >>> m = torus.mesh(level=6)
        >>> m.stats["genus"], m.guaranteed
        ([1], True)
        """
        if progress is True:
            progress = _tqdm_progress()
        elif progress is False:
            progress = None
        if level is None:
            level = 10 if tolerance is not None else 7
        options = _options(level, tolerance, kmax, coarse, min_level, smooth, creases, certify, prune, t, domain)
        bricks = None if bricks is None else _brick_level(bricks)
        core = self._core.mesh(options, None if threads is None else int(threads), progress, bricks)
        return Mesh(core)

    def animate(
        self,
        t0: float,
        t1: float,
        frames: int,
        edge: Optional[float] = None,
        alpha: Optional[float] = None,
        *,
        passes: Optional[int] = None,
    ) -> Iterator[Mesh]:
        """Track the moving surface f(·, t) = 0 with twinned meshes (``isoc animate``).

        Parameters
        ----------
        t0, t1 : float
            First and last time.
        frames : int
            Number of frames; frame k is at ``t0 + (t1 - t0) * k / (frames - 1)``.
        edge : float, optional
            Target mechanical edge length (default: the domain's largest
            side / 40).
        alpha : float, optional
            Refinement angle α_r in degrees (−180 disables refinement).
        passes : int, optional
            Most refinement passes per frame.

        Yields
        ------
        Mesh
            The geometric (refined) mesh of each frame; ``stats["frame"]``
            is the frame's report (as in ``stats.json`` of ``isoc animate``).
        """
        frames = int(frames)
        if frames < 1:
            raise ValueError("frames must be at least 1")
        anim = _isoc.CoreAnimation(
            self._core,
            float(t0),
            None if edge is None else float(edge),
            None if alpha is None else float(alpha),
            None if passes is None else int(passes),
        )
        try:
            for k in range(frames):
                tk = t0 if frames == 1 else t0 + (t1 - t0) * k / (frames - 1)
                yield Mesh(anim.next_frame(float(tk)))
        finally:
            anim.close()


def _source_of(source: Union[str, Expr], domain: Optional[list[float]]) -> tuple[str, Optional[list[float]]]:
    if isinstance(source, Expr):
        d = domain if domain is not None else [-1.0, 1.0] * 3
        params = "".join(f"param {n} = {v!r};\n" for n, v in source._params)
        text = (
            f"domain [{d[0]!r}, {d[1]!r}], [{d[2]!r}, {d[3]!r}], [{d[4]!r}, {d[5]!r}];\n"
            f"{params}surface {source};\n"
        )
        return text, None
    if isinstance(source, str):
        return source, domain
    raise TypeError(f"compile takes .iso text or an isoc expression, not {type(source).__name__}")


def compile(  # noqa: A001 (the package's verb)
    source: Union[str, Expr],
    *,
    domain: Any = None,
    params: Optional[dict] = None,
    file: str = "<string>.iso",
) -> Surface:
    """Compile a surface from ``.iso`` text or an expression.

    Parameters
    ----------
    source : str or Expr
        ``.iso`` source text, or an expression built from ``isoc.x, y, z, t``
        (its surface is ``expr = 0``).
    domain : sequence of float, optional
        ``(a, b)`` for [a, b]³ or ``(a, b, c, d, e, f)``; replaces the
        file's ``domain``. An expression's default is [-1, 1]³.
    params : dict, optional
        Overrides of the ``param`` values of the file or of the expression
        (:func:`param`), ``{"r": 1.5}``.
    file : str, optional
        Name used in error messages (a name ending in ``.vm`` reads a
        Fidget model).

    Returns
    -------
    Surface

    Raises
    ------
    CompileError
        The source does not compile (``.line``, ``.column``, ``.message``;
        ``str(err)`` is the rendered diagnostic with a caret).
    ValueError
        A bad domain.

    Examples
    --------
    >>> import isoc
    >>> s = isoc.compile("domain [-2, 2]^3; param r = 1; surface x^2 + y^2 + z^2 = r^2;", params={"r": 1.5})
    >>> s.params
    {'r': 1.5}
    """
    d = _domain(domain)
    text, d = _source_of(source, d)
    p = [(str(k), float(v)) for k, v in (params or {}).items()]
    core = _isoc.CoreSurface.compile(text, file, d, p)
    return Surface(core, text)


def _options(level: int, tolerance: Optional[float], kmax: Optional[float], coarse: bool, min_level: int,
             smooth: int, creases: bool, certify: bool, prune: bool, t: float, domain: Any) -> dict:
    """`Surface.mesh`'s options as the core takes them (typed; checked there)."""
    return {
        "level": int(level),
        "tolerance": None if tolerance is None else float(tolerance),
        "kmax": None if kmax is None else float(kmax),
        "coarse": bool(coarse),
        "min_level": int(min_level),
        "smooth": int(smooth),
        "creases": bool(creases),
        "certify": bool(certify),
        "prune": bool(prune),
        "t": float(t),
        "domain": _domain(domain),
    }


def _recompile(source: str, file: str, domain: Sequence[float], params: dict) -> Surface:
    """A pickled :class:`Surface` compiled again."""
    return compile(source, domain=list(domain), params=dict(params), file=file)


def _brick_level(bricks: Any) -> int:
    """`bricks` checked: an int in 0..=6."""
    if isinstance(bricks, bool) or not isinstance(bricks, numbers.Integral):
        raise TypeError(f"bricks must be an int, not {type(bricks).__name__}")
    if not 0 <= int(bricks) <= 6:
        raise ValueError(f"bricks={bricks}: must be 0 to 6 (8**bricks bricks)")
    return int(bricks)


def load(path: Union[str, "os.PathLike[str]"], *, domain: Any = None, params: Optional[dict] = None) -> Surface:
    """Compile a ``.iso`` file or a Fidget ``.vm`` model (by its extension).

    Parameters
    ----------
    path : str or path-like
        The file.
    domain, params
        As in :func:`compile`.

    Returns
    -------
    Surface

    Raises
    ------
    CompileError
        The file does not compile (the diagnostics name the file).
    OSError
        The file cannot be read.
    """
    name = os.fspath(path)
    with open(name, "rb") as f:
        text = f.read().decode("utf-8", errors="replace")
    return compile(text, domain=domain, params=params, file=name)
