//! The crate's layout as a checked property: the library's modules form no
//! import cycle (file by file, and between the top-level modules of the
//! pipeline), and the library never touches what belongs to the binary.
//!
//! The import graph is read from the source: every `use` path and every
//! `crate::`/`super::` path in code (comments, strings and unit-test
//! modules stripped), resolved to the deepest module file it names. A
//! parent's `pub use` of its own descendants' items is a re-export, not an
//! import. Rust does not forbid cycles; this test does.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

type Module = Vec<String>;

/// Every `.rs` file under `dir`, recursively.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).expect("readable source dir") {
        let p = e.expect("dir entry").path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The module path of a library file (`src/jit/mod.rs` → `[jit]`), or
/// `None` for the binary's files.
fn module_of(src: &Path, file: &Path) -> Option<Module> {
    let rel = file.strip_prefix(src).ok()?;
    let mut parts: Vec<String> = rel
        .iter()
        .map(|s| s.to_string_lossy().into_owned())
        .collect();
    if parts.first().map(String::as_str) == Some("cli") || parts == ["main.rs"] {
        return None;
    }
    let last = parts.pop()?;
    let stem = last.trim_end_matches(".rs");
    if stem != "mod" && stem != "lib" {
        parts.push(stem.to_string());
    }
    Some(parts)
}

/// Source text without comments, string contents and the trailing
/// `#[cfg(test)] mod …` block.
fn code_only(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < b.len() {
        if b[i..].starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i..].starts_with(b"/*") {
            let end = text[i + 2..].find("*/").map_or(b.len(), |k| i + 2 + k + 2);
            i = end;
        } else if b[i] == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if b[i] == b'\'' && i + 2 < b.len() && (b[i + 2] == b'\'' || b[i + 1] == b'\\') {
            // A char literal such as '"' or '\n' (not a lifetime).
            let end = text[i + 1..].find('\'').map_or(b.len(), |k| i + 1 + k + 1);
            i = end.max(i + 3);
        } else {
            let ch = text[i..].chars().next().expect("in bounds");
            out.push(ch);
            i += ch.len_utf8();
        }
    }
    match out.find("#[cfg(test)]") {
        Some(k)
            if out[k..]
                .trim_start_matches("#[cfg(test)]")
                .trim_start()
                .starts_with("mod ") =>
        {
            out.truncate(k);
            out
        }
        _ => out,
    }
}

/// Expands a use tree (`a::{b, c::{d, e}}`) into its paths.
fn expand(tree: &str) -> Vec<String> {
    let tree: String = tree.chars().filter(|c| !c.is_whitespace()).collect();
    let Some(open) = tree.find('{') else {
        return vec![tree];
    };
    let (prefix, inner) = (&tree[..open], &tree[open + 1..tree.len() - 1]);
    let mut parts = Vec::new();
    let (mut depth, mut start) = (0, 0);
    for (k, c) in inner.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&inner[start..k]);
                start = k + 1;
            }
            _ => {}
        }
    }
    parts.push(&inner[start..]);
    parts
        .into_iter()
        .filter(|p| !p.is_empty())
        .flat_map(|p| expand(p).into_iter().map(|q| format!("{prefix}{q}")))
        .collect()
}

/// The deepest module file a path in `me` refers to.
fn resolve(me: &Module, path: &str, mods: &BTreeSet<Module>) -> Option<Module> {
    let path = path.split(" as ").next().unwrap_or(path);
    let segs: Vec<&str> = path.split("::").filter(|s| !s.is_empty()).collect();
    let (mut cur, rest): (Module, &[&str]) = match segs.first().copied() {
        Some("crate") => (vec![], &segs[1..]),
        Some("super") => {
            let mut base = me.clone();
            let ups = segs.iter().take_while(|s| **s == "super").count();
            base.truncate(base.len().saturating_sub(ups));
            (base, &segs[ups..])
        }
        Some("self") => (me.clone(), &segs[1..]),
        Some(first) => {
            let mut child = me.clone();
            child.push(first.to_string());
            if !mods.contains(&child) {
                return None;
            }
            (me.clone(), &segs[..])
        }
        None => return None,
    };
    for s in rest {
        cur.push(s.to_string());
        if !mods.contains(&cur) {
            cur.pop();
            break;
        }
    }
    Some(cur)
}

