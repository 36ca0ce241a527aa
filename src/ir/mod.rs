//! The SSA intermediate representation of a surface's function.
//!
//! # Contract
//!
//! A [`Program`] is a flat list of instructions `v0, v1, …`; instruction `vi`
//! defines exactly one value and refers only to values `vj` with `j < i`, so
//! evaluating the list front to back is always valid and no stage needs
//! recursion. The program has one output, the value whose zero set is the
//! surface. The inputs are the four variables `x y z t` ([`Var`]).
//!
//! Every evaluator (reference interpreters in [`crate::eval`], the JIT in
//! [`crate::jit`]) gives each [`Op`] the same meaning:
//!
//! | op | point meaning (f64) | interval meaning |
//! |---|---|---|
//! | `var x` | the input | the input box side |
//! | `const c [lo, hi]` | `c` | `[lo, hi]` |
//! | `neg a` `abs a` `sqrt a` `square a` | IEEE ops, `square a = a*a` | exact ranges, outward rounded |
//! | `powi a n` | `a^n` by repeated squaring; `n < 0` is `1/a^-n` | exact monotone rules (even `n` on an interval straddling 0 starts at 0) |
//! | `exp log sin cos tan asin acos atan` | correctly rounded (CORE-MATH) | enclosure: correctly rounded bound ± one ulp |
//! | `add sub mul div min max` | IEEE ops | outward rounded |
//! | `atan2 y x` | correctly rounded | enclosure; `[-π, π]` across the branch cut |
//! | `pow a b` | `exp(b·ln a)`, defined for `a > 0` | enclosure over the part of the box where `a > 0` |
//! | `floor ceil round a` | `f64::floor/ceil/round` (round: ties away from 0) | `[f lo, f hi]`, continuous iff the two are equal |
//! | `not a` | 1 if `a == 0`, else 0 | `[0,0]`, `[1,1]` or `[0,1]` (not continuous) |
//! | `compare a b` | −1, 0, 1 as `a < b`, `a = b`, `a > b` | the possible signs; continuous only when one is certain |
//! | `mod a b` | `a.rem_euclid(b)`, NaN for `b = 0` | `[0, max abs b]`, exact within one period of a constant `b` |
//! | `and a b` / `or a b` | `a == 0 ? a : b` / `a != 0 ? a : b` | the chosen operand when the choice is certain, else the hull (not continuous) |
//!
//! The last five rows are Fidget's ops (for `.vm` models, [`crate::syntax::vm`]);
//! unlike Fidget's point evaluator, a NaN operand gives NaN (the IR's rule
//! that NaN propagates through every op).
//!
//! Outside an op's domain (sqrt of a negative, log of a non-positive, division
//! by zero, `pow` of a non-positive base) the point value is NaN, and the
//! interval value encloses the range over the part of the box where the op is
//! defined, with a flag saying that it is not defined (or not continuous)
//! everywhere on the box; see [`crate::interval`].
//!
//! # Constants
//!
//! A constant carries two things: `value`, the f64 that the point evaluators
//! use, and `[lo, hi]`, an enclosure of the *real* number it stands for (and
//! of `value`). A decimal literal such as `0.1` is not an f64, so its
//! enclosure is one ulp wide; `pi` likewise. Constant folding computes both
//! halves — the point result with point arithmetic, the enclosure with
//! interval arithmetic — so that folding never makes an interval kernel
//! unsound (the "soundness trap" of folding in round-to-nearest).
//!
//! # Text form
//!
//! [`Program`] prints (via `Display`) and parses back ([`text::parse`]) as:
//!
//! ```text
//! v0 = var x
//! v1 = const 0.1 [0.09999999999999999, 0.1]
//! v2 = powi v0 3
//! v3 = add v2 v1
//! output v3
//! ```
//!
//! A constant whose enclosure is the single point `c` prints as `const c`.
//! Numbers print in shortest round-trip form, so the text form round-trips
//! bit for bit.

pub mod builder;
pub(crate) mod dce;
pub mod fold;
pub mod literal;
pub mod semantics;
pub mod simplify;
pub mod text;

pub use builder::Builder;

use std::fmt;

/// An SSA value: the index of the instruction that defines it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Value(pub u32);

impl Value {
    /// The index of the defining instruction.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "v{}", self.0)
    }
}

/// The four inputs of every program.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Var {
    /// The `x` coordinate (input 0).
    X,
    /// The `y` coordinate (input 1).
    Y,
    /// The `z` coordinate (input 2).
    Z,
    /// The time parameter `t` (input 3).
    T,
}

impl Var {
    /// All variables, in input order (`x y z t`).
    pub const ALL: [Var; 4] = [Var::X, Var::Y, Var::Z, Var::T];

