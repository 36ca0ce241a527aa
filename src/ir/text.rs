//! The IR's text form: printing ([`std::fmt::Display`] for [`Program`]) and
//! parsing back ([`parse`]). The format is described in the [`super`]
//! module doc; one instruction per line, `;` starts a comment.

use std::fmt;

use super::{BinOp, Const, Op, Program, UnOp, Value, Var};

impl fmt::Display for Const {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.value)?;
        if !self.is_exact() {
            write!(f, " [{:?}, {:?}]", self.lo, self.hi)?;
            if !self.defined {
                f.write_str(" undefined")?;
            }
        }
        Ok(())
    }
}

impl fmt::Display for Op {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Op::Var(v) => write!(f, "var {}", v.name()),
            Op::Const(c) => write!(f, "const {c}"),
            Op::Unary(u, a) => write!(f, "{} {a}", u.name()),
            Op::Binary(b, x, y) => write!(f, "{} {x} {y}", b.name()),
            Op::Powi(a, n) => write!(f, "powi {a} {n}"),
        }
    }
}

impl fmt::Display for Program {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, op) in self.insts.iter().enumerate() {
            writeln!(f, "v{i} = {op}")?;
        }
        writeln!(f, "output {}", self.output)
    }
}

/// A text-form parse error: 1-based line and a message.
#[derive(Clone, Debug, PartialEq)]
pub struct ParseError {
    /// The 1-based line of the error.
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

impl std::error::Error for ParseError {}

/// Parses the text form. Values must be defined in order (`vN` on line N of
/// the instructions), operands must be defined earlier, and exactly one
/// `output` line ends the program.
pub fn parse(text: &str) -> Result<Program, ParseError> {
    let mut insts = Vec::new();
    let mut output = None;
    for (ln, raw) in text.lines().enumerate() {
        let line = raw.split(';').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let err = |m: String| ParseError {
            line: ln + 1,
            message: m,
        };
        if output.is_some() {
            return Err(err("nothing may follow `output`".into()));
        }
        if let Some(rest) = line.strip_prefix("output") {
            let v = value(rest.trim(), insts.len()).map_err(err)?;
            output = Some(v);
            continue;
        }
        let (lhs, rhs) = line
            .split_once('=')
            .ok_or_else(|| err("expected `vN = op …` or `output vN`".into()))?;
        let expect = format!("v{}", insts.len());
        if lhs.trim() != expect {
            return Err(err(format!("expected `{expect}`, found `{}`", lhs.trim())));
        }
        insts.push(instruction(rhs.trim(), insts.len()).map_err(err)?);
    }
    let output = output.ok_or_else(|| ParseError {
        line: text.lines().count(),
        message: "missing `output`".into(),
    })?;
    Ok(Program { insts, output })
}

fn value(word: &str, defined: usize) -> Result<Value, String> {
    let n: u32 = word
        .strip_prefix('v')
        .and_then(|d| d.parse().ok())
        .ok_or_else(|| format!("expected a value `vN`, found `{word}`"))?;
    if n as usize >= defined {
        return Err(format!("`{word}` is used before it is defined"));
    }
    Ok(Value(n))
}

fn number(word: &str) -> Result<f64, String> {
    word.parse()
        .map_err(|_| format!("expected a number, found `{word}`"))
}

fn instruction(text: &str, defined: usize) -> Result<Op, String> {
    let mut words = text.split_whitespace();
    let name = words.next().ok_or("empty instruction")?;
    let rest: Vec<&str> = words.collect();
    let args = |k: usize| -> Result<(), String> {
        if rest.len() == k {
            Ok(())
        } else {
            Err(format!("`{name}` takes {k} operands, found {}", rest.len()))
        }
    };
    if name == "var" {
        args(1)?;
        let v = Var::ALL
            .into_iter()
            .find(|v| v.name() == rest[0])
            .ok_or_else(|| format!("unknown variable `{}`", rest[0]))?;
        return Ok(Op::Var(v));
    }
    if name == "const" {
        return constant(&rest).map(Op::Const);
    }
    if name == "powi" {
        args(2)?;
        let n = rest[1]
            .parse()
            .map_err(|_| format!("expected an integer exponent, found `{}`", rest[1]))?;
        return Ok(Op::Powi(value(rest[0], defined)?, n));
    }
    if let Some(u) = UnOp::ALL.into_iter().find(|u| u.name() == name) {
        args(1)?;
        return Ok(Op::Unary(u, value(rest[0], defined)?));
    }
    if let Some(b) = BinOp::ALL.into_iter().find(|b| b.name() == name) {
        args(2)?;
        return Ok(Op::Binary(
            b,
            value(rest[0], defined)?,
            value(rest[1], defined)?,
        ));
    }
    Err(format!("unknown instruction `{name}`"))
}

/// `c` or `c [lo, hi]` or `c [lo, hi] undefined`.
fn constant(words: &[&str]) -> Result<Const, String> {
    let joined = words.join(" ");
    let (value, rest) = match joined.split_once('[') {
        None => return Ok(Const::exact(number(joined.trim())?)),
        Some((v, rest)) => (number(v.trim())?, rest),
    };
    let (range, tail) = rest.split_once(']').ok_or("expected `]`")?;
    let (lo, hi) = range.split_once(',').ok_or("expected `lo, hi`")?;
    let defined = match tail.trim() {
        "" => true,
        "undefined" => false,
        other => return Err(format!("unexpected `{other}` after a constant")),
    };
    Ok(Const {
        value,
        lo: number(lo.trim())?,
        hi: number(hi.trim())?,
        defined,
    })
}
