//! Lowering a resolved AST to IR (or to an f64, for constants).
//!
//! # Contract
//!
//! [`lower_surface`] builds the [`Program`] of the surface `lhs` (or
//! `lhs - rhs`) with [`Builder`], inlining every function call. The walk is
//! an explicit task stack, never recursion. Each `let` is lowered once
//! (memoised), and so is each call of a function with the same argument
//! values; a work budget ([`WORK_LIMIT`] nodes of inlined bodies) turns
//! pathological inlining blow-ups into an error instead of a hang.
//!
//! Literals become [`Const`]s enclosing their exact decimal value
//! ([`Const::literal`]); `pi` is [`Const::pi`]; params are exact; `a ^ b` is [`Builder::power`],
//! `pow(a, b)` too; `min`/`max` of n arguments nest left to right.
//!
//! [`eval_const`] runs the same walk over an f64 [`Sink`] to evaluate
//! `param` values and domain bounds.
//!
//! # Layout
//!
//! [`Sink`] abstracts over the target (IR builder or f64); [`walk`] is the
//! task-stack lowering; [`literal`] gives the enclosure of a literal.

use super::ast::{Ast, BinKind, ExprId, ExprKind};
use super::names::{Builtin, Res, Resolved};
use crate::ir::{BinOp, Builder, Const, Program, UnOp, Value, Var};
use std::collections::HashMap;

/// Maximum number of function-body nodes visited while lowering one program
/// (inlining can multiply the size of the source exponentially; nodes outside
/// function bodies are lowered once each and are not counted).
pub(crate) const WORK_LIMIT: usize = 200_000;

/// A lowering target.
pub(crate) trait Sink {
    type V: Copy;
    /// A key identifying a value, for memoising function calls.
    fn key(&self, v: Self::V) -> u64;
    fn literal(&mut self, text: &str) -> Self::V;
    fn var(&mut self, v: Var) -> Self::V;
    fn pi(&mut self) -> Self::V;
    fn exact(&mut self, x: f64) -> Self::V;
    fn unary(&mut self, op: UnOp, a: Self::V) -> Self::V;
    fn binary(&mut self, op: BinOp, a: Self::V, b: Self::V) -> Self::V;
    fn power(&mut self, a: Self::V, b: Self::V) -> Self::V;
}

/// The enclosure of a decimal literal ([`Const::literal`]). Resolution has
/// already rejected literals that overflow, so the fallback (an undefined
/// NaN constant) is never reached for a checked program.
pub fn literal(text: &str) -> Const {
    Const::literal(text).unwrap_or(Const::exact(f64::NAN))
}

/// `pi` as a constant: its f64 and an enclosure of the real π.
pub(crate) fn pi_const() -> Const {
    Const::pi()
}

impl Sink for Builder {
    type V = Value;
    fn key(&self, v: Value) -> u64 {
        u64::from(v.0)
    }
    fn literal(&mut self, text: &str) -> Value {
        self.constant(literal(text))
    }
    fn var(&mut self, v: Var) -> Value {
        Builder::var(self, v)
    }
    fn pi(&mut self) -> Value {
        self.constant(pi_const())
    }
    fn exact(&mut self, x: f64) -> Value {
        self.constant(Const::exact(x))
    }
    fn unary(&mut self, op: UnOp, a: Value) -> Value {
        Builder::unary(self, op, a)
    }
    fn binary(&mut self, op: BinOp, a: Value, b: Value) -> Value {
        Builder::binary(self, op, a, b)
    }
    fn power(&mut self, a: Value, b: Value) -> Value {
        Builder::power(self, a, b)
    }
}

/// Point evaluation in f64, for constant expressions.
struct F64;