    /// Position of the variable in an input array `[x, y, z, t]`.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The variable's name in the language and the text form.
    pub fn name(self) -> &'static str {
        ["x", "y", "z", "t"][self as usize]
    }
}

/// A constant: the f64 the point evaluators use and an enclosure of the real
/// number it stands for. Invariant: `lo <= value <= hi`, or `value` is NaN
/// (a constant outside an op's domain, e.g. `sqrt(-1)`), in which case
/// `lo`/`hi` enclose whatever part of the real value exists (possibly empty,
/// `lo > hi`) and `defined` is false.
#[derive(Clone, Copy, Debug)]
pub struct Const {
    /// The f64 the point evaluators use (NaN when not defined).
    pub value: f64,
    /// Lower bound of the enclosure of the real value.
    pub lo: f64,
    /// Upper bound of the enclosure of the real value.
    pub hi: f64,
    /// False when the constant's expression was not defined (e.g. `log(0)`,
    /// `1/0`); the interval evaluators propagate the flag.
    pub defined: bool,
}

impl Const {
    /// A constant that is exactly the f64 `v` (e.g. an integer literal).
    pub fn exact(v: f64) -> Const {
        Const {
            value: v,
            lo: v,
            hi: v,
            defined: !v.is_nan(),
        }
    }

    /// True when the enclosure is the single point `value`.
    pub fn is_exact(&self) -> bool {
        self.defined && self.lo == self.value && self.hi == self.value
    }

    /// Bitwise key, for hash-consing.
    fn key(&self) -> (u64, u64, u64, bool) {
        (
            self.value.to_bits(),
            self.lo.to_bits(),
            self.hi.to_bits(),
            self.defined,
        )
    }
}

impl PartialEq for Const {
    fn eq(&self, other: &Self) -> bool {
        self.key() == other.key()
    }
}
impl Eq for Const {}
impl std::hash::Hash for Const {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.key().hash(state)
    }
}

/// Operations of one argument.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum UnOp {
    /// `-a`.
    Neg,
    /// `|a|`.
    Abs,
    /// Square root (NaN for `a < 0`).
    Sqrt,
    /// `a * a`.
    Square,
    /// `e^a`.
    Exp,
    /// Natural logarithm (NaN for `a <= 0`).
    Log,
    /// Sine (radians).
    Sin,
    /// Cosine (radians).
    Cos,
    /// Tangent (radians).
    Tan,
    /// Arcsine, in `[-π/2, π/2]` (NaN outside `[-1, 1]`).
    Asin,
    /// Arccosine, in `[0, π]` (NaN outside `[-1, 1]`).
    Acos,
    /// Arctangent, in `(-π/2, π/2)`.
    Atan,
    /// Largest integer `<= a`.
    Floor,
    /// Smallest integer `>= a`.
    Ceil,
    /// Nearest integer, ties away from zero (`f64::round`, Fidget's rule).
    Round,
    /// Logical not: 1 if `a == 0`, else 0 (NaN for NaN).
    Not,
}

/// Operations of two arguments.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BinOp {
    /// `a + b`.
    Add,
    /// `a - b`.
    Sub,
    /// `a * b`.
    Mul,
    /// `a / b` (NaN for `b = 0`).
    Div,
    /// The smaller of `a` and `b` (NaN if either is NaN; `-0 < +0`).
    Min,
    /// The larger of `a` and `b` (NaN if either is NaN; `-0 < +0`).
    Max,
    /// `atan2(y, x)`: first operand is `y`.
    Atan2,
    /// `pow(a, b) = exp(b·ln a)`, defined for `a > 0`.
    Pow,
    /// `-1`, `0` or `1` as `a < b`, `a = b`, `a > b` (NaN if either is NaN).
    Compare,
    /// `a.rem_euclid(b)`: the least non-negative remainder, in `[0, |b|]`
    /// (NaN for `b = 0`).
    Mod,
    /// Logical and: `a` if `a == 0`, else `b` (NaN if either is NaN).
    And,
    /// Logical or: `a` if `a != 0`, else `b` (NaN if either is NaN).
    Or,
}

impl UnOp {
    /// Every unary op, in declaration order.
    pub const ALL: [UnOp; 16] = [
        UnOp::Neg,
        UnOp::Abs,
        UnOp::Sqrt,
        UnOp::Square,
        UnOp::Exp,
        UnOp::Log,
        UnOp::Sin,
        UnOp::Cos,
        UnOp::Tan,
        UnOp::Asin,
        UnOp::Acos,
        UnOp::Atan,
        UnOp::Floor,
        UnOp::Ceil,
        UnOp::Round,
        UnOp::Not,
    ];

