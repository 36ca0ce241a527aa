//! Interval arithmetic with outward rounding: the soundness core of isoc.
//!
//! # Contract
//!
//! For every operation `op` and intervals `a` (and `b`), the result
//! `(r, defined)` of [`unary`], [`binary`] or [`powi`] satisfies:
//!
//! * **Enclosure.** For every real `x ∈ a` (and `y ∈ b`) at which `op` is
//!   defined, the exact real value `op(x, y)` lies in `r`. Since the bounds
//!   of `r` are floats, this also encloses any correctly rounded (or
//!   round-to-nearest IEEE) evaluation of `op` at float inputs in `a`, `b`:
//!   the interval of a degenerate box `[p, p]` always contains the point
//!   value of [`crate::eval::point`] (unless that is NaN).
//! * **Decoration.** `defined` is true only if `op` is defined *and
//!   continuous* on the whole of `a × b` (IEEE 1788 `dac`/`com` collapsed
//!   into one flag). It may be false when in doubt (e.g. `tan` on an
//!   interval that may contain a pole); it is never true when it should not
//!   be.
//! * **Domains** (the point semantics of `crate::ir`): `sqrt` on `x ≥ 0`,
//!   `log` on `x > 0`, `asin`/`acos` on `[-1, 1]`, `a / b` on `b ≠ 0`,
//!   `pow(a, b) = exp(b·ln a)` on `a > 0`, `atan2(y, x)` off the origin and
//!   continuous off the branch cut `{x < 0, y = 0}` (across it the result is
//!   `[-π, π]`), `tan` off its poles, negative integer powers off `0`. The
//!   result encloses the range over the part of the box inside the domain
//!   (empty when there is none) and `defined` is false when the box leaves
//!   the domain.
//! * **Piecewise-constant and selecting ops** (`floor ceil round not
//!   compare mod and or`, Fidget's) enclose the set of values exactly and
//!   are continuous only when no jump can lie inside the box; see
//!   [`discrete`].
//! * **Integer powers** follow exact monotone rules: even `n` on an interval
//!   straddling 0 starts at 0, odd `n` is increasing; each bound is computed
//!   as an outward-rounded version of the *same* repeated-squaring chain the
//!   point evaluator uses, so both the real `x^n` and the float chain are
//!   enclosed. `a^0 = [1, 1]` for every `a` (even empty: the point value is
//!   1 for every input, NaN included). `a^-n = 1 / a^n`.
//!
//! # Rounding
//!
//! No rounding-mode switches: every bound is computed in round-to-nearest
//! and then moved outward, see [`round`] (error-free transformations decide
//! when a result is exact, so e.g. `[-1, 2]²` is exactly `[0, 4]`).
//! Transcendental bounds come from the correctly rounded CORE-MATH functions
//! (`core-math` crate) moved one ulp outward — correct rounding means the
//! exact value is within half an ulp, so the step is provably enough (plain
//! libm gives no such guarantee) — then clamped to the function's true range
//! (`sin` into `[-1, 1]`, `exp ≥ 0`, `atan` into `[-π/2, π/2]`, …). The only
//! exact transcendental values used are the trivial ones (`exp 0 = 1`,
//! `log 1 = 0`, `sin 0 = 0`, …), and sign facts keep a step from crossing
//! 0 or 1 where the side is known (`exp x ≥ 1` for `x ≥ 0`, `atan x ≥ 0` for
//! `x ≥ 0`, an underflowing product of positives stays `≥ 0`, …), which
//! keeps the evaluator inclusion-isotone (a sub-box never gets a wider
//! interval; tested). `sin`/`cos`/`tan` decide which critical
//! points `kπ/2` lie in the argument by an interval enclosure of `x·2/π`;
//! when floating point cannot decide, the extremum (or pole) is included.
//! See [`trig`]. `pow` takes the hull of its four corners (it is monotone
//! in each argument separately), see [`elementary::pow`].
//!
//! # Files
//!
//! [`round`]: outward rounding of single float operations; [`arith`]:
//! `+ − × /`, min, max, abs, sqrt, integer powers; [`elementary`]: exp, log,
//! asin, acos, atan, atan2, pow; [`trig`]: sin, cos, tan with range
//! reduction. [`unary`], [`binary`] and [`powi`] below dispatch on the IR
//! op and are what the evaluators, the constant folder and the JIT's
//! transcendental helpers call.
//!
//! # Data layout
//!
//! An [`Interval`] is `{lo, hi}` with `lo ≤ hi`; bounds may be infinite
//! (`lo = -∞` / `hi = +∞` mean unbounded). The empty interval is
//! `lo = +∞, hi = -∞` ([`Interval::EMPTY`]); any `lo > hi` is read as empty.
//! Inputs are first normalised ([`Interval::normalize`]): a NaN bound makes
//! the interval entire with `defined = false`; a bound equal to `+∞` on the
//! low side (`[+∞, +∞]`) is read as the ray `[f64::MAX, +∞]` (and `[-∞, -∞]`
//! as `[-∞, -f64::MAX]`), so that a point evaluator's infinite values are
//! enclosed in the limit sense: `+∞` is "in" an interval whose `hi` is `+∞`.
//! After normalisation `lo < +∞` and `hi > -∞`, which is what keeps
//! `∞ − ∞` out of the bound arithmetic.
//!
//! References: R. E. Moore, *Interval Analysis* (1966); IEEE Std 1788-2015;
//! Paiva, de Figueiredo & Stolfi, *Robust adaptive meshes for implicit
//! surfaces* (SIBGRAPI 2006), which uses these enclosures for the octree.

