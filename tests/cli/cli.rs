//! The command line as a user runs it (SPEC §2): exit statuses, the error
//! format, `eval --json`, `compile --emit`.

use std::path::PathBuf;
use std::process::{Command, Output};

pub(crate) fn isoc(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_isoc"))
        .args(args)
        .output()
        .expect("run isoc")
}

/// A fresh temporary file holding `text`.
pub(crate) fn temp_file(name: &str, text: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("isoc-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

pub(crate) fn stdout(o: &Output) -> String {
    String::from_utf8(o.stdout.clone()).unwrap()
}

pub(crate) fn stderr(o: &Output) -> String {
    String::from_utf8(o.stderr.clone()).unwrap()
}

#[test]
fn eval_point_json_matches_hand_computation() {
    let f = temp_file(
        "sphere.iso",
        b"domain [-2, 2]^3;\nsurface x^2 + y^2 + z^2 - 1;\n",
    );
    let o = isoc(&["eval", f.to_str().unwrap(), "0.5", "-1", "2", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(j["value"].as_f64().unwrap(), 0.25 + 1.0 + 4.0 - 1.0);
    let g: Vec<f64> = j["grad"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(g, vec![1.0, -2.0, 4.0]);
}

#[test]
fn eval_uses_time() {
    let f = temp_file("pulse.iso", b"domain [-2, 2]^3;\nsurface x + 10*t;\n");
    let o = isoc(&["eval", f.to_str().unwrap(), "1", "0", "0", "0.5", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(j["value"].as_f64().unwrap(), 6.0);
}

#[test]
fn eval_box_json_encloses() {
    let f = temp_file(
        "sphere2.iso",
        b"domain [-2, 2]^3;\nsurface x^2 + y^2 + z^2 - 1;\n",
    );
    let o = isoc(&[
        "eval",
        f.to_str().unwrap(),
        "--box",
        "-1,2,0,1,0.5,0.5",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let v = &j["value"];
    // x^2 ∈ [0, 4], y^2 ∈ [0, 1], z^2 = 0.25: f ∈ [-0.75, 4.25].
    assert!(v[0].as_f64().unwrap() <= -0.75 && v[1].as_f64().unwrap() >= 4.25);
    assert!(v[0].as_f64().unwrap() > -0.76 && v[1].as_f64().unwrap() < 4.26);
    // ∂f/∂x = 2x ∈ [-2, 4].
    let gx = &j["grad"][0];
    assert!(gx[0].as_f64().unwrap() <= -2.0 && gx[1].as_f64().unwrap() >= 4.0);
    assert_eq!(j["defined"], serde_json::Value::Bool(true));
}

#[test]
fn errors_are_located_with_a_caret_and_exit_1() {
    let f = temp_file("bad.iso", b"domain [-1, 1]^3;\nsurface x + qq;\n");
    let o = isoc(&["compile", f.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    let first = e.lines().next().unwrap();
    assert!(
        first.ends_with("bad.iso:2:13: error: unknown name `qq`")
            || (first.contains("bad.iso:2:13: error:") && first.contains("qq")),
        "{e}"
    );
    assert!(e.contains("surface x + qq;"), "{e}");
    assert!(e.contains('^'), "{e}");
    assert!(stdout(&o).is_empty());
}

#[test]
fn bad_options_are_errors_not_panics() {
    let f = temp_file(
        "ok.iso",
        b"domain [-1, 1]^3;\nparam r = 1;\nsurface x - r;\n",
    );
    let p = f.to_str().unwrap();
    for args in [
        vec!["compile", p, "--set", "nope=1"],
        vec!["compile", p, "--set", "r=abc"],
        vec!["compile", p, "--domain", "1,0,0,1,0,1"],
        vec!["eval", p, "1", "2"],
        vec!["eval", p, "--box", "0,1,0,1"],
        vec!["compile", "/nonexistent/file.iso"],
    ] {
        let o = isoc(&args);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("error"), "{args:?}");
    }
    let o = isoc(&["eval", p, "3", "0", "0", "--set", "r=2.5", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(j["value"].as_f64().unwrap(), 0.5);
}

#[test]
fn emit_ir_round_trips_through_the_text_form() {
    let f = temp_file(
        "ir.iso",
        b"domain [-1, 1]^3;\nlet a = 2*x^2 + y^2 + z^2 - 1;\nsurface a^3 - (0.1*x^2 + y^2)*z^3;\n",
    );
    let o = isoc(&["compile", f.to_str().unwrap(), "--emit", "ir"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let p = isoc::ir::text::parse(&text).unwrap();
    assert_eq!(p.to_string(), text);
    let s = isoc::Surface::compile(
        &std::fs::read_to_string(&f).unwrap(),
        "ir.iso",
        &Default::default(),
    )
    .unwrap();
    assert_eq!(p, s.program);
    // 0.1 is kept with its enclosure.
    assert!(text.contains("const 0.1 ["), "{text}");
}

/// `--emit asm` and `--emit clif` list every kernel the JIT may run, the
/// point gradient's two tiers among them (the second one named apart),
/// each with its text.
#[test]
fn emit_lists_both_point_gradient_tiers() {
    let f = temp_file(
        "tiers.iso",
        b"domain [-1, 1]^3;\nsurface min(x^2 + y^2 + z^2 - 0.5, x + 0.25);\n",
    );
    for stage in ["asm", "clif"] {
        let o = isoc(&["compile", f.to_str().unwrap(), "--emit", stage]);
        assert!(o.status.success(), "{}", stderr(&o));
        let text = stdout(&o);
        for name in ["point_grad_batch", "point_grad_batch_x2"] {
            let header = format!("; ---- {name} ----\n");
            let at = text
                .find(&header)
                .unwrap_or_else(|| panic!("{stage}: no {name} in\n{text}"));
            let body = &text[at + header.len()..];
            let body = &body[..body.find("; ----").unwrap_or(body.len())];
            assert!(
                body.len() > 100 && !body.contains("(not available)"),
                "{stage}: {name}: {body}"
            );
        }
    }
}

#[test]
fn emit_ast_prints_something_for_every_statement() {
    let f = temp_file(
        "ast.iso",
        b"domain [-1, 1], [-2, 2], [-3, 3];\nparam r = 2;\nfn g(x, c) = x*c;\nlet a = g(y, r);\nsurface a = 1;\n",
    );
    let o = isoc(&["compile", f.to_str().unwrap(), "--emit", "ast"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    for word in ["domain", "param", "fn", "let", "surface"] {
        assert!(text.contains(word), "{word} missing in\n{text}");
    }
}

#[test]
fn mesh_stats_json_and_output_file() {
    let f = temp_file(
        "msphere.iso",
        b"domain [-1.3, 1.3]^3;\nsurface x^2 + y^2 + z^2 - 1;\n",
    );
    let out = f.with_extension("glb");
    let _ = std::fs::remove_file(&out);
    let o = isoc(&[
        "mesh",
        f.to_str().unwrap(),
        "--level",
        "5",
        "-o",
        out.to_str().unwrap(),
        "--stats",
        "json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert_eq!(text.lines().count(), 1, "exactly one JSON object: {text}");
    let j: serde_json::Value = serde_json::from_str(&text).unwrap();
    for key in [
        "triangles",
        "vertices",
        "aspect_good",
        "components",
        "euler",
        "genus",
        "watertight",
        "ambiguous_cells",
        "guaranteed",
        "max_level_reached",
        "timings_ms",
    ] {
        assert!(j.get(key).is_some(), "missing {key}: {text}");
    }
    for key in ["compile", "octree", "dual", "polygonize", "smooth", "total"] {
        assert!(j["timings_ms"][key].is_number(), "timings_ms.{key}");
    }
    assert_eq!(j["components"], 1);
    assert_eq!(j["euler"], 2);
    assert_eq!(j["genus"], serde_json::json!([0]));
    assert_eq!(j["watertight"], true);
    assert_eq!(j["guaranteed"], true);
    assert_eq!(&std::fs::read(&out).unwrap()[..4], b"glTF");
}

#[test]
fn mesh_default_output_is_the_stem_with_ply() {
    let f = temp_file(
        "stem.iso",
        b"domain [-1.3, 1.3]^3;\nsurface x^2 + y^2 + z^2 - 1;\n",
    );
    let ply = f.with_extension("ply");
    let _ = std::fs::remove_file(&ply);
    let o = isoc(&["mesh", f.to_str().unwrap(), "--level", "4"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).is_empty(), "nothing on stdout unless asked");
    assert!(std::fs::read(&ply).unwrap().starts_with(b"ply\n"));
}

#[test]
fn mesh_errors_write_no_file() {
    let f = temp_file("broken.iso", b"domain [-1, 1]^3;\nsurface x +;\n");
    let out = f.with_extension("ply");
    let _ = std::fs::remove_file(&out);
    let o = isoc(&["mesh", f.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(!out.exists());
    let g = temp_file("good.iso", b"domain [-1, 1]^3;\nsurface x;\n");
    let o = isoc(&["mesh", g.to_str().unwrap(), "-o", "/tmp/x.unknown"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("format"));
}

#[test]
fn animate_writes_both_meshes_per_frame_and_stats() {
    let dir = std::env::temp_dir().join(format!("isoc-anim-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let src = concat!(env!("CARGO_MANIFEST_DIR"), "/corpus/pulse.iso");
    let o = isoc(&[
        "animate",
        src,
        "--t0",
        "0",
        "--t1",
        "0.2",
        "--frames",
        "3",
        "--edge",
        "0.2",
        "--alpha",
        "10",
        "--passes",
        "2",
        "-o",
        dir.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).is_empty(),
        "stdout must stay empty without --json"
    );
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("stats.json")).unwrap()).unwrap();
    let frames = stats.as_array().unwrap();
    assert_eq!(frames.len(), 3);
    for (k, f) in frames.iter().enumerate() {
        let t = f["t"].as_f64().unwrap();
        assert!((t - 0.1 * k as f64).abs() < 1e-12);
        for key in [
            "mechanical_triangles",
            "geometric_triangles",
            "splits",
            "collapses",
            "inverted_found",
            "inverted_repaired",
        ] {
            assert!(f[key].is_u64(), "{key} in {f}");
        }
        assert!(f["ms"]["total"].as_f64().unwrap() >= 0.0);
        for kind in ["geometric", "mechanical"] {
            let path = dir.join(format!("{kind}_{k:04}.ply"));
            let bytes = std::fs::read(&path).unwrap();
            let head = String::from_utf8_lossy(&bytes[..400.min(bytes.len())]).to_string();
            let tris = f[format!("{kind}_triangles")].as_u64().unwrap();
            assert!(
                head.contains(&format!("element face {tris}")),
                "{path:?}: {head}"
            );
        }
    }
    // No temporary files are left behind.
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    assert_eq!(names.len(), 7, "{names:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn animate_errors_write_nothing() {
    let dir = std::env::temp_dir().join(format!("isoc-anim-bad-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let bad = temp_file("bad_anim.iso", b"domain [-1, 1]^3;\nsurface x^2 + * t;\n");
    let o = isoc(&[
        "animate",
        bad.to_str().unwrap(),
        "--t0",
        "0",
        "--t1",
        "1",
        "--frames",
        "2",
        "-o",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("bad_anim.iso:2:"), "{}", stderr(&o));
    assert!(stderr(&o).contains('^'));
    assert!(!dir.exists());
    let good = concat!(env!("CARGO_MANIFEST_DIR"), "/corpus/pulse.iso");
    for args in [
        vec!["--frames", "0"],
        vec!["--frames", "2", "--edge", "-1"],
        vec!["--frames", "2", "--edge", "0"],
        vec!["--frames", "2", "--e-min", "1", "--e-max", "1.5"],
        vec!["--frames", "2", "--poisson", "0.5"],
        vec!["--frames", "2", "--passes", "13"],
        vec!["--frames", "2", "--edge", "1e-6"],
        vec!["--frames", "2", "--alpha", "nan"],
    ] {
        let mut all = vec![
            "animate",
            good,
            "--t0",
            "0",
            "--t1",
            "1",
            "-o",
            dir.to_str().unwrap(),
        ];
        all.extend(args.iter());
        let o = isoc(&all);
        assert_ne!(o.status.code(), Some(0), "{args:?}");
        assert!(!stderr(&o).contains("panicked"), "{args:?}: {}", stderr(&o));
        // The tracker's typed errors come back named by the flag given
        // (`-1` is refused by clap before the tracker sees it).
        if let Some(flag) = args
            .get(2)
            .filter(|f| ["--edge", "--passes", "--alpha"].contains(f) && args[3] != "-1")
        {
            assert!(
                stderr(&o).starts_with(&format!("error: {flag}")),
                "{args:?}: {}",
                stderr(&o)
            );
        }
        assert!(!dir.exists(), "{args:?} created the output directory");
    }
}

// ------------------------------------------------------------ `.vm` models

use crate::support::vmref;

/// `isoc eval MODEL X Y Z --json` agrees with the independent line-by-line
/// interpreter of the `.vm` text (Fidget's semantics, f64) at random
/// points of the domain, on each shared model.
#[test]
fn vm_models_eval_matches_independent_interpreter() {
    for (m, model) in vmref::MODELS.iter().enumerate() {
        let path = vmref::models_dir().join(model);
        let text = std::fs::read_to_string(&path).unwrap();
        let mut rng = vmref::Lcg(0x9e37_79b9_7f4a_7c15 ^ m as u64);
        let n = if *model == "prospero.vm" { 20 } else { 50 };
        for _ in 0..n {
            let p = [0, 1, 2].map(|_| rng.range(-1.0, 1.0));
            let args: Vec<String> = p.iter().map(|c| format!("{c:?}")).collect();
            let o = isoc(&[
                "eval",
                path.to_str().unwrap(),
                &args[0],
                &args[1],
                &args[2],
                "--json",
            ]);
            assert!(o.status.success(), "{model}: {}", stderr(&o));
            let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
            let got = j["value"].as_f64().unwrap_or(f64::NAN);
            let want = vmref::eval(&text, p[0], p[1], p[2]);
            assert!(
                vmref::agree(got, want),
                "{model} at {p:?}: isoc {got:e}, reference {want:e}"
            );
        }
    }
}

fn models_path(name: &str) -> String {
    vmref::models_dir().join(name).to_str().unwrap().to_string()
}

fn mesh_stats(args: &[&str]) -> serde_json::Value {
    let o = isoc(args);
    assert!(o.status.success(), "{}", stderr(&o));
    serde_json::from_str(&stdout(&o)).unwrap()
}

#[test]
fn vm_tanglecube_mesh_is_closed_genus_5() {
    // The model's surface reaches |x| ≈ 2.34, so the default [-1, 1]³ cuts
    // it; a domain around all of it gives the closed genus-5 surface.
    let out = temp_file("tanglecube.ply", b"");
    let j = mesh_stats(&[
        "mesh",
        &models_path("tanglecube.vm"),
        "--level",
        "5",
        "--domain",
        "-3,3,-3,3,-3,3",
        "--stats",
        "json",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(j["watertight"], true, "{j}");
    assert_eq!(j["boundary_edges"], 0, "{j}");
    assert_eq!(j["components"], 1, "{j}");
    assert_eq!(j["genus"], serde_json::json!([5]), "{j}");
}

#[test]
fn vm_two_d_model_gives_an_open_prism() {
    let out = temp_file("quarter.ply", b"");
    let j = mesh_stats(&[
        "mesh",
        &models_path("quarter.vm"),
        "--level",
        "5",
        "--stats",
        "json",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(j["watertight"], false, "{j}");
    assert!(j["boundary_edges"].as_u64().unwrap() > 0, "{j}");
    assert!(j["triangles"].as_u64().unwrap() > 0, "{j}");
    // Open only where the domain cuts it: still a manifold (SPEC §2).
    assert_eq!(j["manifold"], true, "{j}");
    assert_eq!(j["nonmanifold_edges"], 0, "{j}");
}

#[test]
fn mesh_reports_the_manifold_check() {
    // The random CSG scene whose mesh once had 3 edges on four triangles
    // (in ambiguous cells): closed and 2-manifold, and said so.
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/regress/csg_nonmanifold.iso");
    let out = temp_file("csg_nonmanifold.ply", b"");
    let args = [
        "mesh",
        scene.to_str().unwrap(),
        "--level",
        "7",
        "--stats",
        "json",
        "-o",
        out.to_str().unwrap(),
    ];
    let o = isoc(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(j["manifold"], true, "{j}");
    assert_eq!(j["nonmanifold_edges"], 0, "{j}");
    assert_eq!(j["watertight"], true, "{j}");
    assert!(stderr(&o).contains(", manifold,"), "{}", stderr(&o));
}

#[test]
fn level_alone_is_faithful_kmax_and_coarse_are_the_adaptive_minimum() {
    let f = temp_file(
        "faithful_sphere.iso",
        b"domain [-1.5, 1.5]^3;\nsurface x^2 + y^2 + z^2 - 1;\n",
    );
    let out = temp_file("faithful_sphere.ply", b"");
    let tris = |extra: &[&str]| {
        let mut args = vec![
            "mesh",
            f.to_str().unwrap(),
            "--level",
            "6",
            "--stats",
            "json",
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        mesh_stats(&args)["triangles"].as_u64().unwrap()
    };
    let (faithful, coarse) = (tris(&[]), tris(&["--coarse"]));
    // The chord criterion refines the flat-looking cells the geometry
    // criterion alone keeps coarse (a sphere: 284 triangles at any level).
    assert!(faithful > 10 * coarse, "{faithful} vs {coarse}");
    // An explicit --kmax replaces the default: the adaptive minimum.
    assert_eq!(tris(&["--kmax", "1"]), coarse);
    assert!(tris(&["--kmax", "0.2"]) > coarse);
}

#[test]
fn vm_compile_emit_and_errors() {
    let f = temp_file("circle.vm", b"# a circle\nx var-x\ny var-y\nx2 square x\ny2 square y\nr add x2 y2\nc const 0.25\nout sub r c # f = r^2 - 1/4\n");
    let o = isoc(&["compile", f.to_str().unwrap(), "--emit", "ir"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let ir = stdout(&o);
    assert!(ir.contains("square") && ir.contains("const 0.25"), "{ir}");
    // The IR text round-trips.
    let back = isoc::ir::text::parse(&ir).unwrap();
    assert_eq!(back.to_string(), ir);
    let o = isoc(&["compile", f.to_str().unwrap(), "--emit", "ast"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).starts_with("(x var-x)\n(y var-y)\n"),
        "{}",
        stdout(&o)
    );
    let o = isoc(&["eval", f.to_str().unwrap(), "0.5", "0", "7", "--json"]);
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(j["value"].as_f64().unwrap(), 0.0);
    // --domain is honoured, --set has nothing to set.
    let o = isoc(&[
        "eval",
        f.to_str().unwrap(),
        "--box",
        "0,1,0,1,0,1",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = isoc(&["compile", f.to_str().unwrap(), "--set", "r=1"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).starts_with("error: --set r=…: `r` is not a param"),
        "{}",
        stderr(&o)
    );
    // A located error, exit status 1, no output file.
    let bad = temp_file("bad.vm", b"x var-x\ny rand x\n");
    let out = bad.with_extension("ply");
    let o = isoc(&["mesh", bad.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).starts_with(&format!("{}:2:3: error: `rand`", bad.display())),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}

#[test]
fn mesh_tolerance_reports_deviation() {
    let src = temp_file(
        "tol_sphere.iso",
        b"domain [-1.3, 1.3]^3;\nsurface x^2 + y^2 + z^2 - 1;\n",
    );
    let out = src.with_extension("ply");
    let o = isoc(&[
        "mesh",
        src.to_str().unwrap(),
        "--tolerance",
        "0.002",
        "--stats",
        "json",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(j["tolerance_met"], true);
    let d = j["max_deviation"].as_f64().unwrap();
    assert!(d > 0.0 && d <= 0.002, "{d}");
    let bad = isoc(&["mesh", src.to_str().unwrap(), "--tolerance", "0"]);
    assert_eq!(bad.status.code(), Some(1));
    assert!(stderr(&bad).contains("--tolerance"), "{}", stderr(&bad));
}

/// A Fidget model meshes the same with and without per-cell pruning
/// (`--no-prune`): the same octree counts and triangles, closed.
#[test]
fn mesh_vm_model_with_and_without_pruning() {
    let model = models_path("colonnade.vm");
    let run = |extra: Option<&str>, name: &str| {
        let out = temp_file(name, b"");
        let out = out.to_str().unwrap();
        let mut args = vec!["mesh", &model, "--level", "5", "--stats", "json", "-o", out];
        args.extend(extra);
        mesh_stats(&args)
    };
    let pruned = run(None, "col_pruned.ply");
    let full = run(Some("--no-prune"), "col_full.ply");
    for key in [
        "triangles",
        "vertices",
        "octree_nodes",
        "ambiguous_cells",
        "genus",
        "watertight",
    ] {
        assert_eq!(pruned[key], full[key], "{key}");
    }
    assert_eq!(pruned["watertight"], true);
}
