//! What resolution decides: the built-in functions, what each name or
//! call node refers to ([`Res`]) and the resolved file ([`Resolved`]).
//! [`super::resolve`] produces these; [`super::lower`] consumes them.

use super::ast::{ExprId, Span};
use crate::geometry::Bounds;
use crate::ir::{UnOp, Var};

/// A built-in function.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Builtin {
    Unary(UnOp),
    Atan2,
    /// `pow(a, b)`, the same as `a ^ b`.
    Pow,
    Min,
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
    Coord(Var),
    Pi,
    /// Index into [`Resolved::params`].
    Param(usize),
    /// Index into [`Resolved::lets`].
    Let(usize),
    /// The i-th parameter of the enclosing fn.
    FnParam(usize),
    Builtin(Builtin),
    /// Index into [`Resolved::fns`].
    Fn(usize),
}

/// A function definition.
#[derive(Clone, Debug)]
pub struct FnDef {
    pub name: String,
    pub arity: usize,
    pub body: ExprId,
}

/// The result of resolution. See the module doc.
#[derive(Clone, Debug, Default)]
pub struct Resolved {
    pub res: Vec<Res>,
    /// Bodies of the `let`s, in source order.
    pub lets: Vec<ExprId>,
    /// Every `param` with its final value (after `--set`), in source order.
    pub params: Vec<(String, f64)>,
    pub fns: Vec<FnDef>,
    /// The first `surface`: lhs, rhs, statement span.
    pub surface: Option<(ExprId, Option<ExprId>, Span)>,
    /// The file's domain (not `--domain`), when it is valid.
    pub domain: Option<Bounds>,
}

