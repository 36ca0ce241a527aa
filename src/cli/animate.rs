//! `isoc animate` (SPEC §2): tracks a surface in `t` with twinned meshes
//! ([`isoc::twin`]) and writes, per frame `k`, `DIR/geometric_%04d.ply`
//! and `DIR/mechanical_%04d.ply`, then `DIR/stats.json` (one object per
//! frame). Every file is written atomically; a progress bar over frames
//! goes to stderr; stdout stays empty unless `--json` asks for the stats.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::error::Error;
use super::{SourceArgs, compile_file, io_err, write};
use isoc::twin::{FrameReport, Tracker, TwinOptions};

/// Options of `isoc animate`.
#[derive(clap::Args, Debug, Clone)]
pub struct AnimateArgs {
    /// Time of the first frame.
    #[arg(long, allow_negative_numbers = true)]
    pub t0: f64,
    /// Time of the last frame.
    #[arg(long, allow_negative_numbers = true)]
    pub t1: f64,
    /// Number of frames (frame k is at t0 + (t1 − t0)·k/(N − 1)).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub frames: u32,
    /// Target mechanical edge length ê (default: the domain's largest side / 40).
    #[arg(long)]
    pub edge: Option<f64>,
    /// α_r in degrees: refine the geometric mesh where normals turn by more (−180: no refinement).
    #[arg(long, default_value_t = 20.0, allow_negative_numbers = true)]
    pub alpha: f64,
    /// N_p: most refinement passes of the geometric mesh (at most 12).
    #[arg(long, default_value_t = 4)]
    pub passes: usize,
    /// Young's modulus E of the mechanical elements.
    #[arg(long, default_value_t = 1000.0)]
    pub young: f64,
    /// Poisson's ratio ν.
    #[arg(long, default_value_t = 0.3, allow_negative_numbers = true)]
    pub poisson: f64,
    /// Time step dt of the quasi-static solve.
    #[arg(long, default_value_t = 0.04)]
    pub dt: f64,
    /// Collapse edges shorter than e_min·ê.
    #[arg(long = "e-min", default_value_t = 1.0)]
    pub e_min: f64,
    /// Split edges longer than e_max·ê.
    #[arg(long = "e-max", default_value_t = 2.0)]
    pub e_max: f64,
    /// ε_e: tolerance on an edge's length change per frame, in units of ê.
    #[arg(long = "eps-e", default_value_t = 0.1)]
    pub eps_e: f64,
    /// Apply the sharp-feature constraint (eq. 4).
    #[arg(long)]
    pub sharp: bool,
    /// Disable edge flips in the mechanical remeshing.
    #[arg(long = "no-flips")]
    pub no_flips: bool,
    /// Disable the topology watch (no re-initialisation on topology changes).
    #[arg(long = "no-watch")]
    pub no_watch: bool,
    /// Output directory (created if needed).
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
    /// Also print the per-frame statistics as one JSON array on stdout.
    #[arg(long)]
    pub json: bool,
}

pub(super) fn run(
    args: &SourceArgs,
    a: &AnimateArgs,
    out: &mut dyn Write,
    _err: &mut dyn Write,
) -> Result<(), Error> {
    for (name, v) in [("--t0", a.t0), ("--t1", a.t1)] {
        if !v.is_finite() {
            return Err(Error::Usage(format!("{name} must be finite, got {v}")));
        }
    }
    let surface = compile_file(args)?;
    let opts = TwinOptions {
        edge: a.edge,
        alpha_deg: a.alpha,
        passes: a.passes,
        young: a.young,
        poisson: a.poisson,
        dt: a.dt,
        e_min: a.e_min,
        e_max: a.e_max,
        eps_e: a.eps_e,
        flips: !a.no_flips,
        sharp: a.sharp,
        watch: !a.no_watch,
        ..TwinOptions::default()
    };
    let mut tracker = Tracker::new(&surface, a.t0, &opts)?;
    std::fs::create_dir_all(&a.output).map_err(io_err(&a.output.display().to_string()))?;
    let bar = indicatif::ProgressBar::with_draw_target(
        Some(a.frames as u64),
        indicatif::ProgressDrawTarget::stderr(),
    );
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} frames [{elapsed}] {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let mut reports: Vec<FrameReport> = Vec::with_capacity(a.frames as usize);
    for k in 0..a.frames {
        let t = if a.frames == 1 {
            a.t0
        } else {
            a.t0 + (a.t1 - a.t0) * k as f64 / (a.frames - 1) as f64
        };
        let rep = tracker.advance(t)?;
        write_frame(&a.output, "geometric", k, tracker.geometric())?;
        write_frame(&a.output, "mechanical", k, tracker.mechanical())?;
        bar.set_message(format!(
            "t = {t:.4}: {} / {} triangles",
            rep.mechanical_triangles, rep.geometric_triangles
        ));
        bar.inc(1);
        reports.push(rep);
    }
    bar.finish_and_clear();
    let frames: Vec<serde_json::Value> = reports
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let mut v = serde_json::to_value(r).unwrap_or_default();
            if let Some(o) = v.as_object_mut() {
                o.insert("frame".into(), k.into());
            }
            v
        })
        .collect();
    let text = serde_json::to_string_pretty(&frames).unwrap_or_default();
    let path = a.output.join("stats.json");
    isoc::io::write_atomic(&path, |w| w.write_all(text.as_bytes()))?;
    if a.json {
        write(
            out,
            &format!("{}\n", serde_json::to_string(&frames).unwrap_or_default()),
        )?;
    }
    Ok(())
}

fn write_frame(dir: &Path, kind: &str, k: u32, mesh: &isoc::mesh::Mesh) -> Result<(), Error> {
    Ok(isoc::io::write_file(
        mesh,
        &dir.join(format!("{kind}_{k:04}.ply")),
    )?)
}
