//! Name resolution and the semantic checks of SPEC §1.
//!
//! # Contract
//!
//! [`resolve`] walks the statements in source order and, for every name and
//! call node, records what it refers to ([`Res`], indexed by [`ExprId`]).
//! It never stops at the first problem: each one becomes a [`Diagnostic`]
//! with the span of the offending name or statement. Checked here:
//!
//! - unknown names and functions (with a "did you mean" help when a visible
//!   name is close), names used before their definition, wrong argument
//!   counts, recursion (a function may only call earlier functions; a call to
//!   itself or to a later function that leads back is reported as
//!   recursion), redefinitions, duplicate fn parameters;
//! - `let`/`param`/`fn` named like a coordinate (`x y z t`), `pi` or a
//!   built-in function (fn *parameters* may shadow `x y z t`);
//! - missing or duplicate `surface`; missing (unless `--domain`) or
//!   duplicate `domain`; domain shape, empty, inverted or non-finite bounds;
//! - number literals that overflow to infinity;
//! - `param` values and domain bounds must be constant: numbers, `pi`,
//!   earlier params, operators and built-ins. They are evaluated here (in
//!   f64, through [`super::lower::eval_const`]); `--set` overrides a param.
//!
//! Expression walks use an explicit stack (no recursion).

use super::CompileOptions;
use super::ast::{Ast, ExprId, ExprKind, Ident, Span, StmtKind};
use super::diag::Diagnostic;
use super::diag::closest;
use super::lower::eval_const;
use super::names::{BUILTINS, Builtin, FnDef, Res, Resolved};
use crate::geometry::Bounds;
use crate::ir::Var;
use std::collections::HashMap;

fn builtin(name: &str) -> Option<Builtin> {
    BUILTINS.iter().find(|(n, _)| *n == name).map(|&(_, b)| b)
}

fn coordinate(name: &str) -> Option<Var> {
    Var::ALL.into_iter().find(|v| v.name() == name)
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Let,
    Param,
    Fn,
}

