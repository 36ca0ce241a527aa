//! The octree's parameters: levels, the paper's criteria and the chord
//! tolerance of a faithful `--level`.

use super::node::MAX_LEVEL;
use crate::geometry::Bounds;
use crate::octree::{Chord, TopologyTest};

/// Octree parameters (the command line's `--level`, `--min-level`,
/// `--kmax`, `--certify`).
#[derive(Clone, Copy, Debug)]
pub struct OctreeOptions {
    /// Deepest level a cell may be subdivided to (`--level`).
    pub max_level: u8,
    /// Level down to which every non-empty cell is subdivided whatever the
    /// criteria (`--min-level`).
    pub min_level: u8,
    /// Geometry criterion (Paiva et al. §4.1): subdivide while the spread of
    /// the unit normals over the cell exceeds it; 0 refines uniformly.
    pub kmax: f64,
    /// Topology criterion applied to each cell (`--certify` picks
    /// [`TopologyTest::Certify`]).
    pub test: TopologyTest,
    /// Time at which the surface is taken.
    pub t: f64,
    /// Prune the program per subtree (see the module doc's "Pruning").
    pub prune: bool,
    /// Faithful `--level` (SPEC §2): the chord tolerance on a flat piece,
    /// in sides of a maximal-level cell (the cube root of Ω's volume over
    /// `2^max_level`); where the surface is curved the tolerance adds a
    /// share of a uniform mesher's chord error there ([`Chord`],
    /// [`OctreeOptions::chord_tolerance`] in domain units). Below the
    /// maximal level, a cell that passes the other criteria is subdivided
    /// while its estimated chord error ([`criteria::chord_error`]) exceeds
    /// `OCTREE_SLACK` times the tolerance at the turn of the normals across
    /// it; the mesher then splits the edges still farther than the
    /// tolerance at theirs (`mesher::chord`). `None`: the geometry
    /// criterion `k_max` alone (the adaptive minimum, `--coarse`).
    pub chord: Option<f64>,
}

impl Default for OctreeOptions {
    fn default() -> Self {
        OctreeOptions {
            max_level: 7,
            min_level: 3,
            kmax: 1.0,
            test: TopologyTest::Paper,
            t: 0.0,
            prune: true,
            chord: Some(DEFAULT_CHORD),
        }
    }
}

impl OctreeOptions {
    /// The chord tolerance [`OctreeOptions::chord`] in domain units: its
    /// share of the side of a maximal-level cell of `domain` on a flat
    /// piece, more where the surface is curved ([`Chord`]). Where `domain`
    /// is not a cube, the side is that of a cube of a maximal-level cell's
    /// volume (the geometric mean of its sides): a uniform mesher with
    /// `2^L` cells per axis has as many cells.
    pub fn chord_tolerance(&self, domain: Bounds) -> Option<Chord> {
        let volume: f64 = (0..3).map(|k| domain.hi[k] - domain.lo[k]).product();
        let level = self.max_level.min(MAX_LEVEL);
        let cell = volume.cbrt() / (1u64 << level) as f64;
        self.chord.map(|c| Chord {
            base: c * cell,
            cell,
        })
    }
}

/// The octree's chord criterion subdivides cells whose estimated chord
/// error exceeds this many times the tolerance: the mesher's edge splits
/// ([`crate::mesher::chord`]) correct the last factor below a level.
pub(super) const OCTREE_SLACK: f64 = 4.0;

/// The default chord tolerance of [`OctreeOptions::chord`] on a flat
/// piece, in sides of a maximal-level cell (calibrated against Fidget at
/// depth 8: `docs/faithful.md`).
pub const DEFAULT_CHORD: f64 = 0.035;

#[cfg(test)]
mod tests {
    use super::*;

    /// The chord tolerance's cell is a maximal-level cell's side on a
    /// cube, and on a box the side of a cube of that cell's volume: a box
    /// eight times as long as it is wide and deep has cells twice as
    /// large as the cube on its width, and half as large as the cube on
    /// its length. Its base is `chord` cells; `None` gives none.
    #[test]
    fn the_chord_tolerance_reads_the_cell_of_a_box_by_its_volume() {
        let opts = OctreeOptions {
            max_level: 3,
            chord: Some(0.5),
            ..OctreeOptions::default()
        };
        let cube = Bounds {
            lo: [0.0; 3],
            hi: [8.0; 3],
        };
        let long = Bounds {
            lo: [0.0; 3],
            hi: [8.0, 1.0, 1.0],
        };
        let tol = |b| opts.chord_tolerance(b).expect("on");
        assert_eq!(
            tol(cube),
            Chord {
                base: 0.5,
                cell: 1.0
            }
        );
        let c = tol(long);
        assert!((c.cell - 0.25).abs() < 1e-15, "{c:?}");
        assert!((c.base - 0.125).abs() < 1e-15, "{c:?}");
        let coarse = OctreeOptions {
            chord: None,
            ..opts
        };
        assert_eq!(coarse.chord_tolerance(long), None);
    }
}
