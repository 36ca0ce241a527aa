//! `isoc mesh --bricks B [--brick I]` and `isoc merge` as a user runs them
//! (SPEC §2): the bricked file is the whole mesh, parts merged in any
//! order are the bricked file, and bad flags or parts are errors that
//! write nothing.

use std::path::{Path, PathBuf};

use super::cli::{isoc, stderr, stdout, temp_file};

/// A scratch directory of this test process.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("isoc-bricks-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    dir
}

fn s(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}

/// Runs `isoc` and returns its `--stats json` object; asserts success.
fn run(args: &[&str]) -> serde_json::Value {
    let o = isoc(args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    serde_json::from_str(&stdout(&o)).expect("one JSON object")
}

/// A binary PLY's triangles as their corners' bits, each rotated to start
/// at the least (orientation kept), sorted.
fn ply_triangles(bytes: &[u8]) -> Vec<[[u32; 3]; 3]> {
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .expect("a PLY header")
        + 11;
    let header = std::str::from_utf8(&bytes[..end]).expect("text");
    let count = |what: &str| -> usize {
        let line = header.lines().find(|l| l.starts_with(what)).expect(what);
        line[what.len()..].trim().parse().expect("a count")
    };
    let (nv, nf) = (count("element vertex "), count("element face "));
    let at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4"));
    let vertex = |i: usize| [0, 1, 2].map(|k| at(end + 27 * i + 4 * k));
    let faces = end + 27 * nv;
    let mut tris: Vec<[[u32; 3]; 3]> = (0..nf)
        .map(|f| {
            let p = [0, 1, 2].map(|k| vertex(at(faces + 13 * f + 1 + 4 * k) as usize));
            let r = (0..3).min_by_key(|&k| p[k]).unwrap_or(0);
            [p[r], p[(r + 1) % 3], p[(r + 2) % 3]]
        })
        .collect();
    tris.sort_unstable();
    tris
}

const FIGURES: [&str; 9] = [
    "triangles",
    "vertices",
    "components",
    "euler",
    "genus",
    "manifold",
    "watertight",
    "octree_nodes",
    "dual_cells",
];

#[test]
fn bricked_mesh_is_the_whole_mesh_and_merged_parts_are_the_bricked_file() {
    let dir = scratch("same");
    let file = "corpus/twotorus.iso";
    let flags = [
        "--level",
        "5",
        "--smooth",
        "0",
        "--no-creases",
        "--stats",
        "json",
    ];
    let whole = dir.join("whole.ply");
    let w = run(&[&["mesh", file, "-o", s(&whole)][..], &flags].concat());
    for b in ["1", "2"] {
        let bricked = dir.join(format!("bricked{b}.ply"));
        let j = run(&[
            &["mesh", file, "--bricks", b, "-o", s(&bricked)][..],
            &flags,
        ]
        .concat());
        for k in FIGURES {
            assert_eq!(j[k], w[k], "B = {b}: {k}");
        }
        let (a, c) = (
            std::fs::read(&whole).unwrap(),
            std::fs::read(&bricked).unwrap(),
        );
        assert!(ply_triangles(&a) == ply_triangles(&c), "B = {b}: triangles");
    }
    // Parts written in a shuffled order and given in another: the merge
    // is the bricked file, byte for byte, in two formats.
    let parts: Vec<PathBuf> = [5, 2, 7, 0, 3, 6, 1, 4]
        .iter()
        .map(|i| {
            let p = dir.join(format!("part{i}.ply"));
            let i = i.to_string();
            run(&[
                &["mesh", file, "--bricks", "1", "--brick", &i, "-o", s(&p)][..],
                &flags,
            ]
            .concat());
            p
        })
        .collect();
    for ext in ["ply", "obj"] {
        let (merged, bricked) = (
            dir.join(format!("merged.{ext}")),
            dir.join(format!("b.{ext}")),
        );
        let mut args = vec!["merge"];
        args.extend(parts.iter().rev().map(|p| s(p)));
        args.extend(["-o", s(&merged), "--stats", "json"]);
        let m = run(&args);
        for k in FIGURES {
            assert_eq!(m[k], w[k], "merge: {k}");
        }
        run(&[
            &["mesh", file, "--bricks", "1", "-o", s(&bricked)][..],
            &flags,
        ]
        .concat());
        assert!(
            std::fs::read(&merged).unwrap() == std::fs::read(&bricked).unwrap(),
            ".{ext}: the merge differs from the bricked file"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Asserts that `args` fail with exit status 1 (2 for a flag the parser
/// refuses), an `error:` naming `needle`, and no file at `out`.
fn refused(args: &[&str], needle: &str, out: &Path) {
    let o = isoc(args);
    let e = stderr(&o);
    assert!(matches!(o.status.code(), Some(1 | 2)), "{args:?}: {e}");
    assert!(e.contains("error:") && e.contains(needle), "{args:?}: {e}");
    assert!(!out.exists(), "{args:?} wrote {}", out.display());
}

#[test]
fn brick_flags_and_bad_parts_are_errors_that_write_nothing() {
    let dir = scratch("errors");
    let file = "corpus/torus.iso";
    let out = dir.join("out.ply");
    let o = s(&out);
    refused(
        &["mesh", file, "--bricks", "1", "--brick", "8", "-o", o],
        "--brick 8",
        &out,
    );
    refused(
        &[
            "mesh",
            file,
            "--bricks",
            "1",
            "--tolerance",
            "0.01",
            "-o",
            o,
        ],
        "--tolerance",
        &out,
    );
    let stl = dir.join("part.stl");
    refused(
        &["mesh", file, "--bricks", "1", "--brick", "0", "-o", s(&stl)],
        "part",
        &stl,
    );
    refused(&["mesh", file, "--brick", "0", "-o", o], "--bricks", &out);
    refused(&["mesh", file, "--bricks", "7", "-o", o], "7", &out);
    // Parts: of another run, twice the same, not a part, cut short.
    let part = |name: &str, src: &str, i: &str| {
        let p = dir.join(name);
        run(&[
            "mesh",
            src,
            "--level",
            "4",
            "--bricks",
            "1",
            "--brick",
            i,
            "-o",
            s(&p),
            "--stats",
            "json",
        ]);
        p
    };
    let (a, b) = (
        part("a.ply", file, "0"),
        part("b.ply", "corpus/sphere.iso", "1"),
    );
    refused(&["merge", s(&a), s(&b), "-o", o], "different runs", &out);
    refused(&["merge", s(&a), s(&a), "-o", o], "both are brick 0", &out);
    let plain = temp_file("plain.ply", b"ply\nformat ascii 1.0\nend_header\n");
    refused(
        &["merge", s(&plain), "-o", o],
        "not an isoc part file",
        &out,
    );
    let bytes = std::fs::read(&a).unwrap();
    let cut = dir.join("cut.ply");
    std::fs::write(&cut, &bytes[..bytes.len() - 7]).unwrap();
    refused(&["merge", s(&cut), "-o", o], "bytes", &out);
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .collect();
    assert_eq!(left.len(), 3, "no temporary file is left: {left:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn ctrl_c_stops_a_bricked_run_and_leaves_no_file() {
    let dir = scratch("interrupt");
    let src = temp_file(
        "gyroid.iso",
        b"domain [-31.4, 31.4]^3;\nsurface sin(x)*cos(y) + sin(y)*cos(z) + sin(z)*cos(x);\n",
    );
    let out = dir.join("g.ply");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_isoc"))
        .args([
            "mesh",
            s(&src),
            "--level",
            "9",
            "--bricks",
            "2",
            "-o",
            s(&out),
        ])
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("run isoc");
    // The streamed records' temporary files appear before the first brick.
    let started = std::time::Instant::now();
    while std::fs::read_dir(&dir).unwrap().count() == 0 {
        assert!(
            started.elapsed().as_secs() < 60,
            "no temporary file appeared"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let kill = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .expect("kill");
    assert!(kill.success());
    let waited = std::time::Instant::now();
    let status = loop {
        if let Some(st) = child.try_wait().expect("wait") {
            break st;
        }
        if waited.elapsed().as_secs() > 60 {
            let _ = child.kill();
            panic!("isoc did not stop within 60 s of Ctrl-C");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    assert_eq!(
        status.code(),
        Some(130),
        "the exit status of an interrupted run"
    );
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .collect();
    assert!(
        left.is_empty(),
        "an interrupted run leaves nothing: {left:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