impl Sink for F64 {
    type V = f64;
    fn key(&self, v: f64) -> u64 {
        v.to_bits()
    }
    fn literal(&mut self, text: &str) -> f64 {
        text.parse().unwrap_or(f64::NAN)
    }
    fn var(&mut self, _: Var) -> f64 {
        f64::NAN
    }
    fn pi(&mut self) -> f64 {
        std::f64::consts::PI
    }
    fn exact(&mut self, x: f64) -> f64 {
        x
    }
    fn unary(&mut self, op: UnOp, a: f64) -> f64 {
        match op {
            UnOp::Neg => -a,
            UnOp::Abs => a.abs(),
            UnOp::Sqrt => a.sqrt(),
            UnOp::Square => a * a,
            UnOp::Exp => a.exp(),
            UnOp::Log => a.ln(),
            UnOp::Sin => a.sin(),
            UnOp::Cos => a.cos(),
            UnOp::Tan => a.tan(),
            UnOp::Asin => a.asin(),
            UnOp::Acos => a.acos(),
            UnOp::Atan => a.atan(),
            UnOp::Floor | UnOp::Ceil | UnOp::Round | UnOp::Not => {
                crate::ir::semantics::point_unary(op, a)
            }
        }
    }
    fn binary(&mut self, op: BinOp, a: f64, b: f64) -> f64 {
        match op {
            BinOp::Add => a + b,
            BinOp::Sub => a - b,
            BinOp::Mul => a * b,
            BinOp::Div => a / b,
            BinOp::Min => a.min(b),
            BinOp::Max => a.max(b),
            BinOp::Atan2 => a.atan2(b),
            BinOp::Pow => self.power(a, b),
            BinOp::Compare | BinOp::Mod | BinOp::And | BinOp::Or => {
                crate::ir::semantics::point_binary(op, a, b)
            }
        }
    }
    fn power(&mut self, a: f64, b: f64) -> f64 {
        if b.fract() == 0.0 || a > 0.0 {
            a.powf(b)
        } else {
            f64::NAN
        }
    }
}

/// Evaluates a constant expression (resolved in a constant context: no
/// coordinates, lets or fns) in f64. `params` are the param values so far.
pub(crate) fn eval_const(ast: &Ast, res: &[Res], e: ExprId, params: &[f64]) -> f64 {
    let t = Tables {
        res,
        lets: &[],
        fns: &[],
        params,
    };
    let mut memo = Vec::new();
    let mut work = 0;
    walk(ast, &t, e, &mut F64, &mut memo, &mut work).unwrap_or(f64::NAN)
}

/// Why lowering failed: inlining exceeded [`WORK_LIMIT`] (or, for an
/// unchecked AST, there is no surface or a name was left unresolved).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct TooLarge;

/// The program of the resolved surface. See [`TooLarge`].
pub(crate) fn lower_surface(ast: &Ast, r: &Resolved) -> Result<Program, TooLarge> {
    let (lhs, rhs, _) = r.surface.clone().ok_or(TooLarge)?;
    let params: Vec<f64> = r.params.iter().map(|p| p.1).collect();
    let fns: Vec<ExprId> = r.fns.iter().map(|f| f.body).collect();
    let t = Tables {
        res: &r.res,
        lets: &r.lets,
        fns: &fns,
        params: &params,
    };
    let mut b = Builder::new();
    let mut memo: Vec<Option<Value>> = vec![None; r.lets.len()];
    let mut work = 0;
    let mut out = walk(ast, &t, lhs, &mut b, &mut memo, &mut work).map_err(|()| TooLarge)?;
    if let Some(rhs) = rhs {
        let rv = walk(ast, &t, rhs, &mut b, &mut memo, &mut work).map_err(|()| TooLarge)?;
        out = b.binary(BinOp::Sub, out, rv);
    }
    Ok(b.finish(out))
}

/// What the walk needs besides the AST.
struct Tables<'r> {
    res: &'r [Res],
    /// Let bodies.
    lets: &'r [ExprId],
    /// Fn bodies.
    fns: &'r [ExprId],
    params: &'r [f64],
}

enum Task {
    Eval(ExprId, u32),
    Apply(ExprId),
    SetLet(usize),
    SetCall(usize, Vec<u64>),
}

