//! Polygonisation of (dual) cells.
//!
//! * [`mc33`]: the topologically correct Marching Cubes 33 polygoniser of one
//!   cube cell given its 8 corner values (Lewiner et al. 2003; Chernyaev
//!   1995), derived procedurally from the trilinear interpolant rather than
//!   from a case table. Degenerate dual cells (Paiva et al. 2006, §4.3:
//!   corners repeated where octree leaves of different sizes meet) need
//!   nothing special: their key is the 8 values with the repeated corners'
//!   values duplicated.
//! * [`extract`]: dual marching cubes over the octree — every active dual
//!   cell through [`mc33`], vertices keyed by leaf pairs and bisected onto
//!   the surface, joined into one mesh.
//! * [`isolated`]: the samples every cell leaves alone (blobs beside sharp
//!   edges), and the one join per sample that `f` confirms.
//!
//! The topology of the result is measured by [`crate::mesh::topology`].

pub mod extract;
mod isolated;
pub mod mc33;