/// The library's import graph: module → modules it imports.
fn import_graph() -> BTreeMap<Module, BTreeSet<Module>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let lib: Vec<(Module, String)> = files
        .iter()
        .filter_map(|f| {
            Some((
                module_of(&src, f)?,
                code_only(&std::fs::read_to_string(f).ok()?),
            ))
        })
        .collect();
    let mods: BTreeSet<Module> = lib.iter().map(|(m, _)| m.clone()).collect();
    let mut graph: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
    for (me, code) in &lib {
        let edges = graph.entry(me.clone()).or_default();
        let mut rest = code.as_str();
        let mut body = String::new();
        // `use` declarations (a `pub use` of a descendant is a re-export).
        while let Some(k) = find_word(rest, "use") {
            body.push_str(&rest[..k]);
            let end = rest[k..].find(';').map_or(rest.len(), |e| k + e);
            let before = rest[..k].trim_end();
            let reexport = before.ends_with("pub") || before.ends_with(')');
            for p in expand(&rest[k + 3..end]) {
                if let Some(t) = resolve(me, &p, &mods)
                    && t != *me
                    && !(reexport && t.starts_with(me))
                {
                    edges.insert(t);
                }
            }
            rest = &rest[(end + 1).min(rest.len())..];
        }
        body.push_str(rest);
        // Paths in code: `crate::a::b`, `super::c`.
        for start in ["crate::", "super::"] {
            let mut at = 0;
            while let Some(k) = body[at..].find(start) {
                let k = at + k;
                let word_start = k == 0 || !is_ident(body.as_bytes()[k - 1]);
                let end = body[k..]
                    .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                    .map_or(body.len(), |e| k + e);
                if word_start
                    && let Some(t) = resolve(me, &body[k..end], &mods)
                    && t != *me
                {
                    edges.insert(t);
                }
                at = end.max(k + 1);
            }
        }
    }
    graph
}

