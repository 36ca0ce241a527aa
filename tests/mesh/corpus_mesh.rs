//! The mesher on the corpus: every file meshes; whenever the mesher says
//! `guaranteed`, the mesh's own topology (components and total genus,
//! computed from the mesh) is the one the file's `# expect:` line states
//! (checked independently by `tests/front/corpus.rs`); the chair gives the same
//! triangulation up to a few percent in its three domains (Paiva et al.
//! Fig. 8: no symmetry artefacts).

use isoc::mesher::{self, MeshOptions, MeshReport};
use isoc::octree::{OctreeOptions, TopologyTest};
use isoc::{CompileOptions, Surface};

use crate::support::corpus;

/// `(components, total genus)` from the `# expect:` line, `None` for a
/// singular surface.
fn expected(src: &str) -> Option<(usize, i64)> {
    let line = src.lines().find_map(|l| l.strip_prefix("# expect:"))?;
    let get = |k: &str| {
        line.split_whitespace()
            .find_map(|w| w.strip_prefix(&format!("{k}=")))
            .map(|v| v.parse::<i64>().unwrap())
    };
    Some((get("components")? as usize, get("genus")?))
}

fn run(s: &Surface, level: u8, kmax: f64, test: TopologyTest) -> MeshReport {
    let opts = MeshOptions {
        octree: OctreeOptions {
            max_level: level,
            min_level: 3.min(level),
            kmax,
            test,
            t: 0.0,
            prune: true,
            chord: None,
        },
        smooth: 0,
        domain: None,
        creases: true,
    };
    mesher::mesh(s, &opts, &|_| {}).1
}

#[test]
fn guaranteed_corpus_meshes_have_the_true_topology() {
    let mut guaranteed_somewhere = 0;
    for (name, src) in corpus() {
        let s = Surface::compile(&src, &name, &CompileOptions::default()).unwrap();
        let want = expected(&src);
        for level in 4..=8 {
            for test in [TopologyTest::Paper, TopologyTest::Certify] {
                let r = run(&s, level, 1.0, test);
                if !r.guaranteed {
                    continue;
                }
                guaranteed_somewhere += 1;
                let (c, g) = want.unwrap_or_else(|| {
                    panic!(
                        "{name} level {level} {test:?}: a singular surface was called guaranteed"
                    )
                });
                let t = &r.topology;
                let genus: i64 = t.genus.iter().map(|g| g.unwrap_or(-1000)).sum();
                assert!(
                    t.watertight && t.components == c && genus == g,
                    "{name} level {level} {test:?}: guaranteed, but the mesh has {t:?}; expected {c} component(s), genus {g}"
                );
            }
        }
    }
    assert!(
        guaranteed_somewhere > 0,
        "the check above must not be vacuous"
    );
}

#[test]
fn chair_has_no_symmetry_artefacts() {
    let counts: Vec<usize> = ["left", "mid", "right"]
        .iter()
        .map(|side| {
            let path = format!("corpus/chair_{side}.iso");
            let src = std::fs::read_to_string(&path).unwrap();
            let s = Surface::compile(&src, &path, &CompileOptions::default()).unwrap();
            run(&s, 6, 0.95, TopologyTest::Paper).triangles
        })
        .collect();
    let (lo, hi) = (*counts.iter().min().unwrap(), *counts.iter().max().unwrap());
    assert!(lo > 0);
    assert!(
        (hi - lo) as f64 <= 0.05 * hi as f64,
        "triangle counts differ by more than 5%: {counts:?}"
    );
}
