//! The command line (SPEC §2): argument definitions and one function per
//! subcommand. Commands write to the `out`/`err` streams they are given and
//! return the process exit status; only `main` touches the real process.

use std::io::Write;
use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};
use serde_json::{Value as Json, json};

use crate::error::Error;
use crate::interval::Interval;
use crate::surface::{Bounds, CompileOptions, Surface};

/// isoc — compile and mesh implicit surfaces.
#[derive(Parser, Debug)]
#[command(name = "isoc", version, about)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// Options shared by the commands that compile a file.
#[derive(clap::Args, Debug, Clone)]
pub struct SourceArgs {
    /// The `.iso` file.
    pub file: PathBuf,
    /// Override a `param` (repeatable): `--set r=1.5`.
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// The domain `a,b,c,d,e,f` = [a,b]×[c,d]×[e,f]; replaces the file's.
    #[arg(long, value_name = "a,b,c,d,e,f", allow_hyphen_values = true)]
    pub domain: Option<String>,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Check a file, build its IR and print a summary (or one stage).
    Compile {
        #[command(flatten)]
        source: SourceArgs,
        /// Print one stage instead of the summary.
        #[arg(long, value_enum)]
        emit: Option<Emit>,
    },
    /// Value and gradient at a point, or their enclosures over a box.
    Eval {
        #[command(flatten)]
        source: SourceArgs,
        /// The point: X Y Z [T].
        #[arg(allow_negative_numbers = true, num_args = 0..=4)]
        coords: Vec<f64>,
        /// A box `a,b,c,d,e,f` instead of a point.
        #[arg(long = "box", value_name = "a,b,c,d,e,f", allow_hyphen_values = true)]
        bbox: Option<String>,
        /// Time for `--box` evaluation (default 0).
        #[arg(long, allow_negative_numbers = true)]
        t: Option<f64>,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
    },
}

/// Stages `compile --emit` can print.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Emit {
    Ast,
    Ir,
}

/// Runs a parsed command line; returns the exit status.
pub fn run(cli: Cli, out: &mut dyn Write, err: &mut dyn Write) -> i32 {
    let result = match cli.command {
        Command::Compile { source, emit } => compile(&source, emit, out),
        Command::Eval {
            source,
            coords,
            bbox,
            t,
            json,
        } => eval(&source, &coords, bbox.as_deref(), t, json, out),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            let _ = err.write_all(e.render().as_bytes());
            1
        }
    }
}

fn io_err(path: &str) -> impl Fn(std::io::Error) -> Error + '_ {
    move |error| Error::Io {
        path: path.to_string(),
        error,
    }
}

/// Parses `--set` and `--domain` into compile options.
fn options(args: &SourceArgs) -> Result<CompileOptions, Error> {
    let mut params = Vec::new();
    for s in &args.set {
        let (name, value) = s
            .split_once('=')
            .ok_or_else(|| Error::Usage(format!("--set `{s}`: expected NAME=VALUE")))?;
        let v: f64 = value
            .trim()
            .parse()
            .map_err(|_| Error::Usage(format!("--set `{s}`: `{value}` is not a number")))?;
        if !v.is_finite() {
            return Err(Error::Usage(format!(
                "--set `{s}`: the value is not finite"
            )));
        }
        params.push((name.trim().to_string(), v));
    }
    let domain = args.domain.as_deref().map(Bounds::parse).transpose()?;
    Ok(CompileOptions { params, domain })
}

fn load(args: &SourceArgs) -> Result<(String, Vec<u8>), Error> {
    let name = args.file.display().to_string();
    let bytes = std::fs::read(&args.file).map_err(io_err(&name))?;
    Ok((name, bytes))
}

fn compile_file(args: &SourceArgs) -> Result<Surface, Error> {
    let opts = options(args)?;
    let (name, bytes) = load(args)?;
    Surface::compile_bytes(&bytes, &name, &opts)
}

fn write(out: &mut dyn Write, text: &str) -> Result<(), Error> {
    out.write_all(text.as_bytes()).map_err(io_err("<stdout>"))
}

fn compile(args: &SourceArgs, emit: Option<Emit>, out: &mut dyn Write) -> Result<(), Error> {
    if emit == Some(Emit::Ast) {
        let (name, bytes) = load(args)?;
        let source = crate::syntax::source_from_bytes(&bytes, &name)?;
        return write(out, &crate::syntax::emit_ast(&source, &name)?);
    }
    let surface = compile_file(args)?;
    match emit {
        Some(Emit::Ir) => write(out, &surface.program.to_string()),
        _ => {
            let d = surface.domain;
            let mut s = format!(
                "{}: ok\n  IR: {} instructions\n  domain: [{}, {}] x [{}, {}] x [{}, {}]\n",
                surface.file,
                surface.program.len(),
                d.lo[0],
                d.hi[0],
                d.lo[1],
                d.hi[1],
                d.lo[2],
                d.hi[2]
            );
            for (name, v) in &surface.params {
                s += &format!("  param {name} = {v}\n");
            }
            write(out, &s)
        }
    }
}

/// A number for JSON: shortest round-trip form; non-finite values (which
/// JSON cannot hold) become `null`.
fn num(v: f64) -> Json {
    json!(v)
}

fn interval_json(iv: Interval) -> Json {
    json!([num(iv.lo), num(iv.hi)])
}

fn eval(
    args: &SourceArgs,
    coords: &[f64],
    bbox: Option<&str>,
    t: Option<f64>,
    as_json: bool,
    out: &mut dyn Write,
) -> Result<(), Error> {
    let surface = compile_file(args)?;
    let text = match bbox {
        Some(b) => {
            if !coords.is_empty() {
                return Err(Error::Usage(
                    "give either X Y Z [T] or --box, not both".into(),
                ));
            }
            let b = Bounds::parse(b)?;
            let t = t.unwrap_or(0.0);
            let [x, y, z] = b.sides();
            let g = surface.grad([x, y, z, Interval { lo: t, hi: t }]);
            if as_json {
                json!({
                    "value": interval_json(g.value),
                    "grad": g.grad.map(interval_json),
                    "defined": g.defined,
                })
                .to_string()
                    + "\n"
            } else {
                let iv = |i: Interval| format!("[{:?}, {:?}]", i.lo, i.hi);
                format!(
                    "value: {}\ngrad:  {} {} {}\ndefined on the whole box: {}\n",
                    iv(g.value),
                    iv(g.grad[0]),
                    iv(g.grad[1]),
                    iv(g.grad[2]),
                    g.defined
                )
            }
        }
        None => {
            if !(3..=4).contains(&coords.len()) {
                return Err(Error::Usage(
                    "eval needs a point X Y Z [T] or --box a,b,c,d,e,f".into(),
                ));
            }
            if t.is_some() {
                return Err(Error::Usage(
                    "--t goes with --box; give T after X Y Z".into(),
                ));
            }
            let p = [
                coords[0],
                coords[1],
                coords[2],
                *coords.get(3).unwrap_or(&0.0),
            ];
            let (v, g) = surface.point_grad(p);
            if as_json {
                json!({"value": num(v), "grad": g.map(num)}).to_string() + "\n"
            } else {
                format!("value: {v:?}\ngrad:  {:?} {:?} {:?}\n", g[0], g[1], g[2])
            }
        }
    };
    write(out, &text)
}