pub mod arith;
pub(crate) mod discrete;
pub(crate) mod elementary;
pub mod round;
pub(crate) mod trig;

/// A closed interval `[lo, hi]` of reals, bounds possibly infinite.
/// The empty interval is `lo = +∞, hi = -∞`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    /// Lower bound (`+∞` for the empty interval).
    pub lo: f64,
    /// Upper bound (`-∞` for the empty interval).
    pub hi: f64,
}

/// An interval plus the decoration "the function was defined and continuous
/// on the whole input box" (IEEE 1788 `dac`/`com` collapsed into one flag).
/// When `defined` is false, `iv` still encloses the range over the part of
/// the box where the function is defined (possibly empty).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DecInterval {
    /// Enclosure of the range where the function is defined.
    pub iv: Interval,
    /// The function is defined and continuous on the whole input box.
    pub defined: bool,
}

/// Lower bound of the f64 enclosure of π (`f64::consts::PI < π`).
pub const PI_LO: f64 = std::f64::consts::PI;
/// Upper bound of the f64 enclosure of π.
pub const PI_HI: f64 = 3.141_592_653_589_793_6;
/// Lower bound of π/2.
pub(crate) const HALF_PI_LO: f64 = std::f64::consts::FRAC_PI_2;
/// Upper bound of π/2.
pub const HALF_PI_HI: f64 = 1.570_796_326_794_896_8;

impl Interval {
    /// The empty set.
    pub const EMPTY: Interval = Interval {
        lo: f64::INFINITY,
        hi: f64::NEG_INFINITY,
    };
    /// The whole real line.
    pub const ENTIRE: Interval = Interval {
        lo: f64::NEG_INFINITY,
        hi: f64::INFINITY,
    };

    /// `[lo, hi]` as given (no checks; see [`Interval::normalize`]).
    pub const fn new(lo: f64, hi: f64) -> Interval {
        Interval { lo, hi }
    }

    /// The degenerate interval `[x, x]`.
    pub const fn point(x: f64) -> Interval {
        Interval { lo: x, hi: x }
    }

    /// True for the empty set (any `lo > hi`; NaN bounds are not empty).
    pub fn is_empty(&self) -> bool {
        self.lo > self.hi
    }

    /// True when the interval proves its value is not zero: both bounds
    /// on one side of 0. Written so that a NaN bound never excludes zero
    /// (a cell is never discarded, nor a gradient certified, on a NaN).
    pub fn excludes_zero(&self) -> bool {
        self.lo > 0.0 || self.hi < 0.0
    }

