//! Writing a mesh that arrives part by part ([`crate::mesh::sink::Sink`],
//! fed by bricked meshing), without holding it.
//!
//! # Contract
//!
//! A [`StreamWriter`] appends each part's vertex and triangle records to
//! two temporary files beside the output as they come; [`StreamWriter::finish`]
//! writes the header (which needs the counts), copies the records after it
//! and renames the file into place — so memory stays one part's records,
//! and a failed or dropped writer leaves no output and no temporary file.
//! The records are the in-memory writers' own ([`super::ply`],
//! [`super::stl`], [`super::obj`], [`super::threemf`]): a streamed file is
//! byte for byte what writing the welded mesh at once would give.
//!
//! # Limits
//!
//! - GLB is gathered in memory and written at the end (its binary chunk
//!   follows a JSON header that needs every count and bound).
//! - The disk holds the records twice for a moment (the temporary files
//!   and the output).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::{Format, WriteError, atomic_file, sibling, threemf, write_atomic};
use crate::mesh::Mesh;
use crate::mesh::sink::Sink;

/// A mesh file written as its parts arrive (see the module doc).
pub struct StreamWriter {
    path: PathBuf,
    format: Format,
    unit: threemf::Unit,
    /// Vertex and triangle records (none for GLB).
    records: Option<[Records; 2]>,
    /// GLB's mesh, gathered.
    gathered: Mesh,
    vertices: usize,
    triangles: usize,
    buf: Vec<u8>,
}

/// One temporary file of records.
struct Records {
    path: PathBuf,
    out: BufWriter<File>,
}

impl Records {
    fn create(path: PathBuf) -> std::io::Result<Records> {
        let out = BufWriter::with_capacity(1 << 20, File::create(&path)?);
        Ok(Records { path, out })
    }

    /// The records, flushed and rewound for reading.
    fn reader(&mut self) -> std::io::Result<File> {
        self.out.flush()?;
        File::open(&self.path)
    }
}

impl Drop for Records {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

impl StreamWriter {
    /// A writer of `path`, in the format its extension names (`unit`: a
    /// 3MF model's).
    pub fn create(path: &Path, unit: threemf::Unit) -> Result<StreamWriter, WriteError> {
        let format = Format::from_path(path)?;
        let io = |error| WriteError::Io {
            path: path.to_path_buf(),
            error,
        };
        let records = match format {
            Format::Glb => None,
            _ => Some([
                Records::create(sibling(path, "vertices")).map_err(io)?,
                Records::create(sibling(path, "triangles")).map_err(io)?,
            ]),
        };
        Ok(StreamWriter {
            path: path.to_path_buf(),
            format,
            unit,
            records,
            gathered: Mesh::default(),
            vertices: 0,
            triangles: 0,
            buf: Vec::new(),
        })
    }

    /// Writes the file: header, records, trailer; renamed into place.
    pub fn finish(mut self) -> Result<(), WriteError> {
        let (nv, nf) = (self.vertices, self.triangles);
        let Some([mut v, mut t]) = self.records.take() else {
            let mesh = std::mem::take(&mut self.gathered);
            return write_atomic(&self.path, |w| super::encode(&mesh, self.format, w));
        };
        let io = |error| WriteError::Io {
            path: self.path.clone(),
            error,
        };
        let (mut v, mut t) = (v.reader().map_err(io)?, t.reader().map_err(io)?);
        if self.format == Format::ThreeMf {
            let large = v.metadata().map_err(io)?.len() + t.metadata().map_err(io)?.len()
                > u64::from(u32::MAX) / 2;
            let unit = self.unit;
            return atomic_file(&self.path, |file| {
                threemf::package(BufWriter::new(file), large, |w| {
                    threemf::model_start(unit, w)?;
                    if nf > 0 {
                        threemf::object_start(1, w)?;
                        std::io::copy(&mut v, w)?;
                        threemf::vertices_end(w)?;
                        std::io::copy(&mut t, w)?;
                        threemf::object_end(w)?;
                    }
                    threemf::model_end(usize::from(nf > 0), w)
                })?
                .flush()
            });
        }
        let format = self.format;
        write_atomic(&self.path, |w| {
            match format {
                Format::Ply => super::ply::header(w, nv, nf)?,
                Format::Stl => super::stl::header(w, nf)?,
                _ => writeln!(w, "# isoc")?,
            }
            if format != Format::Stl {
                std::io::copy(&mut v, w)?;
            }
            std::io::copy(&mut t, w)?;
            Ok(())
        })
    }

    /// The records of `part`'s vertices `new` and of its triangles
    /// (`triangles`: renumbered) in the writer's format, into `self.buf`
    /// as two runs; returns where the triangles start.
    fn encode(&mut self, part: &Mesh, new: &[u32], triangles: &[[u32; 3]]) -> usize {
        let buf = &mut self.buf;
        buf.clear();
        for &i in new {
            let i = i as usize;
            match self.format {
                Format::Ply => super::ply::vertex(buf, part, i),
                Format::Obj => super::obj::vertex(buf, part, i),
                Format::ThreeMf => {
                    threemf::vertex(part.positions[i], buf).expect("writing to memory")
                }
                Format::Stl | Format::Glb => {}
            }
        }
        let split = buf.len();
        for (k, &t) in triangles.iter().enumerate() {
            match self.format {
                Format::Ply => super::ply::face(buf, t),
                Format::Obj => super::obj::face(buf, t, super::obj::with_normals(part)),
                Format::Stl => super::stl::facet(buf, part, part.triangles[k]),
                _ => threemf::triangle(t, buf).expect("writing to memory"),
            }
        }
        split
    }
}

impl Sink for StreamWriter {
    fn append(&mut self, part: &Mesh, new: &[u32], triangles: &[[u32; 3]]) -> std::io::Result<()> {
        self.vertices += new.len();
        self.triangles += triangles.len();
        if self.records.is_none() {
            return self.gathered.append(part, new, triangles);
        }
        let split = self.encode(part, new, triangles);
        let Some([v, t]) = self.records.as_mut() else {
            return Ok(());
        };
        v.out.write_all(&self.buf[..split])?;
        t.out.write_all(&self.buf[split..])
    }
}
