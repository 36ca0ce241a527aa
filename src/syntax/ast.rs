//! The abstract syntax tree, stored as an arena.
//!
//! # Contract
//!
//! Expressions live in one flat vector ([`Ast::exprs`]) and refer to their
//! children by index ([`ExprId`]); a child is always pushed before its
//! parent, so `child.0 < parent.0`. Nothing here is a recursive Rust type, so
//! dropping an AST of any depth is a loop, and every walk over it (printing,
//! resolution, lowering) uses an explicit stack — a 100,000-deep tree cannot
//! overflow the machine stack.
//!
//! Statements ([`Stmt`]) are kept in source order in [`Ast::stmts`].
//!
//! # Layout
//!
//! [`Ast`] (arena + statements, with the push helpers the grammar actions
//! call), [`Expr`]/[`ExprKind`], [`Stmt`]/[`StmtKind`], the printer
//! [`Ast::print`] used by `isoc compile --emit ast`, and [`Ast::print_infix`]
//! (source text again, fully parenthesised).

use super::diag::Diagnostic;
use std::fmt::Write;
use std::ops::Range;

/// Byte range in the source.
pub(crate) type Span = Range<usize>;

/// Index of an expression in [`Ast::exprs`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ExprId(pub u32);

impl ExprId {
    /// The id as a `usize` index into [`Ast::exprs`].
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// Binary operators of the language.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinKind {
    /// `a + b`.
    Add,
    /// `a - b`.
    Sub,
    /// `a * b`.
    Mul,
    /// `a / b`.
    Div,
    /// `a ^ b` (power).
    Pow,
}

impl BinKind {
    /// The operator's source symbol (`+ - * / ^`).
    pub fn symbol(self) -> &'static str {
        match self {
            BinKind::Add => "+",
            BinKind::Sub => "-",
            BinKind::Mul => "*",
            BinKind::Div => "/",
            BinKind::Pow => "^",
        }
    }
}

/// An expression node.
#[derive(Clone, Debug, PartialEq)]
pub enum ExprKind {
    /// A number literal, with its source text.
    Num(String),
    /// A name: a coordinate, `pi`, a `let`, a `param` or a fn parameter.
    Name(String),
    /// Unary minus, `-a`.
    Neg(ExprId),
    /// A binary operation `a op b`.
    Bin(BinKind, ExprId, ExprId),
    /// `name(args…)`; `name_span` covers the name only.
    Call {
        /// The called function's name.
        name: String,
        /// Span of the name alone.
        name_span: Span,
        /// The arguments, in order.
        args: Vec<ExprId>,
    },
}

/// An expression in the arena: its node and source span.
#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    /// What the expression is.
    pub kind: ExprKind,
    /// The whole expression's byte range in the source.
    pub span: Span,
}

/// A name with its span (a definition site).
#[derive(Clone, Debug, PartialEq)]
pub struct Ident {
    /// The name's text.
    pub name: String,
    /// The name's byte range in the source.
    pub span: Span,
}

/// A statement of the language.
#[derive(Clone, Debug, PartialEq)]
pub enum StmtKind {
    /// `domain [a,b]^N;` (`power = Some((N text, span))`) or
    /// `domain [a,b], [c,d], …;` (`power = None`). The count of ranges and
    /// the power are checked by resolution, not by the grammar.
    Domain {
        /// The ranges `[a, b]` as (low, high) expressions, in order.
        ranges: Vec<(ExprId, ExprId)>,
        /// The exponent `N` of `[a,b]^N` (its text and span), if any.
        power: Option<(String, Span)>,
    },
    /// `let name = value;`
    Let {
        /// The defined name.
        name: Ident,
        /// The bound expression.
        value: ExprId,
    },
    /// `param name = value;`
    Param {
        /// The parameter's name.
        name: Ident,
        /// The default value (a constant expression).
        value: ExprId,
    },
    /// `fn name(params…) = body;`
    Fn {
        /// The function's name.
        name: Ident,
        /// The formal parameters, in order.
        params: Vec<Ident>,
        /// The function's body.
        body: ExprId,
    },
    /// `surface lhs;` or `surface lhs = rhs;`
    Surface {
        /// The left-hand side (the whole function when there is no `=`).
        lhs: ExprId,
        /// The right-hand side, if the statement is an equation.
        rhs: Option<ExprId>,
    },
}