fn is_ident(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

/// The next occurrence of `word` as a whole word followed by a space.
fn find_word(text: &str, word: &str) -> Option<usize> {
    let b = text.as_bytes();
    let mut at = 0;
    while let Some(k) = text[at..].find(word) {
        let k = at + k;
        let before_ok = k == 0 || !is_ident(b[k - 1]);
        let after_ok = b
            .get(k + word.len())
            .is_some_and(|c| c.is_ascii_whitespace());
        if before_ok && after_ok {
            return Some(k);
        }
        at = k + word.len();
    }
    None
}

/// The strongly connected components with more than one module (Tarjan,
/// iterative).
fn cycles(graph: &BTreeMap<Module, BTreeSet<Module>>) -> Vec<Vec<Module>> {
    let nodes: Vec<&Module> = graph.keys().collect();
    let index_of: BTreeMap<&Module, usize> =
        nodes.iter().enumerate().map(|(i, m)| (*m, i)).collect();
    let adj: Vec<Vec<usize>> = nodes
        .iter()
        .map(|m| {
            graph[*m]
                .iter()
                .filter_map(|t| index_of.get(t).copied())
                .collect()
        })
        .collect();
    let n = nodes.len();
    let (mut index, mut low, mut on) = (vec![usize::MAX; n], vec![0; n], vec![false; n]);
    let (mut stack, mut next, mut out) = (Vec::new(), 0, Vec::new());
    for root in 0..n {
        if index[root] != usize::MAX {
            continue;
        }
        let mut work = vec![(root, 0)];
        while let Some(&mut (v, ref mut k)) = work.last_mut() {
            if *k == 0 {
                index[v] = next;
                low[v] = next;
                next += 1;
                stack.push(v);
                on[v] = true;
            }
            if let Some(&w) = adj[v].get(*k) {
                *k += 1;
                if index[w] == usize::MAX {
                    work.push((w, 0));
                } else if on[w] {
                    low[v] = low[v].min(index[w]);
                }
                continue;
            }
            work.pop();
            if let Some(&(u, _)) = work.last() {
                low[u] = low[u].min(low[v]);
            }
            if low[v] == index[v] {
                let mut comp = Vec::new();
                while let Some(w) = stack.pop() {
                    on[w] = false;
                    comp.push(nodes[w].clone());
                    if w == v {
                        break;
                    }
                }
                if comp.len() > 1 {
                    out.push(comp);
                }
            }
        }
    }
    out
}

fn names(comp: &[Module]) -> String {
    let mut v: Vec<String> = comp.iter().map(|m| m.join("::")).collect();
    v.sort();
    v.join(", ")
}

#[test]
fn no_module_imports_one_that_imports_it_back() {
    let graph = import_graph();
    assert!(
        graph.len() > 40,
        "the source tree was not found: {} modules",
        graph.len()
    );
    // The reader sees real imports: a few that must be there.
    let has = |a: &str, b: &str| {
        let m = |s: &str| s.split("::").map(str::to_string).collect::<Module>();
        graph.get(&m(a)).is_some_and(|e| e.contains(&m(b)))
    };
    assert!(has("mesher", "polygonize::extract") && has("polygonize::extract", "mesh"));
    assert!(has("ir::fold", "ir::semantics") && has("syntax::lower", "syntax::names"));
    let files = cycles(&graph);
    assert!(
        files.is_empty(),
        "file-level import cycles: {:?}",
        files.iter().map(|c| names(c)).collect::<Vec<_>>()
    );
    // Between the pipeline's top-level modules.
    let mut top: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
    for (a, targets) in &graph {
        let ta: Module = a.iter().take(1).cloned().collect();
        let e = top.entry(ta.clone()).or_default();
        for b in targets {
            let tb: Module = b.iter().take(1).cloned().collect();
            if tb != ta && !tb.is_empty() {
                e.insert(tb);
            }
        }
    }
    let tops = cycles(&top);
    assert!(
        tops.is_empty(),
        "top-level import cycles: {:?}",
        tops.iter().map(|c| names(c)).collect::<Vec<_>>()
    );
}

#[test]
fn the_cycle_finder_finds_cycles() {
    let m = |s: &str| vec![s.to_string()];
    let mut g: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
    g.insert(m("a"), [m("b")].into());
    g.insert(m("b"), [m("c")].into());
    g.insert(m("c"), [m("a")].into());
    g.insert(m("d"), [m("a")].into());
    let c = cycles(&g);
    assert_eq!(c.len(), 1);
    assert_eq!(names(&c[0]), "a, b, c");
    assert_eq!(
        expand("crate::a::{b, c::{d, e}}"),
        ["crate::a::b", "crate::a::c::d", "crate::a::c::e"]
    );
}

#[test]
fn the_library_leaves_printing_exiting_and_flags_to_the_binary() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let forbidden = [
        "println!",
        "eprintln!",
        "print!",
        "eprint!",
        "dbg!",
        "std::process::exit",
        "std::env::",
        "clap::",
        "indicatif::",
    ];
    let mut bad = Vec::new();
    for f in files.iter().filter(|f| module_of(&src, f).is_some()) {
        let code = code_only(&std::fs::read_to_string(f).expect("readable"));
        for w in forbidden {
            if code.contains(w) {
                bad.push(format!("{}: {w}", f.display()));
            }
        }
    }
    assert!(bad.is_empty(), "{bad:#?}");
}
