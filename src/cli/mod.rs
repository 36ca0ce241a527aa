//! The command line (SPEC §2): argument definitions and one function per
//! subcommand. Commands write to the `out`/`err` streams they are given and
//! return the process exit status; only `main` touches the real process.

mod animate;
mod bricks;
mod error;

use std::io::Write;
use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};
use serde_json::{Value as Json, json};

use error::Error;
use isoc::interval::Interval;
use isoc::{Bounds, CompileOptions, Surface};

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
    /// The `.iso` file (or a Fidget `.vm` model, by its extension).
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
    /// Mesh the surface with the robust adaptive mesher.
    Mesh {
        #[command(flatten)]
        source: SourceArgs,
        #[command(flatten)]
        mesh: MeshArgs,
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
    /// Weld part files (`mesh --bricks B --brick I`) into one mesh.
    Merge {
        /// The parts, in any order.
        #[arg(required = true)]
        parts: Vec<PathBuf>,
        /// Output file: .ply, .obj, .stl, .glb or .3mf.
        #[arg(short = 'o', long = "output", required = true)]
        output: PathBuf,
        /// Unit of a .3mf output (as `mesh --unit`).
        #[arg(long, default_value = "millimeter")]
        unit: String,
        /// Print statistics on stdout: `--stats json`.
        #[arg(long, value_enum)]
        stats: Option<StatsFormat>,
    },
    /// Track a surface in `t` with twinned meshes, frame by frame.
    Animate {
        #[command(flatten)]
        source: SourceArgs,
        #[command(flatten)]
        animate: animate::AnimateArgs,
    },
}

/// Options of `isoc mesh`.
#[derive(clap::Args, Debug, Clone)]
pub struct MeshArgs {
    /// Maximal octree level [default: 7, or 10 with --tolerance].
    #[arg(long, value_parser = clap::value_parser!(u8).range(0..=20))]
    pub level: Option<u8>,
    /// Refine until every measured triangle point lies within D (domain
    /// units) of the surface, with --level as the cap.
    #[arg(long, value_name = "D")]
    pub tolerance: Option<f64>,
    /// Uniform subdivision level to start from (at most --level).
    #[arg(long = "min-level", default_value_t = 3)]
    pub min_level: u8,
    /// Geometry criterion: subdivide while the normals' spread exceeds K
    /// [default: 1]. Given, it replaces the faithful default (the chord
    /// criterion, see --coarse).
    #[arg(long, value_name = "K")]
    pub kmax: Option<f64>,
    /// The adaptive minimum: only the topology and geometry (--kmax)
    /// criteria, without the default chord criterion that makes --level
    /// as faithful as a uniform mesher at that depth.
    #[arg(long)]
    pub coarse: bool,
    /// Smoothing passes (edge flips, then tangential relaxation onto the
    /// surface).
    #[arg(long, default_value_t = 3)]
    pub smooth: usize,
    /// Stricter topology test (Plantinga–Vegter small normal variation).
    #[arg(long)]
    pub certify: bool,
    /// Evaluate every octree cell with the full program (no per-cell
    /// pruning of min/max branches).
    #[arg(long = "no-prune")]
    pub no_prune: bool,
    /// Leave sharp creases (CSG edges and corners) cut off as marching
    /// cubes makes them, instead of putting vertices on them.
    #[arg(long = "no-creases")]
    pub no_creases: bool,
    /// Time at which a surface in `t` is meshed.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub t: f64,
    /// Output file: .ply, .obj, .stl, .glb or .3mf (default: the input's
    /// stem .ply).
    #[arg(short = 'o', long = "output")]
    pub output: Option<PathBuf>,
    /// Unit of a .3mf output: micron, millimeter, centimeter, inch, foot
    /// or meter (one domain unit is one of these; other formats have no
    /// unit).
    #[arg(long, default_value = "millimeter")]
    pub unit: String,
    /// Print statistics on stdout: `--stats json`.
    #[arg(long, value_enum)]
    pub stats: Option<StatsFormat>,
    /// Mesh the domain as 8^B bricks, in parallel, streamed to the output
    /// with bounded memory; the same mesh as without bricks.
    #[arg(long, value_name = "B", value_parser = clap::value_parser!(u8).range(0..=6))]
    pub bricks: Option<u8>,
    /// Mesh only brick I of the 8^B (0 ≤ I < 8^B) into a part file (.ply)
    /// for `isoc merge`.
    #[arg(long, value_name = "I", requires = "bricks")]
    pub brick: Option<u32>,
}

