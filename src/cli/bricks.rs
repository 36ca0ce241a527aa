//! Bricked meshing on the command line (SPEC §2): `mesh --bricks B`
//! (every brick, streamed into one file), `mesh --bricks B --brick I` (one
//! brick into a part file) and `merge` (parts into one file).

use std::io::{BufReader, Write};
use std::path::{Path, PathBuf};

use isoc::Surface;
use isoc::io::stream::StreamWriter;
use isoc::io::{Format, part, threemf};
use isoc::mesher::brick::{self, Brick, BrickError, PartInfo};
use isoc::mesher::stitch::Stitcher;
use isoc::mesher::{MeshOptions, MeshReport};
use serde_json::json;

use super::{Error, MeshArgs, StatsFormat, interrupt, io_err, print_stats, summary};

/// Refuses brick flags that cannot work, before any work is done.
pub fn check(m: &MeshArgs, output: &Path) -> Result<(), Error> {
    let Some(b) = m.bricks else {
        return Ok(());
    };
    if m.tolerance.is_some() {
        return Err(Error::Usage(
            "--tolerance adapts the whole mesh at once; it does not go with --bricks".into(),
        ));
    }
    if let Some(i) = m.brick {
        let n = Brick::count(b);
        if i >= n {
            return Err(Error::Usage(format!(
                "--brick {i}: --bricks {b} has bricks 0 to {}",
                n - 1
            )));
        }
        if Format::from_path(output)? != Format::Ply {
            return Err(Error::Usage(
                "--brick writes a part file for `isoc merge`: give -o PART.ply".into(),
            ));
        }
    }
    Ok(())
}

/// `--bricks B --brick I`: brick `i` into the part file `output`.
pub fn mesh_part(
    surface: &Surface,
    opts: &MeshOptions,
    bricks: u8,
    i: u32,
    output: &Path,
) -> Result<MeshReport, Error> {
    let b = Brick::new(bricks, i).ok_or_else(|| Error::Usage(format!("--brick {i}")))?;
    let (p, info) =
        brick::mesh_part(surface, opts, b, &interrupt()).map_err(|_| Error::Interrupted)?;
    let info = info.to_json();
    isoc::io::write_atomic(output, |w| part::write(&p.mesh, &p.origins, &info, w))?;
    // The summary and `--stats` tell the part's own topology: open along
    // its seams.
    let mut report = p.report;
    report.topology = isoc::mesh::topology::analyze_in(&p.mesh, Some(&surface.domain));
    report.aspect_good = isoc::mesh::quality::aspect_good(&p.mesh);
    Ok(report)
}

/// `--bricks B`: every brick, welded and streamed into `output`.
pub fn mesh_bricked(
    surface: &Surface,
    opts: &MeshOptions,
    bricks: u8,
    output: &Path,
    unit: threemf::Unit,
    bar: &indicatif::ProgressBar,
) -> Result<MeshReport, Error> {
    let mut writer = StreamWriter::create(output, unit)?;
    let done = |k: u32, n: u32| bar.set_message(format!("bricks: {k} of {n} meshed"));
    let report = brick::mesh_bricks(
        surface,
        surface.domain,
        opts,
        bricks,
        &mut writer,
        &done,
        &interrupt(),
    )
    .map_err(|e| match e {
        BrickError::Io(error) => Error::Io {
            path: output.display().to_string(),
            error,
        },
        BrickError::Cancelled => Error::Interrupted,
    })?;
    bar.set_message("writing");
    writer.finish()?;
    Ok(report)
}

/// A part file's header, read.
struct Listed {
    path: PathBuf,
    info: PartInfo,
}

/// Reads the headers of `parts` and checks that they are bricks of one
/// run, each once; returns them in brick order.
fn list(parts: &[PathBuf]) -> Result<Vec<Listed>, Error> {
    let mut listed = Vec::with_capacity(parts.len());
    for path in parts {
        let name = path.display().to_string();
        let file = std::fs::File::open(path).map_err(io_err(&name))?;
        let header = part::read_header(&mut BufReader::new(file))
            .map_err(|e| Error::Usage(format!("{name}: {e}")))?;
        let info = PartInfo::from_json(&header.info)
            .map_err(|e| Error::Usage(format!("{name}: not an isoc part file: {e}")))?;
        listed.push(Listed {
            path: path.clone(),
            info,
        });
    }
    listed.sort_by_key(|l| l.info.brick);
    let first = &listed[0];
    for l in &listed {
        if (l.info.bricks, &l.info.run) != (first.info.bricks, &first.info.run) {
            return Err(Error::Usage(format!(
                "{} and {}: parts of different runs (other surface, options or --bricks)",
                first.path.display(),
                l.path.display()
            )));
        }
    }
    for w in listed.windows(2) {
        if w[0].info.brick == w[1].info.brick {
            return Err(Error::Usage(format!(
                "{} and {}: both are brick {}",
                w[0].path.display(),
                w[1].path.display(),
                w[0].info.brick
            )));
        }
    }
    Ok(listed)
}

/// `isoc merge PART... -o OUT`: welds parts (in brick order, whatever
/// the order given) into `output`, streamed.
pub fn merge(
    parts: &[PathBuf],
    output: &Path,
    unit: &str,
    stats: Option<StatsFormat>,
    out: &mut dyn Write,
    err: &mut dyn Write,
) -> Result<(), Error> {
    let start = std::time::Instant::now();
    let cancel = interrupt();
    let unit: threemf::Unit = unit.parse().map_err(Error::Usage)?;
    Format::from_path(output)?;
    let listed = list(parts)?;
    let (bricks, count) = (listed[0].info.bricks, Brick::count(listed[0].info.bricks));
    if listed.len() < count as usize {
        let _ = writeln!(
            err,
            "warning: {} of the run's {count} bricks given; the mesh is open where the others belong",
            listed.len()
        );
    }
    let mut writer = StreamWriter::create(output, unit)?;
    let mut stitcher = Stitcher::new(&mut writer);
    let mut reports = Vec::with_capacity(listed.len());
    for l in &listed {
        cancel.check().map_err(|_| Error::Interrupted)?;
        let name = l.path.display().to_string();
        let bytes = std::fs::read(&l.path).map_err(io_err(&name))?;
        let (mesh, origins, _) =
            part::read(&bytes).map_err(|e| Error::Usage(format!("{name}: {e}")))?;
        stitcher.add(&mesh, &origins).map_err(io_err(&name))?;
        reports.push(l.info.report.clone());
    }
    let (welded, _) = stitcher.finish();
    writer.finish()?;
    let ms = start.elapsed().as_secs_f64() * 1e3;
    let report = brick::merge_reports(&reports, &welded, ms);
    let _ = err.write_all(summary(output, &report).as_bytes());
    if stats == Some(StatsFormat::Json) {
        let certify = listed[0].info.certify;
        let mut j = isoc::mesher::report::stats_json(&report, None, 0.0, certify);
        j["bricks"] = json!(bricks);
        j["parts"] = json!(listed.len());
        print_stats(j, out)?;
    }
    Ok(())
}
