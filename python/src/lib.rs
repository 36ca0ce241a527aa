//! `isoc._isoc`: the compiled half of the Python package. A thin layer over
//! the `isoc` crate: every computation is the library's; this file only
//! checks arrays, moves numbers between numpy and the kernels, releases the
//! GIL around long work and turns Ctrl-C into the library's cancel token.
//! The documented public API (docstrings, argument defaults, the
//! expression builder) is `isoc/__init__.py`, which wraps these classes.

use std::sync::Mutex;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use rayon::prelude::*;

use isoc::interval::Interval;
use isoc::io::stream::StreamWriter;
use isoc::mesh::sink::Sink;
use isoc::mesher::brick::{self, PartInfo};
use isoc::mesher::stitch::Stitcher;
use isoc::mesher::{self, MeshOptions, Stage};
use isoc::octree::{OctreeOptions, TopologyTest};
use isoc::{Bounds, Cancel, CompileOptions, Surface};

/// How often the waiting thread looks for signals (Ctrl-C) and progress.
const POLL: Duration = Duration::from_millis(20);

/// Points per kernel call in `eval`/`grad` (and per parallel task).
const CHUNK: usize = 1024;

/// A compiled surface (wrapped by `isoc.Surface`).
#[pyclass(module = "isoc._isoc", frozen)]
struct CoreSurface {
    surface: Surface,
    /// Milliseconds `Surface::compile` took (the `compile` timing of
    /// `Mesh.stats`, with the kernels' preparation added by `mesh`).
    compile_ms: f64,
}

