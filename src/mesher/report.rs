//! The statistics object of SPEC §2 (`isoc mesh --stats json`), built from
//! a [`MeshReport`] in one place: the command line prints it and the Python
//! package's `Mesh.stats` is the same object.

use serde_json::{Value as Json, json};

use super::{MeshReport, ToleranceReport};

/// A number for JSON: shortest round-trip form; non-finite values (which
/// JSON cannot hold) become `null`.
fn num(v: f64) -> Json {
    json!(v)
}

/// The `--stats json` object of a mesh run: `report` from
/// [`super::mesh`] (or [`super::mesh_to_tolerance`], whose
/// [`ToleranceReport`] is `tolerance`), `compile_ms` the time spent
/// compiling the surface, `certify` whether the stricter topology test ran.
pub fn stats_json(
    r: &MeshReport,
    tolerance: Option<&ToleranceReport>,
    compile_ms: f64,
    certify: bool,
) -> Json {
    let mut j = json!({
        "triangles": r.triangles,
        "vertices": r.vertices,
        "aspect_good": num(r.aspect_good),
        "components": r.topology.components,
        "euler": r.topology.euler,
        "genus": r.topology.genus,
        "watertight": r.topology.watertight,
        "manifold": r.topology.manifold(),
        "nonmanifold_edges": r.topology.bad_edges(),
        "ambiguous_cells": r.ambiguous_cells,
        "guaranteed": r.guaranteed,
        "max_level_reached": r.octree.max_level_reached,
        "topology_test": if certify { "certify" } else { "paper" },
        "boundary_edges": r.topology.boundary_edges,
        "crease_vertices": r.crease_vertices,
        "octree_nodes": r.octree.nodes,
        "dual_cells": r.dual_cells,
        "timings_ms": {
            "compile": num(compile_ms),
            "octree": num(r.timings.octree),
            "dual": num(r.timings.dual),
            "polygonize": num(r.timings.polygonize),
            "smooth": num(r.timings.smooth),
            "total": num(tolerance.map_or(r.timings.total, |t| t.total_ms) + compile_ms),
        }
    });
    if let (Some(t), Some(obj)) = (tolerance, j.as_object_mut()) {
        obj.insert("max_deviation".into(), num(t.max_deviation));
        obj.insert("tolerance_met".into(), json!(t.met));
        obj.insert("tolerance_passes".into(), json!(t.passes));
        obj.insert("kmax".into(), num(t.kmax));
        obj.insert(
            "adapt".into(),
            json!({
                "splits": t.adapted.splits,
                "refused": t.adapted.refused,
                "collapses": t.adapted.collapses,
                "flips": t.adapted.flips,
                "rounds": t.adapted.rounds,
                "ms": {
                    "size": num(t.adapted.ms[0]),
                    "repair": num(t.adapted.ms[1]),
                    "relax": num(t.adapted.ms[2]),
                },
            }),
        );
        if let Some(ms) = j["timings_ms"].as_object_mut() {
            ms.insert("adapt".into(), num(r.timings.adapt));
        }
    }
    j
}
