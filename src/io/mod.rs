//! Writing meshes: binary PLY (with normals and the red/green ambiguity
//! colours, SPEC §3), OBJ, binary STL, GLB (glTF 2.0 binary) and 3MF, chosen by
//! the output path's extension. Files are written atomically: into a
//! temporary file beside the target, then renamed, so a failed run never
//! leaves a partial file.

pub mod glb;
pub mod obj;
pub mod part;
pub mod ply;
pub mod stl;
pub mod stream;
pub mod threemf;

use std::io::Write;
use std::path::Path;

use crate::mesh::Mesh;

/// Why a mesh could not be written.
#[derive(Debug)]
pub enum WriteError {
    /// The path's extension names no format this module writes.
    UnknownFormat(std::path::PathBuf),
    /// The file system refused (the partial file, if any, is removed).
    Io {
        /// The file being written.
        path: std::path::PathBuf,
        /// What the system said.
        error: std::io::Error,
    },
}

impl std::fmt::Display for WriteError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WriteError::UnknownFormat(p) => write!(
                f,
                "{}: unknown output format; use .ply, .obj, .stl, .glb or .3mf",
                p.display()
            ),
            WriteError::Io { path, error } => write!(f, "{}: {error}", path.display()),
        }
    }
}

impl std::error::Error for WriteError {}

/// Output formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Binary PLY with normals and ambiguity colours (`.ply`, [`ply`]).
    Ply,
    /// Wavefront OBJ (`.obj`, [`obj`]).
    Obj,
    /// Binary STL (`.stl`, [`stl`]).
    Stl,
    /// Binary glTF 2.0 (`.glb`, [`glb`]).
    Glb,
    /// 3MF package (`.3mf`, [`threemf`]).
    ThreeMf,
}

impl Format {
    /// The format named by a path's extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<Format, WriteError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("ply") => Ok(Format::Ply),
            Some("obj") => Ok(Format::Obj),
            Some("stl") => Ok(Format::Stl),
            Some("glb") => Ok(Format::Glb),
            Some("3mf") => Ok(Format::ThreeMf),
            _ => Err(WriteError::UnknownFormat(path.to_path_buf())),
        }
    }
}

/// Serialises `mesh` in `format`.
pub fn encode(mesh: &Mesh, format: Format, out: &mut dyn Write) -> std::io::Result<()> {
    match format {
        Format::Ply => ply::write(mesh, out),
        Format::Obj => obj::write(mesh, out),
        Format::Stl => stl::write(mesh, out),
        Format::Glb => glb::write(mesh, out),
        Format::ThreeMf => threemf::write(mesh, out),
    }
}

/// Writes `mesh` to `path` atomically, in the format its extension names.
pub fn write_file(mesh: &Mesh, path: &Path) -> Result<(), WriteError> {
    let format = Format::from_path(path)?;
    write_atomic(path, |w| encode(mesh, format, w))
}

/// [`write_file`], with the 3MF model's unit (other formats carry no unit
/// and ignore it).
pub fn write_file_in(mesh: &Mesh, path: &Path, unit: threemf::Unit) -> Result<(), WriteError> {
    match Format::from_path(path)? {
        Format::ThreeMf => write_atomic(path, |w| threemf::write_objects(&[mesh], unit, w)),
        format => write_atomic(path, |w| encode(mesh, format, w)),
    }
}

/// Writes a file atomically: `fill` writes into a temporary file in the
/// same directory, which is renamed over `path` only when all went well.
pub fn write_atomic(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), WriteError> {
    atomic_file(path, |file| {
        let mut w = std::io::BufWriter::new(file);
        fill(&mut w)?;
        w.flush()
    })
}

/// [`write_atomic`] with the temporary file itself (seekable, unbuffered).
pub(crate) fn atomic_file(
    path: &Path,
    fill: impl FnOnce(&mut std::fs::File) -> std::io::Result<()>,
) -> Result<(), WriteError> {
    let tmp = sibling(path, "tmp");
    let result = (|| {
        let mut file = std::fs::File::create(&tmp)?;
        fill(&mut file)?;
        file.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(|error| WriteError::Io {
        path: path.to_path_buf(),
        error,
    })
}

/// A hidden file beside `path`, named for it, this process and `tag`.
pub(crate) fn sibling(path: &Path, tag: &str) -> std::path::PathBuf {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("out");
    dir.join(format!(".{name}.{}.{tag}", std::process::id()))
}