    /// The op's name in the text form.
    pub fn name(self) -> &'static str {
        match self {
            UnOp::Neg => "neg",
            UnOp::Abs => "abs",
            UnOp::Sqrt => "sqrt",
            UnOp::Square => "square",
            UnOp::Exp => "exp",
            UnOp::Log => "log",
            UnOp::Sin => "sin",
            UnOp::Cos => "cos",
            UnOp::Tan => "tan",
            UnOp::Asin => "asin",
            UnOp::Acos => "acos",
            UnOp::Atan => "atan",
            UnOp::Floor => "floor",
            UnOp::Ceil => "ceil",
            UnOp::Round => "round",
            UnOp::Not => "not",
        }
    }
}

impl BinOp {
    /// Every binary op, in declaration order.
    pub const ALL: [BinOp; 12] = [
        BinOp::Add,
        BinOp::Sub,
        BinOp::Mul,
        BinOp::Div,
        BinOp::Min,
        BinOp::Max,
        BinOp::Atan2,
        BinOp::Pow,
        BinOp::Compare,
        BinOp::Mod,
        BinOp::And,
        BinOp::Or,
    ];

    /// The op's name in the text form.
    pub fn name(self) -> &'static str {
        match self {
            BinOp::Add => "add",
            BinOp::Sub => "sub",
            BinOp::Mul => "mul",
            BinOp::Div => "div",
            BinOp::Min => "min",
            BinOp::Max => "max",
            BinOp::Atan2 => "atan2",
            BinOp::Pow => "pow",
            BinOp::Compare => "compare",
            BinOp::Mod => "mod",
            BinOp::And => "and",
            BinOp::Or => "or",
        }
    }

    /// True when `a op b == b op a` for every input (used by hash-consing to
    /// put operands in a canonical order).
    pub fn is_commutative(self) -> bool {
        matches!(self, BinOp::Add | BinOp::Mul | BinOp::Min | BinOp::Max)
    }
}

/// One instruction: it defines the value whose index is its position.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Op {
    /// An input variable.
    Var(Var),
    /// A constant.
    Const(Const),
    /// A one-argument op applied to a value.
    Unary(UnOp, Value),
    /// A two-argument op applied to two values, in operand order.
    Binary(BinOp, Value, Value),
    /// `a^n` for an integer `n` of any sign; `a^0 = 1` for every `a`, and
    /// `a^-n = 1/a^n` (so NaN at `a = 0`).
    Powi(Value, i64),
}

impl Op {
    /// The values this instruction reads, in operand order.
    pub fn args(&self) -> impl Iterator<Item = Value> {
        let (a, b) = match *self {
            Op::Var(_) | Op::Const(_) => (None, None),
            Op::Unary(_, a) | Op::Powi(a, _) => (Some(a), None),
            Op::Binary(_, a, b) => (Some(a), Some(b)),
        };
        a.into_iter().chain(b)
    }

    /// The same instruction with every operand renamed by `f`.
    pub fn map_args(self, mut f: impl FnMut(Value) -> Value) -> Op {
        match self {
            Op::Var(_) | Op::Const(_) => self,
            Op::Unary(u, a) => Op::Unary(u, f(a)),
            Op::Powi(a, n) => Op::Powi(f(a), n),
            Op::Binary(b, x, y) => Op::Binary(b, f(x), f(y)),
        }
    }
}

/// A straight-line SSA program with one output. See the module doc.
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    /// The instructions; instruction `i` defines value `vi`.
    pub insts: Vec<Op>,
    /// The value whose zero set is the surface.
    pub output: Value,
}

impl Program {
    /// Number of instructions.
    pub fn len(&self) -> usize {
        self.insts.len()
    }

    /// True when the program has no instructions (never the case for a
    /// program built by [`Builder::finish`]).
    pub fn is_empty(&self) -> bool {
        self.insts.is_empty()
    }

    /// Checks the SSA invariant: every operand refers to an earlier value,
    /// the output exists. Returns a message naming the first violation.
    pub fn validate(&self) -> Result<(), String> {
        for (i, op) in self.insts.iter().enumerate() {
            for a in op.args() {
                if a.index() >= i {
                    return Err(format!("v{i} uses {a}, which is not defined before it"));
                }
            }
        }
        if self.output.index() >= self.insts.len() {
            return Err(format!("output {} is not defined", self.output));
        }
        Ok(())
    }

    /// Which variables the program reads (after dead-code elimination, the
    /// ones its output depends on).
    pub fn uses_var(&self, v: Var) -> bool {
        self.insts.contains(&Op::Var(v))
    }
}