/// Formats of `--stats`.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum StatsFormat {
    Json,
}

/// Stages `compile --emit` can print.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Emit {
    Ast,
    Ir,
    /// Cranelift IR of every kernel, after optimisation.
    Clif,
    /// Disassembly of every kernel's machine code.
    Asm,
}

/// Runs a parsed command line; returns the exit status.
pub fn run(cli: Cli, out: &mut dyn Write, err: &mut dyn Write) -> i32 {
    let result = match cli.command {
        Command::Compile { source, emit } => compile(&source, emit, out),
        Command::Mesh { source, mesh } => mesh_command(&source, &mesh, out, err),
        Command::Eval {
            source,
            coords,
            bbox,
            t,
            json,
        } => eval(&source, &coords, bbox.as_deref(), t, json, out),
        Command::Merge {
            parts,
            output,
            unit,
            stats,
        } => bricks::merge(&parts, &output, &unit, stats, out, err),
        Command::Animate { source, animate } => animate::run(&source, &animate, out, err),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            let _ = err.write_all(e.render().as_bytes());
            if matches!(e, Error::Interrupted) {
                130
            } else {
                1
            }
        }
    }
}

/// The token Ctrl-C cancels: the first press stops the run at its next
/// checkpoint (its temporary files are removed, nothing is written), a
/// second one ends the process at once. The handler is installed once,
/// on first use.
fn interrupt() -> isoc::Cancel {
    static TOKEN: std::sync::OnceLock<isoc::Cancel> = std::sync::OnceLock::new();
    TOKEN
        .get_or_init(|| {
            let token = isoc::Cancel::new();
            let t = token.clone();
            // Without a handler (another one is installed), Ctrl-C keeps
            // its default: the process ends.
            let _ = ctrlc::set_handler(move || {
                if t.is_cancelled() {
                    std::process::exit(130);
                }
                t.cancel();
            });
            token
        })
        .clone()
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
    let domain = args.domain.as_deref().map(parse_box).transpose()?;
    Ok(CompileOptions { params, domain })
}

/// Parses `a,b,c,d,e,f` (`--domain`, `--box`) as `[a,b]×[c,d]×[e,f]`;
/// checks that every side is finite and `a <= b`.
fn parse_box(text: &str) -> Result<Bounds, Error> {
    let nums: Vec<f64> = text
        .split(',')
        .map(|w| w.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| Error::Usage(format!("`{text}` is not six comma-separated numbers")))?;
    if nums.len() != 6 {
        return Err(Error::Usage(format!(
            "`{text}` has {} numbers; a box needs six: a,b,c,d,e,f",
            nums.len()
        )));
    }
    let b = Bounds {
        lo: [nums[0], nums[2], nums[4]],
        hi: [nums[1], nums[3], nums[5]],
    };
    for k in 0..3 {
        if !(b.lo[k].is_finite() && b.hi[k].is_finite()) {
            return Err(Error::Usage(format!("`{text}`: the box is not finite")));
        }
        if b.lo[k] > b.hi[k] {
            return Err(Error::Usage(format!(
                "`{text}`: side {} is inverted ({} > {})",
                ["x", "y", "z"][k],
                b.lo[k],
                b.hi[k]
            )));
        }
    }
    Ok(b)
}

fn load(args: &SourceArgs) -> Result<(String, Vec<u8>), Error> {
    let name = args.file.display().to_string();
    let bytes = std::fs::read(&args.file).map_err(io_err(&name))?;
    Ok((name, bytes))
}

fn compile_file(args: &SourceArgs) -> Result<Surface, Error> {
    let opts = options(args)?;
    let (name, bytes) = load(args)?;
    Ok(Surface::compile_bytes(&bytes, &name, &opts)?)
}