/// `(line, column)`, 1-based, of byte `at` of `source` (columns count
/// characters).
fn line_col(source: &str, at: usize) -> (usize, usize) {
    let before = &source[..source.floor_char_boundary(at.min(source.len()))];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// The Python `isoc.CompileError` for a library error.
fn compile_error(py: Python<'_>, e: &isoc::CompileError) -> PyErr {
    let rendered = e.render();
    let (message, line, column) = match e {
        isoc::CompileError::Front(isoc::syntax::FrontError::Source(s)) => {
            match s.diagnostics.first() {
                Some(d) => {
                    let (l, c) = line_col(&s.source, d.span.start);
                    (d.message.clone(), Some(l), Some(c))
                }
                None => (rendered.clone(), None, None),
            }
        }
        other => (other.to_string(), None, None),
    };
    let cls = py
        .import("isoc")
        .and_then(|m| m.getattr("CompileError"))
        .and_then(|c| c.call1((rendered.trim_end().to_string(), message, line, column)));
    match cls {
        Ok(err) => PyErr::from_value(err),
        Err(e) => e,
    }
}

fn value_error(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

/// The rows of an `(N, 3)` or `(N, 4)` C-contiguous float64 array, in
/// place, and its width.
fn rows<'a>(a: &'a PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<(&'a [f64], usize)> {
    let [_, w] = [a.shape()[0], a.shape()[1]];
    if w != 3 && w != 4 {
        return Err(value_error(format!(
            "{what} must have shape (N, 3) or (N, 4) (x, y, z[, t]); got {:?}",
            a.shape()
        )));
    }
    let data = a
        .as_slice()
        .map_err(|_| value_error(format!("{what} must be C-contiguous")))?;
    Ok((data, w))
}

/// Runs `work` on a scoped thread (in a local rayon pool of `threads`
/// when given) while this thread, without the GIL, waits; every [`POLL`]
/// it takes the GIL to look for signals (Ctrl-C cancels `cancel` and
/// re-raises) and to report progress (`report` with the GIL held).
fn run_cancellable<T: Send>(
    py: Python<'_>,
    threads: Option<usize>,
    cancel: &Cancel,
    work: impl FnOnce() -> T + Send,
    mut report: impl FnMut(Python<'_>) -> PyResult<()>,
) -> PyResult<T> {
    let pool = match threads {
        Some(0) => return Err(value_error("threads must be at least 1")),
        Some(n) => Some(
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| PyRuntimeError::new_err(e.to_string()))?,
        ),
        None => None,
    };
    std::thread::scope(|scope| {
        let (tx, rx) = mpsc::channel();
        // A receiver is not Sync; the mutex makes `&rx` Send.
        let rx = Mutex::new(rx);
        let pool = &pool;
        let handle = scope.spawn(move || {
            let out = match pool {
                Some(p) => p.install(work),
                None => work(),
            };
            let _ = tx.send(());
            out
        });
        let mut failure = None;
        loop {
            let done = py.detach(|| match rx.lock() {
                Ok(r) => r.recv_timeout(POLL),
                Err(_) => Err(mpsc::RecvTimeoutError::Disconnected),
            });
            if !matches!(done, Err(mpsc::RecvTimeoutError::Timeout)) {
                break;
            }
            if let Err(e) = py.check_signals().and_then(|()| report(py)) {
                cancel.cancel();
                failure = Some(e);
                break;
            }
        }
        // On cancellation the work stops at its next checkpoint.
        let out = py.detach(|| handle.join());
        match (failure, out) {
            (Some(e), _) => Err(e),
            (None, Ok(v)) => Ok(v),
            (None, Err(_)) => Err(PyRuntimeError::new_err("isoc: the meshing thread panicked")),
        }
    })
}

/// `Surface.mesh`'s options, as the dict `isoc._options` makes.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
struct Options {
    level: u8,
    tolerance: Option<f64>,
    kmax: Option<f64>,
    coarse: bool,
    min_level: u8,
    smooth: usize,
    creases: bool,
    certify: bool,
    prune: bool,
    t: f64,
    domain: Option<[f64; 6]>,
}

/// The mesher's options from `Surface.mesh`'s, checked (as `isoc mesh`
/// checks its flags).
fn mesh_options(o: &Options) -> PyResult<MeshOptions> {
    let Options {
        level,
        tolerance,
        kmax,
        coarse,
        min_level,
        smooth,
        creases,
        certify,
        prune,
        t,
        domain,
    } = *o;
    if level > 20 {
        return Err(value_error(format!("level {level}: at most 20")));
    }
    if let Some(k) = kmax
        && !(k.is_finite() && k >= 0.0)
    {
        return Err(value_error(format!("kmax {k}: must be a number >= 0")));
    }
    if let Some(d) = tolerance
        && !(d.is_finite() && d > 0.0)
    {
        return Err(value_error(format!(
            "tolerance {d}: must be a positive number (a distance in domain units)"
        )));
    }
    if min_level > level {
        return Err(value_error(format!(
            "min_level {min_level} is above level {level}"
        )));
    }
    if !t.is_finite() {
        return Err(value_error("t must be finite"));
    }
    let domain = match domain {
        None => None,
        Some(d) => {
            let b = Bounds {
                lo: [d[0], d[2], d[4]],
                hi: [d[1], d[3], d[5]],
            };
            if (0..3).any(|k| !(b.lo[k].is_finite() && b.hi[k].is_finite() && b.lo[k] < b.hi[k])) {
                return Err(value_error(format!(
                    "domain {d:?}: every side must be finite and non-empty (a < b)"
                )));
            }
            Some(b)
        }
    };
    Ok(MeshOptions {
        octree: OctreeOptions {
            max_level: level,
            min_level,
            kmax: kmax.unwrap_or(OctreeOptions::default().kmax),
            test: if certify {
                TopologyTest::Certify
            } else {
                TopologyTest::Paper
            },
            t,
            prune,
            // Faithful `level` unless a criterion of the caller's replaces
            // it (SPEC §2, as `isoc mesh`).
            chord: OctreeOptions::default()
                .chord
                .filter(|_| !coarse && kmax.is_none() && tolerance.is_none()),
        },
        smooth,
        domain,
        creases,
    })
}

/// [`mesh_options`] for a bricked run: no tolerance (a whole-mesh
/// adaptation).
fn bricked_options(o: &Options) -> PyResult<MeshOptions> {
    if o.tolerance.is_some() {
        return Err(value_error(
            "tolerance adapts the whole mesh at once; it does not go with bricks",
        ));
    }
    mesh_options(o)
}

/// A stage as `(name, level, cells)` for the progress callback.
fn stage_tuple(s: Stage) -> (&'static str, Option<u8>, Option<usize>) {
    match s {
        Stage::Octree { level, cells } => ("octree", Some(level), Some(cells)),
        Stage::Dual => ("dual", None, None),
        Stage::Polygonize => ("polygonize", None, None),
        Stage::Smooth => ("smooth", None, None),
    }
}

#[pymethods]
impl CoreSurface {
    /// Compiles `source` (`.vm` when `file` ends so, `.iso` otherwise).
    #[staticmethod]
    #[pyo3(signature = (source, file, domain=None, params=Vec::new()))]
    fn compile(
        py: Python<'_>,
        source: &str,
        file: &str,
        domain: Option<[f64; 6]>,
        params: Vec<(String, f64)>,
    ) -> PyResult<CoreSurface> {
        let domain = domain.map(|d| Bounds {
            lo: [d[0], d[2], d[4]],
            hi: [d[1], d[3], d[5]],
        });
        let opts = CompileOptions { params, domain };
        let t0 = Instant::now();
        let surface = py
            .detach(|| Surface::compile(source, file, &opts))
            .map_err(|e| compile_error(py, &e))?;
        Ok(CoreSurface {
            surface,
            compile_ms: t0.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// The simplified SSA program in the library's text form (what
    /// `isoc compile --emit ir` prints).
    #[getter]
    fn ir(&self) -> String {
        self.surface.program.to_string()
    }

    /// `(a, b, c, d, e, f)`: the domain [a,b]×[c,d]×[e,f].
    #[getter]
    fn domain(&self) -> [f64; 6] {
        let d = self.surface.domain;
        [d.lo[0], d.hi[0], d.lo[1], d.hi[1], d.lo[2], d.hi[2]]
    }

    #[getter]
    fn params(&self) -> Vec<(String, f64)> {
        self.surface.params.clone()
    }

    #[getter]
    fn file(&self) -> String {
        self.surface.file.clone()
    }

    /// f at every row of an `(N, 3)`/`(N, 4)` C-contiguous float64 array.
    fn eval<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let (data, w) = rows(&points, "points")?;
        let n = data.len() / w;
        let mut out = vec![0.0; n];
        let s = &self.surface;
        py.detach(|| {
            let chunk = |(rows, out): (&[f64], &mut [f64])| -> Result<(), String> {
                let m = out.len();
                // Columns of this chunk, on the stack (the kernel reads
                // x, y and z as separate arrays): the copy stays in L1.
                let (mut xs, mut ys, mut zs) = ([0.0; CHUNK], [0.0; CHUNK], [0.0; CHUNK]);
                for (k, r) in rows.chunks_exact(w).enumerate() {
                    (xs[k], ys[k], zs[k]) = (r[0], r[1], r[2]);
                }
                let (xs, ys, zs) = (&xs[..m], &ys[..m], &zs[..m]);
                if w == 3 {
                    return s
                        .point_batch(xs, ys, zs, 0.0, out)
                        .map_err(|e| e.to_string());
                }
                // One kernel call per run of equal t.
                let mut a = 0;
                while a < m {
                    let t = rows[a * w + 3];
                    let mut b = a + 1;
                    while b < m && rows[b * w + 3].to_bits() == t.to_bits() {
                        b += 1;
                    }
                    s.point_batch(&xs[a..b], &ys[a..b], &zs[a..b], t, &mut out[a..b])
                        .map_err(|e| e.to_string())?;
                    a = b;
                }
                Ok(())
            };
            let parts = data.chunks(CHUNK * w).zip(out.chunks_mut(CHUNK));
            if n > 16 * CHUNK {
                parts
                    .collect::<Vec<_>>()
                    .into_par_iter()
                    .try_for_each(chunk)
            } else {
                parts.into_iter().try_for_each(chunk)
            }
        })
        .map_err(value_error)?;
        Ok(PyArray1::from_vec(py, out))
    }

    /// Seconds the library's batch point kernel alone takes on the rows of
    /// an `(N, 3)` array, already split into x, y and z columns, in one call
    /// on this thread: the yardstick of `eval`'s overhead (docs/python.md).
    /// With `chunk`, the kernel is called on consecutive slices of that
    /// many points instead (as `eval` does, without its column copy).
    #[pyo3(signature = (points, chunk=None))]
    fn _kernel_seconds(
        &self,
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        chunk: Option<usize>,
    ) -> PyResult<f64> {
        let (data, w) = rows(&points, "points")?;
        let col = |k: usize| data.chunks_exact(w).map(|r| r[k]).collect::<Vec<f64>>();
        let (xs, ys, zs) = (col(0), col(1), col(2));
        let mut out = vec![0.0; xs.len()];
        let s = &self.surface;
        py.detach(|| {
            let c = chunk.unwrap_or(xs.len()).max(1);
            let t0 = Instant::now();
            for (k, o) in out.chunks_mut(c).enumerate() {
                let r = k * c..k * c + o.len();
                s.point_batch(&xs[r.clone()], &ys[r.clone()], &zs[r], 0.0, o)?;
            }
            Ok::<f64, isoc::jit::JitError>(t0.elapsed().as_secs_f64())
        })
        .map_err(|e| value_error(e.to_string()))
    }

    /// (f, ∇f) at every row: `(values (N,), gradients (N, 3))`.
    fn grad<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyAny>)> {
        let (data, w) = rows(&points, "points")?;
        let n = data.len() / w;
        let s = &self.surface;
        let (vals, grads) = py.detach(|| {
            let mut vals = vec![0.0; n];
            let mut grads = vec![0.0; 3 * n];
            let job = |((rows, v), g): ((&[f64], &mut [f64]), &mut [f64])| {
                let m = v.len();
                let pts: Vec<[f64; 3]> = rows.chunks_exact(w).map(|r| [r[0], r[1], r[2]]).collect();
                let mut a = 0;
                while a < m {
                    let t = if w == 4 { rows[a * w + 3] } else { 0.0 };
                    let mut b = a + 1;
                    while w == 4 && b < m && rows[b * w + 3].to_bits() == t.to_bits() {
                        b += 1;
                    }
                    if w == 3 {
                        b = m;
                    }
                    for (k, (f, d)) in s.point_grad_batch(&pts[a..b], t).into_iter().enumerate() {
                        v[a + k] = f;
                        g[3 * (a + k)..3 * (a + k) + 3].copy_from_slice(&d);
                    }
                    a = b;
                }
            };
            data.chunks(CHUNK * w)
                .zip(vals.chunks_mut(CHUNK))
                .zip(grads.chunks_mut(3 * CHUNK))
                .collect::<Vec<_>>()
                .into_par_iter()
                .for_each(job);
            (vals, grads)
        });
        let g = PyArray1::from_vec(py, grads).reshape([n, 3])?;
        Ok((PyArray1::from_vec(py, vals), g.into_any()))
    }

    /// Enclosures of f over boxes `lo[i]..hi[i]` (`(N, 3)` or `(N, 4)`
    /// each): `(lo (N,), hi (N,), defined (N,) bool)`; with `grad`, also
    /// the interval gradient `(N, 3, 2)`.
    #[pyo3(signature = (lo, hi, grad=false))]
    fn interval<'py>(
        &self,
        py: Python<'py>,
        lo: PyReadonlyArray2<'py, f64>,
        hi: PyReadonlyArray2<'py, f64>,
        grad: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (a, w) = rows(&lo, "lo")?;
        let (b, wb) = rows(&hi, "hi")?;
        if wb != w || a.len() != b.len() {
            return Err(value_error(format!(
                "lo and hi must have the same shape; got {:?} and {:?}",
                lo.shape(),
                hi.shape()
            )));
        }
        let mut boxes = Vec::with_capacity(a.len() / w);
        for (i, (p, q)) in a.chunks_exact(w).zip(b.chunks_exact(w)).enumerate() {
            let mut bx = [Interval::point(0.0); 4];
            for k in 0..w {
                let (l, h) = (p[k], q[k]);
                if l.is_nan() || h.is_nan() {
                    return Err(value_error(format!("box {i}: a bound is NaN")));
                }
                if l > h {
                    return Err(value_error(format!(
                        "box {i}: side {} is inverted ({l} > {h})",
                        ["x", "y", "z", "t"][k]
                    )));
                }
                bx[k] = Interval { lo: l, hi: h };
            }
            boxes.push(bx);
        }
        let n = boxes.len();
        let s = &self.surface;
        if grad {
            let out = py.detach(|| s.grad_batch(&boxes));
            let (mut l, mut h, mut d) = (Vec::with_capacity(n), Vec::with_capacity(n), Vec::new());
            let mut g = Vec::with_capacity(6 * n);
            for e in &out {
                l.push(e.value.lo);
                h.push(e.value.hi);
                d.push(e.defined);
                for iv in e.grad {
                    g.extend([iv.lo, iv.hi]);
                }
            }
            let g = PyArray1::from_vec(py, g).reshape([n, 3, 2])?;
            let t = (
                PyArray1::from_vec(py, l),
                PyArray1::from_vec(py, h),
                PyArray1::from_vec(py, d),
                g,
            );
            return Ok(t.into_pyobject(py)?.into_any());
        }
        let out = py.detach(|| s.interval_batch(&boxes));
        let l: Vec<f64> = out.iter().map(|e| e.iv.lo).collect();
        let h: Vec<f64> = out.iter().map(|e| e.iv.hi).collect();
        let d: Vec<bool> = out.iter().map(|e| e.defined).collect();
        let t = (
            PyArray1::from_vec(py, l),
            PyArray1::from_vec(py, h),
            PyArray1::from_vec(py, d),
        );
        Ok(t.into_pyobject(py)?.into_any())
    }

    /// Brick `brick` of the run of `8^bricks` bricks as part-file bytes
    /// (`isoc mesh --bricks B --brick I`; the arguments as `mesh`'s).
    #[pyo3(signature = (bricks, brick, options, threads))]
    fn mesh_part<'py>(
        &self,
        py: Python<'py>,
        bricks: u8,
        brick: u32,
        options: Options,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, pyo3::types::PyBytes>> {
        let opts = bricked_options(&options)?;
        let b = brick::Brick::new(bricks, brick).ok_or_else(|| {
            value_error(format!(
                "brick {brick} of bricks={bricks}: bricks is at most {} and brick below 8^bricks",
                brick::MAX_BRICK_LEVEL
            ))
        })?;
        let cancel = Cancel::new();
        let s = &self.surface;
        let work = || {
            let (p, info) = brick::mesh_part(s, &opts, b, &cancel)?;
            let mut bytes = Vec::new();
            isoc::io::part::write(&p.mesh, &p.origins, &info.to_json(), &mut bytes)
                .map_err(brick::BrickError::Io)?;
            Ok::<_, brick::BrickError>(bytes)
        };
        let bytes =
            run_cancellable(py, threads, &cancel, work, |_| Ok(()))?.map_err(brick_error)?;
        Ok(pyo3::types::PyBytes::new(py, &bytes))
    }

    /// Meshes the surface (see `isoc.Surface.mesh`); with `bricks`, as
    /// `--bricks` (welded in memory).
    #[pyo3(signature = (options, threads, progress, bricks=None))]
    fn mesh(
        &self,
        py: Python<'_>,
        options: Options,
        threads: Option<usize>,
        progress: Option<Py<PyAny>>,
        bricks: Option<u8>,
    ) -> PyResult<CoreMesh> {
        if let Some(b) = bricks {
            let opts = bricked_options(&options)?;
            return self.mesh_bricked(py, &opts, b, threads, options.certify);
        }
        let opts = mesh_options(&options)?;
        let Options {
            tolerance,
            certify,
            prune,
            ..
        } = options;
        let s = &self.surface;
        let cancel = Cancel::new();
        let last: Mutex<Option<Stage>> = Mutex::new(None);
        let on_stage = |st: Stage| {
            if let Ok(mut g) = last.lock() {
                *g = Some(st);
            }
        };
        let work = || {
            // As `isoc mesh` does: every kind compiled up front unless
            // the octree prunes the program per cell.
            let t0 = Instant::now();
            if !prune || !isoc::eval::prune::has_choices(&s.program) {
                s.kernels().prepare(&isoc::jit::Kind::EVERY);
            }
            let prep_ms = t0.elapsed().as_secs_f64() * 1e3;
            let r = match tolerance {
                Some(d) => {
                    mesher::mesh_to_tolerance_cancellable(s, s.domain, &opts, d, &on_stage, &cancel)
                        .map(|(m, r, tol)| (m, r, Some(tol)))
                }
                None => mesher::mesh_cancellable(s, &opts, &on_stage, &cancel)
                    .map(|(m, r)| (m, r, None)),
            };
            (r, prep_ms)
        };
        let report = |py: Python<'_>| -> PyResult<()> {
            let st = last.lock().ok().and_then(|mut g| g.take());
            if let (Some(cb), Some(st)) = (&progress, st) {
                cb.call1(py, stage_tuple(st))?;
            }
            Ok(())
        };
        let (result, prep_ms) = run_cancellable(py, threads, &cancel, work, report)?;
        let (mesh, rep, tol) = result.map_err(|_| {
            pyo3::exceptions::PyKeyboardInterrupt::new_err("isoc: meshing cancelled")
        })?;
        // The last stage, if the poll loop missed it.
        if let (Some(cb), Some(st)) = (&progress, last.lock().ok().and_then(|mut g| g.take())) {
            cb.call1(py, stage_tuple(st))?;
        }
        let stats =
            mesher::report::stats_json(&rep, tol.as_ref(), self.compile_ms + prep_ms, certify);
        Ok(CoreMesh {
            mesh,
            stats: stats.to_string(),
        })
    }
}

impl CoreSurface {
    /// `mesh(..., bricks=B)`: every brick, welded in memory.
    fn mesh_bricked(
        &self,
        py: Python<'_>,
        opts: &MeshOptions,
        bricks: u8,
        threads: Option<usize>,
        certify: bool,
    ) -> PyResult<CoreMesh> {
        let s = &self.surface;
        let cancel = Cancel::new();
        let work = || {
            let mut mesh = isoc::Mesh::default();
            brick::mesh_bricks(s, s.domain, opts, bricks, &mut mesh, &|_, _| {}, &cancel)
                .map(|r| (mesh, r))
        };
        let (mesh, rep) =
            run_cancellable(py, threads, &cancel, work, |_| Ok(()))?.map_err(brick_error)?;
        let mut stats = mesher::report::stats_json(&rep, None, self.compile_ms, certify);
        stats["bricks"] = bricks.into();
        Ok(CoreMesh {
            mesh,
            stats: stats.to_string(),
        })
    }
}

/// A bricked run's failure as a Python exception.
fn brick_error(e: brick::BrickError) -> PyErr {
    match e {
        brick::BrickError::Cancelled => {
            pyo3::exceptions::PyKeyboardInterrupt::new_err("isoc: meshing cancelled")
        }
        brick::BrickError::Io(e) => PyOSError::new_err(e.to_string()),
    }
}

/// Where a [`CoreMerger`] welds to: memory, or a file streamed.
enum Target {
    Memory(isoc::Mesh),
    File(StreamWriter),
}

impl Sink for Target {
    fn append(&mut self, part: &isoc::Mesh, new: &[u32], tris: &[[u32; 3]]) -> std::io::Result<()> {
        match self {
            Target::Memory(m) => m.append(part, new, tris),
            Target::File(w) => w.append(part, new, tris),
        }
    }
}

/// Part files welded one by one (wrapped by `isoc.dask`): the parts of
/// one run, each once, in the order given.
#[pyclass(module = "isoc._isoc")]
struct CoreMerger {
    stitcher: Option<Stitcher<Target>>,
    /// The first part's run: `(bricks, run, certify)`.
    run: Option<(u8, String, bool)>,
    seen: std::collections::HashSet<u32>,
    reports: Vec<mesher::MeshReport>,
    start: Instant,
}

#[pymethods]
impl CoreMerger {
    /// A merger into memory, or streamed into `path` (format by its
    /// extension; `unit` for 3MF).
    #[new]
    #[pyo3(signature = (path=None, unit="millimeter"))]
    fn new(path: Option<std::path::PathBuf>, unit: &str) -> PyResult<Self> {
        let unit: isoc::io::threemf::Unit = unit.parse().map_err(value_error)?;
        let target = match path {
            None => Target::Memory(isoc::Mesh::default()),
            Some(p) => Target::File(StreamWriter::create(&p, unit).map_err(write_error)?),
        };
        Ok(CoreMerger {
            stitcher: Some(Stitcher::new(target)),
            run: None,
            seen: Default::default(),
            reports: Vec::new(),
            start: Instant::now(),
        })
    }

    /// Welds one part file's bytes; returns its brick index.
    fn add(&mut self, py: Python<'_>, part: &[u8]) -> PyResult<u32> {
        let (mesh, origins, info) = py
            .detach(|| isoc::io::part::read(part))
            .map_err(|e| value_error(e.to_string()))?;
        let info = PartInfo::from_json(&info)
            .map_err(|e| value_error(format!("not an isoc part: {e}")))?;
        let run = (info.bricks, info.run.clone(), info.certify);
        if self.run.get_or_insert_with(|| run.clone()) != &run {
            return Err(value_error(
                "parts of different runs (other surface, options or bricks)",
            ));
        }
        if !self.seen.insert(info.brick) {
            return Err(value_error(format!("brick {} given twice", info.brick)));
        }
        let st = self
            .stitcher
            .as_mut()
            .ok_or_else(|| value_error("the merger is finished"))?;
        py.detach(|| st.add(&mesh, &origins))
            .map_err(|e| PyOSError::new_err(e.to_string()))?;
        self.reports.push(info.report);
        Ok(info.brick)
    }

    /// Finishes: `(mesh or None when streamed to a file, stats JSON)`.
    fn finish(&mut self, py: Python<'_>) -> PyResult<(Option<CoreMesh>, String)> {
        let st = self
            .stitcher
            .take()
            .ok_or_else(|| value_error("the merger is finished"))?;
        let (welded, target) = st.finish();
        let mesh = match target {
            Target::Memory(m) => Some(m),
            Target::File(w) => {
                py.detach(|| w.finish()).map_err(write_error)?;
                None
            }
        };
        let ms = self.start.elapsed().as_secs_f64() * 1e3;
        let rep = brick::merge_reports(&self.reports, &welded, ms);
        let (bricks, _, certify) = self.run.clone().unwrap_or_default();
        let mut stats = mesher::report::stats_json(&rep, None, 0.0, certify);
        stats["bricks"] = bricks.into();
        stats["parts"] = self.reports.len().into();
        let stats = stats.to_string();
        let mesh = mesh.map(|mesh| CoreMesh {
            mesh,
            stats: stats.clone(),
        });
        Ok((mesh, stats))
    }
}

/// A write failure as a Python exception.
fn write_error(e: isoc::io::WriteError) -> PyErr {
    match e {
        isoc::io::WriteError::UnknownFormat(_) => value_error(e.to_string()),
        isoc::io::WriteError::Io { .. } => PyOSError::new_err(e.to_string()),
    }
}

/// A mesh (wrapped by `isoc.Mesh`).
#[pyclass(module = "isoc._isoc", frozen)]
struct CoreMesh {
    mesh: isoc::Mesh,
    /// The `--stats json` object, as JSON text.
    stats: String,
}

#[pymethods]
impl CoreMesh {
    #[getter]
    fn stats(&self) -> String {
        self.stats.clone()
    }

    /// `(vertices (V,3) f64, faces (F,3) u32, normals (V,3) f64,
    /// ambiguous (V,) bool)`, copied into new arrays.
    fn arrays<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let m = &self.mesh;
        let v = m.positions.len();
        let flat = |p: &[glam::DVec3]| p.iter().flat_map(|q| q.to_array()).collect::<Vec<f64>>();
        let pos = PyArray1::from_vec(py, flat(&m.positions)).reshape([v, 3])?;
        let nrm = PyArray1::from_vec(py, flat(&m.normals)).reshape([v, 3])?;
        let f = m.triangles.len();
        let tri: Vec<u32> = m.triangles.iter().flatten().copied().collect();
        let tri = PyArray1::from_vec(py, tri).reshape([f, 3])?;
        let amb = PyArray1::from_vec(py, m.ambiguous.clone());
        Ok((pos, tri, nrm, amb).into_pyobject(py)?.into_any())
    }

    /// Writes the mesh, its format chosen by the extension (`.ply`, `.obj`,
    /// `.stl`, `.glb`, `.3mf`), atomically; `unit` for 3MF.
    #[pyo3(signature = (path, unit="millimeter"))]
    fn save(&self, py: Python<'_>, path: std::path::PathBuf, unit: &str) -> PyResult<()> {
        let unit: isoc::io::threemf::Unit = unit.parse().map_err(value_error)?;
        py.detach(|| isoc::io::write_file_in(&self.mesh, &path, unit))
            .map_err(write_error)
    }
}