/// A statement with its span.
#[derive(Clone, Debug, PartialEq)]
pub struct Stmt {
    /// What the statement is.
    pub kind: StmtKind,
    /// The whole statement, keyword to `;`.
    pub span: Span,
}

/// The parsed file. See the module doc.
#[derive(Clone, Debug, Default)]
pub struct Ast {
    /// The expression arena, indexed by [`ExprId`]; children before parents.
    pub exprs: Vec<Expr>,
    /// The statements, in source order.
    pub stmts: Vec<Stmt>,
    /// Syntax errors found (and recovered from) while parsing.
    pub errors: Vec<Diagnostic>,
    /// Every name that follows `let`, `param` or `fn` in the token stream,
    /// including in statements that failed to parse: resolution does not
    /// report such names as unknown (that error would only be a cascade).
    pub declared: std::collections::HashSet<String>,
}

impl Ast {
    /// An empty AST.
    pub fn new() -> Self {
        Ast::default()
    }

    /// The expression with id `id`.
    pub fn expr(&self, id: ExprId) -> &Expr {
        &self.exprs[id.index()]
    }

    /// Adds an expression node and returns its id.
    pub fn push(&mut self, kind: ExprKind, span: Span) -> ExprId {
        let id = ExprId(self.exprs.len() as u32);
        self.exprs.push(Expr { kind, span });
        id
    }

    /// Adds a number literal with source text `text`.
    pub fn num(&mut self, text: &str, span: Span) -> ExprId {
        self.push(ExprKind::Num(text.to_string()), span)
    }

    /// Adds a name reference.
    pub fn name(&mut self, text: &str, span: Span) -> ExprId {
        self.push(ExprKind::Name(text.to_string()), span)
    }

    /// Adds `-a`.
    pub fn neg(&mut self, a: ExprId, span: Span) -> ExprId {
        self.push(ExprKind::Neg(a), span)
    }

    /// Adds `a op b`, spanning from the start of `a` to the end of `b`.
    pub fn bin(&mut self, op: BinKind, a: ExprId, b: ExprId) -> ExprId {
        let span = self.expr(a).span.start..self.expr(b).span.end;
        self.push(ExprKind::Bin(op, a, b), span)
    }

    /// Adds the call `name(args…)`; `span` covers the whole call.
    pub fn call(&mut self, name: Ident, args: Vec<ExprId>, span: Span) -> ExprId {
        self.push(
            ExprKind::Call {
                name: name.name,
                name_span: name.span,
                args,
            },
            span,
        )
    }

    /// Appends a statement.
    pub fn stmt(&mut self, kind: StmtKind, span: Span) {
        self.stmts.push(Stmt { kind, span });
    }