fn write(out: &mut dyn Write, text: &str) -> Result<(), Error> {
    out.write_all(text.as_bytes()).map_err(io_err("<stdout>"))
}

fn compile(args: &SourceArgs, emit: Option<Emit>, out: &mut dyn Write) -> Result<(), Error> {
    if emit == Some(Emit::Ast) {
        let (name, bytes) = load(args)?;
        let source = isoc::syntax::source_from_bytes(&bytes, &name)?;
        return write(out, &isoc::syntax::emit_ast_for(&source, &name)?);
    }
    let surface = compile_file(args)?;
    match emit {
        Some(Emit::Ir) => write(out, &surface.program.to_string()),
        Some(kind @ (Emit::Clif | Emit::Asm)) => {
            let opts = isoc::jit::JitOptions {
                keep_text: true,
                ..Default::default()
            };
            let kernels = isoc::jit::Kernels::lazy(&surface.program, &opts)?;
            kernels.prepare(&isoc::jit::Kind::EVERY);
            kernels.prepare_second_tier();
            let mut s = String::new();
            for info in &kernels.info() {
                let text = if kind == Emit::Clif {
                    &info.clif
                } else {
                    &info.asm
                };
                s += &format!("; ---- {} ----\n", info.name);
                s += text.as_deref().unwrap_or("; (not available)\n");
                s += "\n";
            }
            write(out, &s)
        }
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
            s += "  kernels (machine code, compile time):\n";
            let k = surface.kernels();
            k.prepare(&isoc::jit::Kind::EVERY);
            for info in &k.info() {
                s += &format!(
                    "    {:<16} {:>8} bytes  {:>8.3} ms\n",
                    info.name,
                    info.code_bytes,
                    info.compile_time.as_secs_f64() * 1e3
                );
            }
            for kind in isoc::jit::Kind::EVERY {
                if let isoc::jit::Engine::Interpreter(why) = k.engine(kind) {
                    s += &format!("    {:<16} interpreted ({why})\n", kind.name());
                }
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
            let b = parse_box(b)?;
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

fn mesh_command(
    args: &SourceArgs,
    m: &MeshArgs,
    out: &mut dyn Write,
    err: &mut dyn Write,
) -> Result<(), Error> {
    use isoc::mesher::{self, MeshOptions, Stage};
    use isoc::octree::{OctreeOptions, TopologyTest};

    // Ctrl-C from here on stops the run cleanly.
    interrupt();

    if let Some(k) = m.kmax
        && !(k.is_finite() && k >= 0.0)
    {
        return Err(Error::Usage(format!(
            "--kmax {k}: must be a number >= 0 (0 refines uniformly)"
        )));
    }
    if let Some(d) = m.tolerance
        && !(d.is_finite() && d > 0.0)
    {
        return Err(Error::Usage(format!(
            "--tolerance {d}: must be a positive number (a distance in domain units)"
        )));
    }
    let level = m
        .level
        .unwrap_or(if m.tolerance.is_some() { 10 } else { 7 });
    if m.min_level > level {
        return Err(Error::Usage(format!(
            "--min-level {} is above --level {level}",
            m.min_level
        )));
    }
    let output = match &m.output {
        Some(p) => p.clone(),
        None => args.file.with_extension("ply"),
    };
    // Fail on a bad extension, unit or brick before doing any work.
    isoc::io::Format::from_path(&output)?;
    let unit: isoc::io::threemf::Unit = m.unit.parse().map_err(Error::Usage)?;
    bricks::check(m, &output)?;

    let t0 = std::time::Instant::now();
    let surface = compile_file(args)?;
    // Every kind `mesh` calls, compiled now and in parallel — unless the
    // octree will prune the program per cell: its cells then mostly run
    // the pruned programs in the interpreters, and each kernel compiles
    // on first use, if any.
    if m.no_prune || !isoc::eval::prune::has_choices(&surface.program) {
        surface.kernels().prepare(&isoc::jit::Kind::EVERY);
    }
    let compile_ms = t0.elapsed().as_secs_f64() * 1e3;

    let bar =
        indicatif::ProgressBar::with_draw_target(None, indicatif::ProgressDrawTarget::stderr());
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} [{elapsed}] {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    let opts = MeshOptions {
        octree: OctreeOptions {
            max_level: level,
            min_level: m.min_level,
            kmax: m.kmax.unwrap_or(OctreeOptions::default().kmax),
            test: if m.certify {
                TopologyTest::Certify
            } else {
                TopologyTest::Paper
            },
            t: m.t,
            prune: !m.no_prune,
            // Faithful `--level` unless a criterion of the user's replaces
            // it (SPEC §2).
            chord: OctreeOptions::default()
                .chord
                .filter(|_| !m.coarse && m.kmax.is_none() && m.tolerance.is_none()),
        },
        smooth: m.smooth,
        domain: None,
        creases: !m.no_creases,
    };
    let progress = |stage: Stage| {
        bar.set_message(match stage {
            Stage::Octree { level, cells } => {
                format!("octree: level {level}, {cells} cells evaluated")
            }
            Stage::Dual => "dual grid".to_string(),
            Stage::Polygonize => "polygonising".to_string(),
            Stage::Smooth => "smoothing".to_string(),
        })
    };
    let (report, tol) = match (m.bricks, m.brick, m.tolerance) {
        (Some(b), Some(i), _) => (bricks::mesh_part(&surface, &opts, b, i, &output)?, None),
        (Some(b), None, _) => (
            bricks::mesh_bricked(&surface, &opts, b, &output, unit, &bar)?,
            None,
        ),
        (None, _, Some(d)) => {
            let (mesh, report, tol) = mesher::mesh_to_tolerance_cancellable(
                &surface,
                surface.domain,
                &opts,
                d,
                &progress,
                &interrupt(),
            )
            .map_err(|_| Error::Interrupted)?;
            bar.finish_and_clear();
            isoc::io::write_file_in(&mesh, &output, unit)?;
            (report, Some(tol))
        }
        (None, _, None) => {
            let (mesh, report) = mesher::mesh_cancellable(&surface, &opts, &progress, &interrupt())
                .map_err(|_| Error::Interrupted)?;
            bar.finish_and_clear();
            isoc::io::write_file_in(&mesh, &output, unit)?;
            (report, None)
        }
    };
    bar.finish_and_clear();
    let _ = err.write_all(summary(&output, &report).as_bytes());
    if let Some(t) = &tol {
        let _ = err.write_all(
            format!(
                "tolerance {}: max deviation {:e} ({}), k_max {} after {} pass(es)\n",
                t.tolerance,
                t.max_deviation,
                if t.met { "met" } else { "NOT met" },
                t.kmax,
                t.passes
            )
            .as_bytes(),
        );
    }
    if m.stats == Some(StatsFormat::Json) {
        let mut j = mesher::report::stats_json(&report, tol.as_ref(), compile_ms, m.certify);
        if let Some(b) = m.bricks {
            j["bricks"] = json!(b);
        }
        print_stats(j, out)?;
    }
    Ok(())
}

/// The summary line on stderr after a mesh is written.
fn summary(output: &std::path::Path, r: &isoc::mesher::MeshReport) -> String {
    format!(
        "{}: {} triangles, {} vertices, {} component(s), euler {}, {}, {}, {}\n",
        output.display(),
        r.triangles,
        r.vertices,
        r.topology.components,
        r.topology.euler,
        if r.topology.watertight {
            "watertight"
        } else {
            "open"
        },
        if r.topology.manifold() {
            "manifold".to_string()
        } else {
            format!("NOT manifold ({} bad edge(s))", r.topology.bad_edges())
        },
        if r.guaranteed {
            "topology guaranteed".to_string()
        } else {
            format!("{} ambiguous cell(s)", r.ambiguous_cells)
        }
    )
}

/// Prints `--stats json`'s object, with the process's peak resident
/// memory (`peak_rss_bytes`, where the system tells it).
fn print_stats(mut j: Json, out: &mut dyn Write) -> Result<(), Error> {
    if let Some(bytes) = peak_rss_bytes() {
        j["peak_rss_bytes"] = json!(bytes);
    }
    write(out, &(j.to_string() + "\n"))
}

/// The process's peak resident set (Linux: `VmHWM` in /proc/self/status).
fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}