    /// True when `x` lies in the interval. NaN is in no interval; `+∞` is
    /// "in" an interval unbounded above, `-∞` in one unbounded below.
    pub fn contains(&self, x: f64) -> bool {
        if x == f64::INFINITY {
            self.hi == f64::INFINITY && !self.is_empty()
        } else if x == f64::NEG_INFINITY {
            self.lo == f64::NEG_INFINITY && !self.is_empty()
        } else {
            self.lo <= x && x <= self.hi
        }
    }

    /// True when `self ⊆ other`.
    pub fn subset_of(&self, other: &Interval) -> bool {
        self.is_empty() || (other.lo <= self.lo && self.hi <= other.hi)
    }

    /// Smallest interval containing both.
    pub fn hull(self, other: Interval) -> Interval {
        if self.is_empty() {
            other
        } else if other.is_empty() {
            self
        } else {
            Interval::new(self.lo.min(other.lo), self.hi.max(other.hi))
        }
    }

    /// Intersection.
    pub fn intersect(self, other: Interval) -> Interval {
        let r = Interval::new(self.lo.max(other.lo), self.hi.min(other.hi));
        if r.is_empty() { Interval::EMPTY } else { r }
    }

    /// True when both bounds are finite (and the interval is not empty).
    pub fn is_bounded(&self) -> bool {
        !self.is_empty() && self.lo.is_finite() && self.hi.is_finite()
    }

    /// The canonical form every operation works on, and whether the input
    /// was well formed: NaN bound → `(ENTIRE, false)`; `lo > hi` → `EMPTY`;
    /// `lo = +∞` → `f64::MAX`, `hi = -∞` → `-f64::MAX` (see the module doc).
    pub fn normalize(self) -> (Interval, bool) {
        if self.lo.is_nan() || self.hi.is_nan() {
            return (Interval::ENTIRE, false);
        }
        if self.lo > self.hi {
            return (Interval::EMPTY, true);
        }
        let lo = if self.lo == f64::INFINITY {
            f64::MAX
        } else {
            self.lo
        };
        let hi = if self.hi == f64::NEG_INFINITY {
            -f64::MAX
        } else {
            self.hi
        };
        (Interval::new(lo, hi), true)
    }

    /// Interval enclosing the integer `n` (exact unless `|n| > 2^53`).
    pub fn from_i64(n: i64) -> Interval {
        let f = n as f64;
        // `f as i128` is exact for every float of this magnitude.
        let back = f as i128;
        if back == n as i128 {
            Interval::point(f)
        } else if back > n as i128 {
            Interval::new(f.next_down(), f)
        } else {
            Interval::new(f, f.next_up())
        }
    }
}

impl DecInterval {
    /// `iv` with the flag `defined`.
    pub fn new(iv: Interval, defined: bool) -> DecInterval {
        DecInterval { iv, defined }
    }

    /// True when the enclosure proves the function has no zero on its box:
    /// defined and continuous there, and `iv` on one side of 0
    /// ([`Interval::excludes_zero`]).
    pub fn excludes_zero(&self) -> bool {
        self.defined && self.iv.excludes_zero()
    }
}

/// [`crate::ir::semantics::enclose_binary`] for an op whose rule `rule` is total (defined and continuous
/// everywhere: `Add`, `Sub`, `Mul`, `Min`, `Max`), called directly: the
/// same result, without the dispatch on the op.
#[inline]
pub(crate) fn binary_with(
    a: Interval,
    b: Interval,
    rule: impl Fn(Interval, Interval) -> Interval,
) -> (Interval, bool) {
    let (a, oka) = a.normalize();
    let (b, okb) = b.normalize();
    (rule(a, b), oka && okb && !a.is_empty() && !b.is_empty())
}

/// [`crate::ir::semantics::enclose_unary`] for a total op (`Neg`, `Abs`, `Square`), called directly.
#[inline]
pub(crate) fn unary_with(a: Interval, rule: impl Fn(Interval) -> Interval) -> (Interval, bool) {
    let (a, ok) = a.normalize();
    (rule(a), ok && !a.is_empty())
}
