//! What resolution decides: the built-in functions, what each name or
//! call node refers to ([`Res`]) and the resolved file ([`Resolved`]).
//! [`super::resolve`] produces these; [`super::lower`] consumes them.

use super::ast::{ExprId, Span};
use crate::geometry::Bounds;
use crate::ir::{UnOp, Var};

/// A built-in function.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Builtin {
    /// A one-argument function that lowers to the IR op.
    Unary(UnOp),
    /// `atan2(y, x)`.
    Atan2,
    /// `pow(a, b)`, the same as `a ^ b`.
    Pow,
    /// `min(a, b)`.
    Min,
    /// `max(a, b)`.
    Max,
}

/// All built-in functions by name.
pub(crate) const BUILTINS: [(&str, Builtin); 14] = [
    ("sqrt", Builtin::Unary(UnOp::Sqrt)),
    ("abs", Builtin::Unary(UnOp::Abs)),
    ("sin", Builtin::Unary(UnOp::Sin)),
    ("cos", Builtin::Unary(UnOp::Cos)),
    ("tan", Builtin::Unary(UnOp::Tan)),
    ("asin", Builtin::Unary(UnOp::Asin)),
    ("acos", Builtin::Unary(UnOp::Acos)),
    ("atan", Builtin::Unary(UnOp::Atan)),
    ("exp", Builtin::Unary(UnOp::Exp)),
    ("log", Builtin::Unary(UnOp::Log)),
    ("atan2", Builtin::Atan2),
    ("pow", Builtin::Pow),
    ("min", Builtin::Min),
    ("max", Builtin::Max),
];

/// What a name or call node refers to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Res {
    /// Not a name/call node, or a node whose resolution failed.
    None,
    /// A coordinate `x`, `y`, `z` or `t`.
    Coord(Var),
    /// The constant `pi`.
    Pi,
    /// Index into [`Resolved::params`].
    Param(usize),
    /// Index into [`Resolved::lets`].
    Let(usize),
    /// The i-th parameter of the enclosing fn.
    FnParam(usize),
    /// A call of a built-in function.
    Builtin(Builtin),
    /// Index into [`Resolved::fns`].
    Fn(usize),
}

/// A function definition.
#[derive(Clone, Debug)]
pub struct FnDef {
    /// The function's name.
    pub name: String,
    /// Number of parameters.
    pub arity: usize,
    /// The body expression.
    pub body: ExprId,
}

/// The result of resolution. See the module doc.
#[derive(Clone, Debug, Default)]
pub struct Resolved {
    /// What each expression refers to, indexed by [`ExprId`] (one per node).
    pub res: Vec<Res>,
    /// Bodies of the `let`s, in source order.
    pub lets: Vec<ExprId>,
    /// Every `param` with its final value (after `--set`), in source order.
    pub params: Vec<(String, f64)>,
    /// The `fn` definitions, in source order.
    pub fns: Vec<FnDef>,
    /// The first `surface`: lhs, rhs, statement span.
    pub surface: Option<(ExprId, Option<ExprId>, Span)>,
    /// The file's domain (not `--domain`), when it is valid.
    pub domain: Option<Bounds>,
}