    /// Fully parenthesised s-expression form of the whole file, one
    /// statement per line (`isoc compile --emit ast`).
    pub fn print(&self) -> String {
        let mut out = String::new();
        for s in &self.stmts {
            match &s.kind {
                StmtKind::Domain { ranges, power } => {
                    out.push_str("(domain");
                    for &(a, b) in ranges {
                        out.push_str(" [");
                        self.print_expr(a, &mut out);
                        out.push(' ');
                        self.print_expr(b, &mut out);
                        out.push(']');
                    }
                    if let Some((p, _)) = power {
                        let _ = write!(out, " ^{p}");
                    }
                    out.push(')');
                }
                StmtKind::Let { name, value } => {
                    let _ = write!(out, "(let {} ", name.name);
                    self.print_expr(*value, &mut out);
                    out.push(')');
                }
                StmtKind::Param { name, value } => {
                    let _ = write!(out, "(param {} ", name.name);
                    self.print_expr(*value, &mut out);
                    out.push(')');
                }
                StmtKind::Fn { name, params, body } => {
                    let ps: Vec<&str> = params.iter().map(|p| p.name.as_str()).collect();
                    let _ = write!(out, "(fn {} ({}) ", name.name, ps.join(" "));
                    self.print_expr(*body, &mut out);
                    out.push(')');
                }
                StmtKind::Surface { lhs, rhs } => {
                    out.push_str("(surface ");
                    self.print_expr(*lhs, &mut out);
                    if let Some(r) = rhs {
                        out.push(' ');
                        self.print_expr(*r, &mut out);
                    }
                    out.push(')');
                }
            }
            out.push('\n');
        }
        out
    }

    /// Appends `root` to `out` as fully parenthesised infix source text that
    /// parses back to the same tree (`-a` → `(-a)`, `a + b` → `(a + b)`),
    /// iteratively.
    pub fn print_infix(&self, root: ExprId, out: &mut String) {
        enum Job {
            Node(ExprId),
            Text(&'static str),
        }
        let mut stack = vec![Job::Node(root)];
        while let Some(job) = stack.pop() {
            let id = match job {
                Job::Text(t) => {
                    out.push_str(t);
                    continue;
                }
                Job::Node(id) => id,
            };
            match &self.expr(id).kind {
                ExprKind::Num(t) | ExprKind::Name(t) => out.push_str(t),
                ExprKind::Neg(a) => {
                    out.push_str("(-");
                    stack.push(Job::Text(")"));
                    stack.push(Job::Node(*a));
                }
                ExprKind::Bin(op, a, b) => {
                    out.push('(');
                    stack.push(Job::Text(")"));
                    stack.push(Job::Node(*b));
                    stack.push(Job::Text(match op {
                        BinKind::Add => " + ",
                        BinKind::Sub => " - ",
                        BinKind::Mul => " * ",
                        BinKind::Div => " / ",
                        BinKind::Pow => " ^ ",
                    }));
                    stack.push(Job::Node(*a));
                }
                ExprKind::Call { name, args, .. } => {
                    out.push_str(name);
                    out.push('(');
                    stack.push(Job::Text(")"));
                    for (i, &a) in args.iter().enumerate().rev() {
                        stack.push(Job::Node(a));
                        if i > 0 {
                            stack.push(Job::Text(", "));
                        }
                    }
                }
            }
        }
    }

    /// Appends the s-expression of `root` to `out`, iteratively.
    pub fn print_expr(&self, root: ExprId, out: &mut String) {
        enum Job {
            Node(ExprId),
            Text(&'static str),
        }
        let mut stack = vec![Job::Node(root)];
        while let Some(job) = stack.pop() {
            let id = match job {
                Job::Text(t) => {
                    out.push_str(t);
                    continue;
                }
                Job::Node(id) => id,
            };
            match &self.expr(id).kind {
                ExprKind::Num(t) | ExprKind::Name(t) => out.push_str(t),
                ExprKind::Neg(a) => {
                    out.push_str("(neg ");
                    stack.push(Job::Text(")"));
                    stack.push(Job::Node(*a));
                }
                ExprKind::Bin(op, a, b) => {
                    out.push('(');
                    out.push_str(op.symbol());
                    out.push(' ');
                    stack.push(Job::Text(")"));
                    stack.push(Job::Node(*b));
                    stack.push(Job::Text(" "));
                    stack.push(Job::Node(*a));
                }
                ExprKind::Call { name, args, .. } => {
                    out.push('(');
                    out.push_str(name);
                    stack.push(Job::Text(")"));
                    for &a in args.iter().rev() {
                        stack.push(Job::Node(a));
                        stack.push(Job::Text(" "));
                    }
                }
            }
        }
    }
}