/// Lowers `root` into `sink`; `memo` holds the lowered lets (env 0 is
/// the top level, one env per inlined call holds its argument values).
fn walk<S: Sink>(
    ast: &Ast,
    t: &Tables<'_>,
    root: ExprId,
    sink: &mut S,
    memo: &mut Vec<Option<S::V>>,
    work: &mut usize,
) -> Result<S::V, ()> {
    let (res, lets, params) = (t.res, t.lets, t.params);
    memo.resize(lets.len().max(memo.len()), None);
    let mut envs: Vec<Vec<S::V>> = vec![Vec::new()];
    let mut calls: HashMap<(usize, Vec<u64>), S::V> = HashMap::new();
    let mut vals: Vec<S::V> = Vec::new();
    let mut literals: HashMap<&str, S::V> = HashMap::new();
    let mut tasks = vec![Task::Eval(root, 0)];
    while let Some(task) = tasks.pop() {
        match task {
            Task::Eval(id, env) => {
                // Top-level nodes are visited once each (lets are memoised),
                // so only nodes of inlined function bodies count.
                if env != 0 {
                    *work += 1;
                    if *work > WORK_LIMIT {
                        return Err(());
                    }
                }
                let r = res.get(id.index()).copied().unwrap_or(Res::None);
                match &ast.expr(id).kind {
                    ExprKind::Num(text) => {
                        // Enclosing a literal exactly is not cheap: once per text.
                        let v = match literals.get(text.as_str()) {
                            Some(&v) => v,
                            None => {
                                let v = sink.literal(text);
                                literals.insert(text.as_str(), v);
                                v
                            }
                        };
                        vals.push(v);
                    }
                    ExprKind::Name(_) => {
                        let v = match r {
                            Res::Coord(v) => sink.var(v),
                            Res::Pi => sink.pi(),
                            Res::Param(i) => sink.exact(params.get(i).copied().ok_or(())?),
                            Res::FnParam(i) => *envs[env as usize].get(i).ok_or(())?,
                            Res::Let(i) => match memo.get(i).copied().flatten() {
                                Some(v) => v,
                                None => {
                                    tasks.push(Task::SetLet(i));
                                    tasks.push(Task::Eval(*lets.get(i).ok_or(())?, 0));
                                    continue;
                                }
                            },
                            Res::None | Res::Builtin(_) | Res::Fn(_) => return Err(()),
                        };
                        vals.push(v);
                    }
                    ExprKind::Neg(a) => {
                        tasks.push(Task::Apply(id));
                        tasks.push(Task::Eval(*a, env));
                    }
                    ExprKind::Bin(_, a, b) => {
                        tasks.push(Task::Apply(id));
                        tasks.push(Task::Eval(*b, env));
                        tasks.push(Task::Eval(*a, env));
                    }
                    ExprKind::Call { args, .. } => {
                        tasks.push(Task::Apply(id));
                        for a in args.iter().rev() {
                            tasks.push(Task::Eval(*a, env));
                        }
                    }
                }
            }
            Task::Apply(id) => match &ast.expr(id).kind {
                ExprKind::Neg(_) => {
                    let a = vals.pop().ok_or(())?;
                    vals.push(sink.unary(UnOp::Neg, a));
                }
                ExprKind::Bin(op, _, _) => {
                    let b = vals.pop().ok_or(())?;
                    let a = vals.pop().ok_or(())?;
                    let v = match op {
                        BinKind::Add => sink.binary(BinOp::Add, a, b),
                        BinKind::Sub => sink.binary(BinOp::Sub, a, b),
                        BinKind::Mul => sink.binary(BinOp::Mul, a, b),
                        BinKind::Div => sink.binary(BinOp::Div, a, b),
                        BinKind::Pow => sink.power(a, b),
                    };
                    vals.push(v);
                }
                ExprKind::Call { args, .. } => {
                    let n = args.len();
                    if vals.len() < n {
                        return Err(());
                    }
                    let argv = vals.split_off(vals.len() - n);
                    match res.get(id.index()).copied().unwrap_or(Res::None) {
                        Res::Builtin(b) => vals.push(builtin(sink, b, &argv).ok_or(())?),
                        Res::Fn(i) => {
                            let key: Vec<u64> = argv.iter().map(|&v| sink.key(v)).collect();
                            if let Some(&v) = calls.get(&(i, key.clone())) {
                                vals.push(v);
                                continue;
                            }
                            let body = *t.fns.get(i).ok_or(())?;
                            let env = u32::try_from(envs.len()).map_err(|_| ())?;
                            envs.push(argv);
                            tasks.push(Task::SetCall(i, key));
                            tasks.push(Task::Eval(body, env));
                        }
                        _ => return Err(()),
                    }
                }
                ExprKind::Num(_) | ExprKind::Name(_) => return Err(()),
            },
            Task::SetLet(i) => {
                let v = *vals.last().ok_or(())?;
                if let Some(m) = memo.get_mut(i) {
                    *m = Some(v);
                }
            }
            Task::SetCall(i, key) => {
                let v = *vals.last().ok_or(())?;
                calls.insert((i, key), v);
            }
        }
    }
    match vals.as_slice() {
        [v] => Ok(*v),
        _ => Err(()),
    }
}

fn builtin<S: Sink>(sink: &mut S, b: Builtin, args: &[S::V]) -> Option<S::V> {
    Some(match (b, args) {
        (Builtin::Unary(op), [a]) => sink.unary(op, *a),
        (Builtin::Atan2, [a, b]) => sink.binary(BinOp::Atan2, *a, *b),
        (Builtin::Pow, [a, b]) => sink.power(*a, *b),
        (Builtin::Min | Builtin::Max, [first, rest @ ..]) if !rest.is_empty() => {
            let op = if b == Builtin::Min {
                BinOp::Min
            } else {
                BinOp::Max
            };
            rest.iter().fold(*first, |acc, &v| sink.binary(op, acc, v))
        }
        _ => return None,
    })
}
