//! Where a mesh goes when it is built part by part (bricked meshing,
//! `crate::mesher::stitch`): a [`Sink`] takes each part's new vertices and
//! its triangles as they come, so the whole mesh need never be in memory.
//! A [`Mesh`] is the in-memory sink; `crate::io::stream` writes files.

use super::Mesh;

/// Receives a mesh part by part.
pub trait Sink {
    /// Appends the vertices `new` of `part` (indices into it), numbered on
    /// from those appended before, and then all of `part`'s triangles,
    /// given as `triangles`: the same triangles over the whole mesh's
    /// vertex numbers (`triangles[k]` is `part.triangles[k]` renumbered).
    fn append(&mut self, part: &Mesh, new: &[u32], triangles: &[[u32; 3]]) -> std::io::Result<()>;
}

impl Sink for Mesh {
    fn append(&mut self, part: &Mesh, new: &[u32], triangles: &[[u32; 3]]) -> std::io::Result<()> {
        for &v in new {
            let v = v as usize;
            self.positions.push(part.positions[v]);
            self.normals
                .push(part.normals.get(v).copied().unwrap_or_default());
            self.ambiguous
                .push(part.ambiguous.get(v).copied().unwrap_or(false));
        }
        self.triangles.extend_from_slice(triangles);
        Ok(())
    }
}

impl<S: Sink + ?Sized> Sink for &mut S {
    fn append(&mut self, part: &Mesh, new: &[u32], triangles: &[[u32; 3]]) -> std::io::Result<()> {
        (**self).append(part, new, triangles)
    }
}