/// Twinned meshes frame by frame (wrapped by `isoc.Surface.animate`): a
/// worker thread owns the tracker; each `advance` asks it for one frame.
/// The tracker polls `cancel` (Ctrl-C, `close`, the object dropped).
#[pyclass(module = "isoc._isoc")]
struct CoreAnimation {
    cancel: Cancel,
    ask: Option<mpsc::Sender<f64>>,
    answer: Mutex<mpsc::Receiver<Result<(isoc::Mesh, String), String>>>,
    worker: Option<std::thread::JoinHandle<()>>,
}

#[pymethods]
impl CoreAnimation {
    #[new]
    #[pyo3(signature = (surface, t0, edge=None, alpha=None, passes=None))]
    fn new(
        surface: &CoreSurface,
        t0: f64,
        edge: Option<f64>,
        alpha: Option<f64>,
        passes: Option<usize>,
    ) -> CoreAnimation {
        let s = surface.surface.clone();
        let mut opts = isoc::TwinOptions {
            edge,
            ..Default::default()
        };
        if let Some(a) = alpha {
            opts.alpha_deg = a;
        }
        if let Some(p) = passes {
            opts.passes = p;
        }
        let (ask_tx, ask_rx) = mpsc::channel::<f64>();
        let (ans_tx, ans_rx) = mpsc::channel();
        let cancel = Cancel::new();
        let token = cancel.clone();
        let worker = std::thread::spawn(move || {
            let frame = |tr: &isoc::Tracker<'_>, rep: String| (tr.geometric().clone(), rep);
            let mut tracker = match isoc::Tracker::new_cancellable(&s, t0, &opts, &token) {
                Ok(tr) => tr,
                Err(e) => {
                    let _ = ans_tx.send(Err(e.to_string()));
                    return;
                }
            };
            // Each request advances the tracker to its time (frame k of
            // `isoc animate` is `advance(t_k)`, the first one included).
            while let Ok(t) = ask_rx.recv() {
                let r = match tracker.advance(t) {
                    Ok(rep) => Ok(frame(
                        &tracker,
                        serde_json::to_string(&rep).unwrap_or_default(),
                    )),
                    Err(e) => Err(e.to_string()),
                };
                if ans_tx.send(r).is_err() {
                    break;
                }
            }
        });
        CoreAnimation {
            cancel,
            ask: Some(ask_tx),
            answer: Mutex::new(ans_rx),
            worker: Some(worker),
        }
    }