impl Kind {
    fn word(self) -> &'static str {
        match self {
            Kind::Let => "let",
            Kind::Param => "param",
            Kind::Fn => "fn",
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Global {
    res: Res,
    kind: Kind,
    start: usize,
}

/// Where an expression is, which decides the names it may use.
#[derive(Clone, Copy)]
enum Ctx<'c> {
    /// A `param` value or a domain bound: numbers, `pi`, earlier params.
    Const(&'static str),
    /// A `let` or `surface`: coordinates, earlier lets/params/fns.
    Top,
    /// The body of fn number `index` with these parameters.
    Fn { index: usize, params: &'c [Ident] },
}

struct Resolver<'a> {
    ast: &'a Ast,
    source: &'a str,
    diags: Vec<Diagnostic>,
    out: Resolved,
    globals: HashMap<String, Global>,
    /// Every definition in the file (first one per name), for "used before
    /// its definition".
    all_defs: HashMap<String, (Kind, usize)>,
    /// For fn number k (in source order): the names its body calls.
    callees: Vec<Vec<String>>,
    fn_index: HashMap<String, usize>,
    /// Members (sorted) of the call cycles already reported.
    cycles: Vec<Vec<usize>>,
    /// Names of all fns, in source order.
    fn_names: Vec<String>,
    /// Byte offset of the start of every line.
    line_starts: Vec<usize>,
    /// False when the file had syntax errors.
    complete: bool,
}

/// Resolves and checks `ast`. `complete` is false when the file had syntax
/// errors (then a missing `surface`/`domain` is not reported: it may be in
/// the statement that failed to parse). Diagnostics are appended to `diags`.
pub fn resolve(
    ast: &Ast,
    source: &str,
    opts: &CompileOptions,
    complete: bool,
    diags: &mut Vec<Diagnostic>,
) -> Resolved {
    let mut r = Resolver {
        ast,
        source,
        diags: Vec::new(),
        out: Resolved {
            res: vec![Res::None; ast.exprs.len()],
            ..Resolved::default()
        },
        globals: HashMap::new(),
        all_defs: HashMap::new(),
        callees: Vec::new(),
        fn_index: HashMap::new(),
        cycles: Vec::new(),
        fn_names: Vec::new(),
        complete,
        line_starts: std::iter::once(0)
            .chain(source.match_indices('\n').map(|(i, _)| i + 1))
            .collect(),
    };
    r.prepass();
    r.run(opts, complete);
    diags.append(&mut r.diags);
    r.out
}

impl Resolver<'_> {
    /// 1-based line number of byte `pos` (binary search in the line starts).
    fn line_of(&self, pos: usize) -> usize {
        self.line_starts.partition_point(|&s| s <= pos).max(1)
    }

    /// True when `name` is declared by a statement that failed to parse: an
    /// "unknown name" error for it would only repeat that syntax error.
    fn cascade(&self, name: &str) -> bool {
        !self.complete && self.ast.declared.contains(name)
    }

    /// Whether to spend time on a "did you mean" search: not once the error
    /// count is past what will be shown (keeps hostile files linear).
    fn suggest(&self) -> bool {
        self.diags.len() < super::MAX_DIAGNOSTICS
    }

    fn error(&mut self, msg: impl Into<String>, span: Span) {
        self.diags.push(Diagnostic::new(msg, span));
    }

    /// Collects all definitions and the call graph of the functions.
    fn prepass(&mut self) {
        for s in &self.ast.stmts {
            let (name, kind) = match &s.kind {
                StmtKind::Let { name, .. } => (name, Kind::Let),
                StmtKind::Param { name, .. } => (name, Kind::Param),
                StmtKind::Fn { name, body, .. } => {
                    let mut called: Vec<String> = Vec::new();
                    for id in subtree(self.ast, *body) {
                        if let ExprKind::Call { name, .. } = &self.ast.expr(id).kind
                            && !called.contains(name)
                        {
                            called.push(name.clone());
                        }
                    }
                    self.fn_index
                        .entry(name.name.clone())
                        .or_insert(self.callees.len());
                    self.callees.push(called);
                    self.fn_names.push(name.name.clone());
                    (name, Kind::Fn)
                }
                _ => continue,
            };
            self.all_defs
                .entry(name.name.clone())
                .or_insert((kind, name.span.start));
        }
    }

    fn run(&mut self, opts: &CompileOptions, complete: bool) {
        let ast = self.ast;
        let mut first_surface: Option<usize> = None;
        let mut first_domain: Option<usize> = None;
        for s in &ast.stmts {
            match &s.kind {
                StmtKind::Domain { ranges, power } => {
                    self.domain(ranges, power, s.span.clone(), first_domain.is_none());
                    if let Some(first) = first_domain {
                        let line = self.line_of(first);
                        self.diags.push(
                            Diagnostic::new("duplicate `domain` statement", s.span.clone())
                                .with_note(format!("note: the first `domain` is on line {line}")),
                        );
                    } else {
                        first_domain = Some(s.span.start);
                    }
                }
                StmtKind::Let { name, value } => {
                    self.walk(*value, Ctx::Top);
                    let i = self.out.lets.len();
                    self.out.lets.push(*value);
                    self.define(name, Kind::Let, Res::Let(i));
                }
                StmtKind::Param { name, value } => {
                    let ok = self.walk(*value, Ctx::Const("a `param` value"));
                    let over = opts.params.iter().rev().find(|(n, _)| *n == name.name);
                    let v = match over {
                        Some(&(_, v)) => v,
                        None if ok => self.constant(*value, "param value"),
                        None => f64::NAN,
                    };
                    let i = self.out.params.len();
                    self.out.params.push((name.name.clone(), v));
                    self.define(name, Kind::Param, Res::Param(i));
                }
                StmtKind::Fn { name, params, body } => {
                    let index = self.out.fns.len();
                    for (k, p) in params.iter().enumerate() {
                        if params[..k].iter().any(|q| q.name == p.name) {
                            self.error(
                                format!("duplicate parameter `{}` in `fn {}`", p.name, name.name),
                                p.span.clone(),
                            );
                        }
                    }
                    self.walk(*body, Ctx::Fn { index, params });
                    self.out.fns.push(FnDef {
                        name: name.name.clone(),
                        arity: params.len(),
                        body: *body,
                    });
                    self.define(name, Kind::Fn, Res::Fn(index));
                }
                StmtKind::Surface { lhs, rhs } => {
                    self.walk(*lhs, Ctx::Top);
                    if let Some(r) = rhs {
                        self.walk(*r, Ctx::Top);
                    }
                    if let Some(first) = first_surface {
                        let line = self.line_of(first);
                        self.diags.push(
                            Diagnostic::new("duplicate `surface` statement", s.span.clone())
                                .with_note(format!(
                                    "note: the first `surface` is on line {line}; a file defines exactly one surface"
                                )),
                        );
                    } else {
                        first_surface = Some(s.span.start);
                        self.out.surface = Some((*lhs, *rhs, s.span.clone()));
                    }
                }
            }
        }
        if complete {
            let end = self.source.len();
            if first_domain.is_none() && opts.domain.is_none() {
                self.diags.push(
                    Diagnostic::new("missing `domain` statement", 0..0)
                        .with_note("help: add one, e.g. `domain [-2, 2]^3;`, or give `--domain`"),
                );
            }
            if first_surface.is_none() {
                self.diags.push(
                    Diagnostic::new("missing `surface` statement", end..end)
                        .with_note("help: add one, e.g. `surface x^2 + y^2 + z^2 = 1;`"),
                );
            }
        }
    }

    /// Registers a definition, reporting redefinitions and reserved names.
    fn define(&mut self, name: &Ident, kind: Kind, res: Res) {
        let n = name.name.as_str();
        let word = kind.word();
        if coordinate(n).is_some() {
            self.error(
                format!("cannot define `{n}` with `{word}`: `{n}` is a coordinate"),
                name.span.clone(),
            );
        } else if n == "pi" {
            self.error(
                format!("cannot define `pi` with `{word}`: it is a built-in constant"),
                name.span.clone(),
            );
        } else if builtin(n).is_some() {
            self.error(
                format!("cannot define `{n}` with `{word}`: it is a built-in function"),
                name.span.clone(),
            );
        } else if let Some(g) = self.globals.get(n) {
            let (line, first) = (self.line_of(g.start), g.kind.word());
            self.diags.push(
                Diagnostic::new(format!("redefinition of `{n}`"), name.span.clone()).with_note(
                    format!("note: `{n}` was first defined (by `{first}`) on line {line}"),
                ),
            );
            return;
        }
        self.globals.entry(n.to_string()).or_insert(Global {
            res,
            kind,
            start: name.span.start,
        });
    }

    /// Evaluates a resolved constant expression; reports non-finite values.
    fn constant(&mut self, e: ExprId, what: &str) -> f64 {
        let params: Vec<f64> = self.out.params.iter().map(|p| p.1).collect();
        let v = eval_const(self.ast, &self.out.res, e, &params);
        if !v.is_finite() {
            self.error(
                format!("{what} is not a finite number (it evaluates to {v})"),
                self.ast.expr(e).span.clone(),
            );
        }
        v
    }

    fn domain(
        &mut self,
        ranges: &[(ExprId, ExprId)],
        power: &Option<(String, Span)>,
        span: Span,
        first: bool,
    ) {
        let mut ok = true;
        for &(a, b) in ranges {
            ok &= self.walk(a, Ctx::Const("a domain bound"));
            ok &= self.walk(b, Ctx::Const("a domain bound"));
        }
        match power {
            Some((p, pspan)) => {
                if p.parse::<f64>().ok() != Some(3.0) {
                    ok = false;
                    self.error(
                        format!("a domain is three-dimensional: write `^3`, not `^{p}`"),
                        pspan.clone(),
                    );
                } else if ranges.len() != 1 {
                    ok = false;
                    self.error("`^3` applies to a single range: `domain [a, b]^3;`", span);
                }
            }
            None if ranges.len() != 3 => {
                ok = false;
                self.diags.push(
                    Diagnostic::new(
                        format!("a domain needs three ranges, found {}", ranges.len()),
                        span,
                    )
                    .with_note(
                        "help: write `domain [a, b]^3;` or `domain [a, b], [c, d], [e, f];`",
                    ),
                );
            }
            None => {}
        }
        if !ok {
            return;
        }
        let mut lo = [0.0; 3];
        let mut hi = [0.0; 3];
        for (i, &(a, b)) in ranges.iter().enumerate() {
            let va = self.constant(a, "a domain bound");
            let vb = self.constant(b, "a domain bound");
            if !va.is_finite() || !vb.is_finite() {
                ok = false;
                continue;
            }
            let rspan = self.ast.expr(a).span.start..self.ast.expr(b).span.end;
            if va > vb {
                ok = false;
                self.error(
                    format!("inverted domain: lower bound {va} is greater than upper bound {vb}"),
                    rspan,
                );
            } else if va == vb {
                ok = false;
                self.error(
                    format!("empty domain: the range [{va}, {vb}] has zero width"),
                    rspan,
                );
            }
            lo[i] = va;
            hi[i] = vb;
        }
        if ranges.len() == 1 {
            lo = [lo[0]; 3];
            hi = [hi[0]; 3];
        }
        if ok && first {
            self.out.domain = Some(Bounds { lo, hi });
        }
    }

    /// Resolves every name/call node under `root`; true if no error.
    fn walk(&mut self, root: ExprId, ctx: Ctx<'_>) -> bool {
        let before = self.diags.len();
        let ast = self.ast;
        for id in subtree(ast, root) {
            let e = ast.expr(id);
            match &e.kind {
                ExprKind::Num(text) => {
                    let v: f64 = text.parse().unwrap_or(f64::NAN);
                    if !v.is_finite() {
                        self.diags.push(
                            Diagnostic::new(
                                format!("number `{text}` is too large: it overflows to infinity"),
                                e.span.clone(),
                            )
                            .with_note("note: the largest finite number is about 1.8e308"),
                        );
                    }
                }
                ExprKind::Name(name) => {
                    let r = self.name(name, e.span.clone(), ctx);
                    self.out.res[id.index()] = r;
                }
                ExprKind::Call {
                    name,
                    name_span,
                    args,
                } => {
                    let r = self.call(name, name_span.clone(), args.len(), ctx);
                    self.out.res[id.index()] = r;
                }
                ExprKind::Neg(_) | ExprKind::Bin(..) => {}
            }
        }
        self.diags.len() == before
    }

    /// Names visible in `ctx` (for "did you mean").
    fn visible<'s>(&'s self, ctx: Ctx<'s>, functions: bool) -> Vec<&'s str> {
        let mut v: Vec<&str> = Vec::new();
        if functions {
            v.extend(BUILTINS.iter().map(|b| b.0));
            if !matches!(ctx, Ctx::Const(_)) {
                for (n, g) in &self.globals {
                    if g.kind == Kind::Fn {
                        v.push(n);
                    }
                }
            }
            return v;
        }
        v.push("pi");
        match ctx {
            Ctx::Const(_) => {
                for (n, g) in &self.globals {
                    if g.kind == Kind::Param {
                        v.push(n);
                    }
                }
            }
            Ctx::Top | Ctx::Fn { .. } => {
                v.extend(["x", "y", "z", "t"]);
                for (n, g) in &self.globals {
                    if g.kind != Kind::Fn {
                        v.push(n);
                    }
                }
                if let Ctx::Fn { params, .. } = ctx {
                    v.extend(params.iter().map(|p| p.name.as_str()));
                }
            }
        }
        v.sort_unstable();
        v
    }

    fn name(&mut self, name: &str, span: Span, ctx: Ctx<'_>) -> Res {
        if let Ctx::Fn { params, .. } = ctx
            && let Some(i) = params.iter().position(|p| p.name == name)
        {
            return Res::FnParam(i);
        }
        if let Some(v) = coordinate(name) {
            if let Ctx::Const(what) = ctx {
                self.error(
                    format!("{what} must be constant, but `{name}` is a coordinate"),
                    span,
                );
                return Res::None;
            }
            return Res::Coord(v);
        }
        if name == "pi" {
            return Res::Pi;
        }
        if let Some(g) = self.globals.get(name).copied() {
            return match (g.kind, ctx) {
                (Kind::Fn, _) => {
                    self.error(
                        format!("`{name}` is a function: call it with arguments, `{name}(…)`"),
                        span,
                    );
                    Res::None
                }
                (Kind::Let, Ctx::Const(what)) => {
                    self.error(
                        format!("{what} must be constant: it may use numbers, `pi` and params, not the `let` `{name}`"),
                        span,
                    );
                    Res::None
                }
                _ => g.res,
            };
        }
        if builtin(name).is_some() {
            self.error(
                format!("`{name}` is a built-in function: call it with arguments, `{name}(…)`"),
                span,
            );
            return Res::None;
        }
        if let Some(&(kind, start)) = self.all_defs.get(name) {
            let line = self.line_of(start);
            self.diags.push(
                Diagnostic::new(format!("`{name}` is used before its definition"), span)
                    .with_note(format!(
                        "note: `{name}` is defined (by `{}`) later, on line {line}; a statement may only use names defined before it",
                        kind.word()
                    )),
            );
            return Res::None;
        }
        if self.cascade(name) {
            return Res::None;
        }
        let mut d = Diagnostic::new(format!("unknown name `{name}`"), span);
        if self.suggest()
            && let Some(c) = closest(name, self.visible(ctx, false))
        {
            d = d.with_note(format!("help: did you mean `{c}`?"));
        }
        self.diags.push(d);
        Res::None
    }

    fn call(&mut self, name: &str, span: Span, n: usize, ctx: Ctx<'_>) -> Res {
        if let Some(b) = builtin(name) {
            let want = match b {
                Builtin::Unary(_) => Some(1),
                Builtin::Atan2 | Builtin::Pow => Some(2),
                Builtin::Min | Builtin::Max => None,
            };
            match want {
                Some(k) if k != n => {
                    self.error(
                        format!("`{name}` takes {} but {} given", args(k), given(n)),
                        span,
                    );
                    return Res::None;
                }
                None if n < 2 => {
                    self.error(
                        format!("`{name}` takes at least 2 arguments but {} given", given(n)),
                        span,
                    );
                    return Res::None;
                }
                _ => return Res::Builtin(b),
            }
        }
        if let Some(g) = self.globals.get(name).copied() {
            if let Res::Fn(i) = g.res {
                if matches!(ctx, Ctx::Const(_)) {
                    self.error(
                        format!(
                            "{} must be constant: it may not call the function `{name}`",
                            ctx_what(ctx)
                        ),
                        span,
                    );
                    return Res::None;
                }
                let k = self.out.fns[i].arity;
                if k != n {
                    self.error(
                        format!("`{name}` takes {} but {} given", args(k), given(n)),
                        span,
                    );
                    return Res::None;
                }
                return g.res;
            }
            self.error(
                format!("`{name}` is not a function (it is a `{}`)", g.kind.word()),
                span,
            );
            return Res::None;
        }
        if let Ctx::Fn { index, params } = ctx {
            if self.out.fns.len() == index && self.fn_name(index) == Some(name) {
                self.error(format!("recursion: function `{name}` calls itself"), span);
                return Res::None;
            }
            if params.iter().any(|p| p.name == name) {
                self.error(format!("`{name}` is a parameter, not a function"), span);
                return Res::None;
            }
            if let Some(&target) = self.fn_index.get(name)
                && let Some(path) = self.path(target, index)
            {
                let mut members = path.clone();
                members.sort_unstable();
                if self.cycles.contains(&members) {
                    return Res::None;
                }
                self.cycles.push(members);
                let mut chain: Vec<String> =
                    vec![format!("`{}`", self.fn_name(index).unwrap_or("?"))];
                chain.extend(
                    path.iter()
                        .map(|&k| format!("`{}`", self.fn_name(k).unwrap_or("?"))),
                );
                self.diags.push(
                    Diagnostic::new(
                        format!("recursion: {}", chain.join(" calls ")),
                        span,
                    )
                    .with_note("note: functions may not call themselves, directly or through other functions"),
                );
                return Res::None;
            }
        }
        if coordinate(name).is_some() || name == "pi" {
            self.error(format!("`{name}` is not a function"), span);
            return Res::None;
        }
        if let Some(&(kind, start)) = self.all_defs.get(name) {
            let line = self.line_of(start);
            let msg = if kind == Kind::Fn {
                format!("function `{name}` is called before its definition")
            } else {
                format!("`{name}` is not a function (it is a `{}`)", kind.word())
            };
            self.diags.push(Diagnostic::new(msg, span).with_note(format!(
                "note: `{name}` is defined on line {line}; a function may only call functions defined before it"
            )));
            return Res::None;
        }
        if self.cascade(name) {
            return Res::None;
        }
        let mut d = Diagnostic::new(format!("unknown function `{name}`"), span);
        if self.suggest()
            && let Some(c) = closest(name, self.visible(ctx, true))
        {
            d = d.with_note(format!("help: did you mean `{c}`?"));
        }
        self.diags.push(d);
        Res::None
    }

    fn fn_name(&self, k: usize) -> Option<&str> {
        self.fn_names.get(k).map(String::as_str)
    }

    /// A call path `from → … → to` in the call graph (breadth first), as the
    /// list of fn indices after `from`'s caller, ending with `to`.
    fn path(&self, from: usize, to: usize) -> Option<Vec<usize>> {
        let mut parent: HashMap<usize, usize> = HashMap::new();
        let mut queue = std::collections::VecDeque::from([from]);
        let mut seen = vec![false; self.callees.len()];
        seen[from] = true;
        while let Some(k) = queue.pop_front() {
            if k == to {
                let mut path = vec![k];
                let mut c = k;
                while let Some(&p) = parent.get(&c) {
                    path.push(p);
                    c = p;
                }
                path.reverse();
                return Some(path);
            }
            for callee in &self.callees[k] {
                if let Some(&j) = self.fn_index.get(callee)
                    && !seen[j]
                {
                    seen[j] = true;
                    parent.insert(j, k);
                    queue.push_back(j);
                }
            }
        }
        None
    }
}

fn ctx_what(ctx: Ctx<'_>) -> &'static str {
    match ctx {
        Ctx::Const(w) => w,
        _ => "this expression",
    }
}

fn args(k: usize) -> String {
    if k == 1 {
        "1 argument".into()
    } else {
        format!("{k} arguments")
    }
}

fn given(n: usize) -> String {
    if n == 1 {
        "1 was".into()
    } else {
        format!("{n} were")
    }
}

/// All node ids of the subtree under `root` (pre-order), without recursion.
pub(crate) fn subtree(ast: &Ast, root: ExprId) -> Vec<ExprId> {
    let mut out = Vec::new();
    let mut stack = vec![root];
    while let Some(id) = stack.pop() {
        out.push(id);
        match &ast.expr(id).kind {
            ExprKind::Num(_) | ExprKind::Name(_) => {}
            ExprKind::Neg(a) => stack.push(*a),
            ExprKind::Bin(_, a, b) => {
                stack.push(*b);
                stack.push(*a);
            }
            ExprKind::Call { args, .. } => stack.extend(args.iter().rev()),
        }
    }
    out
}