    /// The frame at `t` (the tracker advanced to it). Waits without the
    /// GIL; Ctrl-C cancels the tracker, waits for the worker to stop (at
    /// the tracker's next checkpoint) and raises.
    fn next_frame(&mut self, py: Python<'_>, t: f64) -> PyResult<CoreMesh> {
        let ask = self
            .ask
            .as_ref()
            .ok_or_else(|| PyRuntimeError::new_err("the animation is closed"))?;
        ask.send(t)
            .map_err(|_| PyRuntimeError::new_err("the animation's worker stopped"))?;
        loop {
            let got = py.detach(|| match self.answer.lock() {
                Ok(r) => r.recv_timeout(POLL),
                Err(_) => Err(mpsc::RecvTimeoutError::Disconnected),
            });
            match got {
                Ok(Ok((mesh, frame))) => {
                    let r = isoc::mesh::topology::analyze(&mesh);
                    let frame: serde_json::Value =
                        serde_json::from_str(&frame).unwrap_or(serde_json::Value::Null);
                    let stats = serde_json::json!({
                        "frame": frame,
                        "triangles": mesh.triangles.len(),
                        "vertices": mesh.positions.len(),
                        "components": r.components,
                        "euler": r.euler,
                        "genus": r.genus,
                        "watertight": r.watertight,
                    });
                    return Ok(CoreMesh {
                        mesh,
                        stats: stats.to_string(),
                    });
                }
                Ok(Err(e)) => return Err(PyRuntimeError::new_err(e)),
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(PyRuntimeError::new_err("the animation's worker stopped"));
                }
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    if let Err(e) = py.check_signals() {
                        self.close(py);
                        return Err(e);
                    }
                }
            }
        }
    }

    /// Cancels the frame under way, if any, and waits (without the GIL)
    /// for the worker to end.
    fn close(&mut self, py: Python<'_>) {
        self.cancel.cancel();
        self.ask = None;
        if let Some(worker) = self.worker.take() {
            // A worker that panicked has nothing left to stop.
            let _ = py.detach(|| worker.join());
        }
    }
}

impl Drop for CoreAnimation {
    fn drop(&mut self) {
        // The worker stops at its next checkpoint and ends by itself once
        // the channel is closed.
        self.cancel.cancel();
        self.ask = None;
    }
}

/// The compiled part of the `isoc` package.
#[pymodule]
fn _isoc(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<CoreSurface>()?;
    m.add_class::<CoreMesh>()?;
    m.add_class::<CoreAnimation>()?;
    m.add_class::<CoreMerger>()?;
    Ok(())
}
