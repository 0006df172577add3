//! The layer check: no module of `src/` uses one on its own layer or above it. The order is
//! written once, in `docs/architecture.md` (the fenced block after `<!-- layers -->`, top layer
//! first); there is no exceptions list.
//!
//! A use is any `crate::NAME` path (with `crate::{A, B}` groups) in code compiled into the
//! library: comments, `#[cfg(test)]` modules and test-only files do not count (tests may build
//! their fixtures from any layer, as `cargo modules dependencies` leaves them out by default).
//!
//! The file check: no import circle of more than one file. Its graph has an edge `a → b` when `a`
//! names a path into `b` (`crate::…`, `super::…`, `self::…`, in the same library code) or
//! declares `b` as a child module; a strongly connected component of more than one file fails
//! the test, which names its files and the edges between them.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The layers from `docs/architecture.md`, top first: module → layer index (0 = top).
fn layers() -> BTreeMap<String, usize> {
    let text = std::fs::read_to_string(root().join("docs/architecture.md")).unwrap();
    let after = text
        .split("<!-- layers -->")
        .nth(1)
        .expect("docs/architecture.md has a `<!-- layers -->` marker");
    let block = after
        .split("```")
        .nth(1)
        .expect("a fenced block follows the marker");
    let mut map = BTreeMap::new();
    for (i, line) in block
        .lines()
        .skip(1) // the fence's info string
        .map(|l| l.split('#').next().unwrap().trim())
        .filter(|l| !l.is_empty())
        .enumerate()
    {
        for m in line.split_whitespace() {
            assert!(
                map.insert(m.to_string(), i).is_none(),
                "`{m}` is on two lines of the layer block"
            );
        }
    }
    map
}

/// The top-level modules `src/lib.rs` declares.
fn lib_modules() -> Vec<String> {
    std::fs::read_to_string(root().join("src/lib.rs"))
        .unwrap()
        .lines()
        .filter_map(|l| l.trim().strip_prefix("pub mod "))
        .map(|m| m.trim_end_matches(';').to_string())
        .collect()
}

fn rs_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rs_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// Files that are compiled only for tests: `#[cfg(test)] mod name;` in their parent.
fn test_only_files(files: &[PathBuf]) -> BTreeSet<PathBuf> {
    let mut set = BTreeSet::new();
    for f in files {
        let text = std::fs::read_to_string(f).unwrap();
        let lines: Vec<&str> = text.lines().map(str::trim).collect();
        let dir = match f.file_name().unwrap().to_str().unwrap() {
            "mod.rs" | "lib.rs" | "main.rs" => f.parent().unwrap().to_path_buf(),
            name => f.parent().unwrap().join(name.trim_end_matches(".rs")),
        };
        for w in lines.windows(2) {
            if w[0] == "#[cfg(test)]"
                && let Some(rest) = w[1]
                    .trim_start_matches("pub ")
                    .trim_start_matches("pub(crate) ")
                    .strip_prefix("mod ")
                && let Some(name) = rest.strip_suffix(';')
            {
                set.insert(dir.join(format!("{name}.rs")));
                set.insert(dir.join(name).join("mod.rs"));
            }
        }
    }
    set
}

/// The code of a file that is compiled into the library: without comments and without inline
/// `#[cfg(test)] mod … { … }` blocks.
fn library_code(text: &str) -> String {
    let mut out = String::new();
    let mut skip_depth: Option<i64> = None;
    let mut depth = 0i64;
    let mut pending_cfg_test = false;
    for line in text.lines() {
        let code = line.split("//").next().unwrap();
        let t = code.trim();
        if skip_depth.is_none() {
            if t == "#[cfg(test)]" {
                pending_cfg_test = true;
                continue;
            }
            // `mod tests {`, or with a visibility (`pub(super) mod tests {`, a fixture shared
            // with a sibling's tests)
            let is_mod = t.starts_with("mod ") || (t.starts_with("pub") && t.contains(" mod "));
            if pending_cfg_test && is_mod && t.ends_with('{') {
                skip_depth = Some(depth);
            }
            pending_cfg_test = false;
        }
        for c in code.chars() {
            match c {
                '{' => depth += 1,
                '}' => depth -= 1,
                _ => {}
            }
        }
        match skip_depth {
            Some(d) if depth <= d => skip_depth = None,
            Some(_) => {}
            None => {
                out.push_str(code);
                out.push('\n');
            }
        }
    }
    out
}

/// The top-level modules a piece of code names through `crate::`.
fn crate_uses(code: &str) -> BTreeSet<String> {
    let mut used = BTreeSet::new();
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect()
    };
    for (i, _) in code.match_indices("crate::") {
        let rest = &code[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            // the group runs to its matching brace (groups nest: `crate::{a::{B, C}, d}`)
            let mut open = 1;
            let end = group
                .char_indices()
                .find_map(|(i, c)| {
                    match c {
                        '{' => open += 1,
                        '}' => open -= 1,
                        _ => {}
                    }
                    (open == 0).then_some(i)
                })
                .unwrap_or(group.len());
            let inner = &group[..end];
            // top-level names of the group: those not inside a nested `{…}`
            let mut level = 0;
            let mut item = String::new();
            for c in inner.chars().chain(std::iter::once(',')) {
                match c {
                    '{' => level += 1,
                    '}' => level -= 1,
                    ',' if level == 0 => {
                        let name = ident(item.trim());
                        if !name.is_empty() {
                            used.insert(name);
                        }
                        item.clear();
                        continue;
                    }
                    _ => {}
                }
                if level == 0 {
                    item.push(c);
                }
            }
        } else {
            let name = ident(rest);
            if !name.is_empty() {
                used.insert(name);
            }
        }
    }
    used
}

/// The top-level module of a file under `src/`.
fn module_of(src: &Path, f: &Path) -> String {
    let rel = f.strip_prefix(src).unwrap();
    let first = rel
        .components()
        .next()
        .unwrap()
        .as_os_str()
        .to_string_lossy();
    first.trim_end_matches(".rs").to_string()
}

#[test]
fn no_module_uses_its_own_layer_or_one_above() {
    let layers = layers();
    let src = root().join("src");
    for m in lib_modules() {
        assert!(
            layers.contains_key(&m),
            "module `{m}` of src/lib.rs has no layer in docs/architecture.md: add it to the layer block"
        );
    }
    let mut files = Vec::new();
    rs_files(&src, &mut files);
    files.sort();
    let tests = test_only_files(&files);
    let mut violations = Vec::new();
    for f in &files {
        let name = f.file_name().unwrap();
        if f.parent() == Some(src.as_path()) && (name == "lib.rs" || name == "main.rs") {
            continue;
        }
        if tests.contains(f) {
            continue;
        }
        let me = module_of(&src, f);
        let mine = layers[&me];
        let code = library_code(&std::fs::read_to_string(f).unwrap());
        for used in crate_uses(&code) {
            if used == me {
                continue;
            }
            let Some(&theirs) = layers.get(&used) else {
                continue; // a crate-root item (a macro, a re-export), not a module
            };
            if theirs <= mine {
                violations.push(format!(
                    "{}: `{me}` uses `crate::{used}`, which is {}",
                    f.strip_prefix(root()).unwrap().display(),
                    if theirs == mine {
                        "on its own layer"
                    } else {
                        "on a layer above it"
                    }
                ));
            }
        }
    }
    assert!(
        violations.is_empty(),
        "imports against the layer order of docs/architecture.md:\n{}",
        violations.join("\n")
    );
}

#[test]
fn the_check_sees_uses_and_ignores_comments_and_tests() {
    let code = library_code(
        "use crate::{ltp::{A, B}, signal};\n// crate::jobs in a comment\nfn f() { crate::model::x(); }\n#[cfg(test)]\nmod tests {\n    use crate::jobs;\n}\nfn g() { crate::data::y(); }\n#[cfg(test)]\npub(super) mod tests2 {\n    use crate::experiment;\n}\n",
    );
    let used = crate_uses(&code);
    let want: BTreeSet<String> = ["ltp", "signal", "model", "data"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    assert_eq!(used, want);
}

#[test]
fn every_layer_module_exists() {
    let mods: BTreeSet<String> = lib_modules().into_iter().collect();
    for m in layers().keys() {
        assert!(
            mods.contains(m),
            "docs/architecture.md names `{m}`, which src/lib.rs does not declare"
        );
    }
}

/// The module path of a file under `src/` (`src/report/axis.rs` → `["report", "axis"]`,
/// `src/report/mod.rs` → `["report"]`, `src/lib.rs` → `[]`); `None` for the binary's `main.rs`.
fn module_path(src: &Path, f: &Path) -> Option<Vec<String>> {
    let rel = f.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if parts == ["main"] {
        return None;
    }
    if matches!(parts.last().map(String::as_str), Some("mod" | "lib")) {
        parts.pop();
    }
    Some(parts)
}

/// Every path a piece of code names from `crate::`, `super::` or `self::` (with `{…}` groups
/// expanded, nested ones too), as its segments: `use super::{a::B, c};` gives
/// `["super", "a", "B"]` and `["super", "c"]`. A keyword counts only as a whole word followed by
/// `::`, so `pub(super)` and `superscript` are not paths.
fn relative_paths(code: &str) -> Vec<Vec<String>> {
    let is_ident = |c: char| c.is_alphanumeric() || c == '_';
    let mut out = Vec::new();
    for kw in ["crate::", "super::", "self::"] {
        for (i, _) in code.match_indices(kw) {
            let before = code[..i].chars().next_back();
            if before.is_some_and(|c| is_ident(c) || c == ':') {
                continue; // part of a longer name or path (`super::super::`, `x::self::`)
            }
            let head = kw.trim_end_matches("::").to_string();
            expand_path(&code[i + kw.len()..], vec![head], &mut out);
        }
    }
    out
}

/// Reads the rest of a path after `prefix::` from `rest` and pushes its expansions.
fn expand_path(rest: &str, mut prefix: Vec<String>, out: &mut Vec<Vec<String>>) {
    let is_ident = |c: char| c.is_alphanumeric() || c == '_';
    let mut rest = rest.trim_start();
    loop {
        if let Some(group) = rest.strip_prefix('{') {
            // split the group at its top-level commas, up to its matching brace
            let mut level = 0;
            let mut item = String::new();
            for c in group.chars() {
                match c {
                    '{' => level += 1,
                    '}' if level == 0 => break,
                    '}' => level -= 1,
                    ',' if level == 0 => {
                        expand_path(&item, prefix.clone(), out);
                        item.clear();
                        continue;
                    }
                    _ => {}
                }
                item.push(c);
            }
            expand_path(&item, prefix, out);
            return;
        }
        let name: String = rest.chars().take_while(|&c| is_ident(c)).collect();
        if name.is_empty() || name == "self" {
            break; // `*`, the end of the path, or `a::{self, B}`
        }
        prefix.push(name.clone());
        match rest[name.len()..].trim_start().strip_prefix("::") {
            Some(next) => rest = next.trim_start(),
            None => break,
        }
    }
    if prefix.len() > 1 || prefix[0] != "self" {
        out.push(prefix);
    }
}

/// The child modules a file declares (`mod name;` / `pub mod name;`).
fn declared_children(code: &str) -> Vec<String> {
    code.lines()
        .filter_map(|l| {
            let t = l.trim();
            let t = match t.strip_prefix("pub") {
                Some(r) if r.starts_with('(') => r.split_once(')')?.1.trim_start(),
                Some(r) => r.trim_start(),
                None => t,
            };
            let name = t.strip_prefix("mod ")?.trim().strip_suffix(';')?.trim();
            Some(name.to_string())
        })
        .collect()
}

/// The file graph of the library: an edge `a → b` when `a` names a path into the file `b`
/// (through `crate::`, `super::` or `self::`, resolved to the deepest file the path reaches),
/// or `b` is a child module that `a` declares. Test-only files and `main.rs` are left out.
fn file_graph(src: &Path) -> BTreeMap<PathBuf, BTreeSet<PathBuf>> {
    let mut files = Vec::new();
    rs_files(src, &mut files);
    files.sort();
    let tests = test_only_files(&files);
    let by_module: BTreeMap<Vec<String>, PathBuf> = files
        .iter()
        .filter(|f| !tests.contains(*f))
        .filter_map(|f| Some((module_path(src, f)?, f.clone())))
        .collect();
    let resolve = |abs: &[String]| -> Option<&PathBuf> {
        (1..=abs.len()).rev().find_map(|k| by_module.get(&abs[..k]))
    };
    let mut graph = BTreeMap::new();
    for (me, f) in &by_module {
        let code = library_code(&std::fs::read_to_string(f).unwrap());
        let mut targets = BTreeSet::new();
        for path in relative_paths(&code) {
            let mut cur = me.clone();
            let mut segs = path.as_slice();
            if segs[0] == "crate" {
                cur.clear();
                segs = &segs[1..];
            } else {
                while let Some(s) = segs.first().filter(|s| *s == "super" || *s == "self") {
                    if s == "super" {
                        cur.pop();
                    }
                    segs = &segs[1..];
                }
            }
            cur.extend(segs.iter().cloned());
            if let Some(t) = resolve(&cur) {
                targets.insert(t.clone());
            }
        }
        for child in declared_children(&code) {
            let mut m = me.clone();
            m.push(child);
            if let Some(t) = by_module.get(&m) {
                targets.insert(t.clone());
            }
        }
        targets.remove(f);
        graph.insert(f.clone(), targets);
    }
    graph
}

/// The strongly connected components of more than one node, each sorted, in order.
fn circles(graph: &BTreeMap<PathBuf, BTreeSet<PathBuf>>) -> Vec<Vec<PathBuf>> {
    let reach = |from: &PathBuf| -> BTreeSet<PathBuf> {
        let mut seen = BTreeSet::new();
        let mut stack = vec![from.clone()];
        while let Some(v) = stack.pop() {
            for w in &graph[&v] {
                if seen.insert(w.clone()) {
                    stack.push(w.clone());
                }
            }
        }
        seen
    };
    let reaches: BTreeMap<&PathBuf, BTreeSet<PathBuf>> =
        graph.keys().map(|v| (v, reach(v))).collect();
    let mut done = BTreeSet::new();
    let mut out = Vec::new();
    for v in graph.keys() {
        if done.contains(v) || !reaches[v].contains(v) {
            continue;
        }
        let comp: Vec<PathBuf> = reaches[v]
            .iter()
            .filter(|w| reaches[*w].contains(v))
            .cloned()
            .collect();
        done.extend(comp.iter().cloned());
        if comp.len() > 1 {
            out.push(comp);
        }
    }
    out
}

#[test]
fn no_import_circle_between_files() {
    let src = root().join("src");
    let graph = file_graph(&src);
    let name = |f: &PathBuf| f.strip_prefix(&src).unwrap().display().to_string();
    let report: Vec<String> = circles(&graph)
        .iter()
        .map(|comp| {
            let set: BTreeSet<&PathBuf> = comp.iter().collect();
            let edges: Vec<String> = comp
                .iter()
                .flat_map(|a| {
                    graph[a]
                        .iter()
                        .filter(|b| set.contains(b))
                        .map(move |b| format!("    {} → {}", name(a), name(b)))
                })
                .collect();
            format!(
                "{} files: {}\n{}",
                comp.len(),
                comp.iter().map(name).collect::<Vec<_>>().join(", "),
                edges.join("\n")
            )
        })
        .collect();
    assert!(
        report.is_empty(),
        "files that import each other in a circle (a child names its mod.rs, or siblings name \
         each other; move what they share into a file of its own):\n{}",
        report.join("\n")
    );
}

#[test]
fn the_file_graph_reads_paths_and_groups() {
    let code = library_code(
        "use super::{a::B, c::{d, e::F}};\npub(super) fn f() { superscript(); crate::x::y(); }\nuse self::g::{self, H};\n// super::comment\nfn h() { super::super::k::L; }\n",
    );
    let got: BTreeSet<String> = relative_paths(&code).iter().map(|p| p.join("::")).collect();
    let want: BTreeSet<String> = [
        "super::a::B",
        "super::c::d",
        "super::c::e::F",
        "crate::x::y",
        "self::g",
        "self::g::H",
        "super::super::k::L",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    assert_eq!(got, want);
    assert_eq!(
        declared_children("pub mod a;\nmod b;\npub(crate) mod c;\nmod d {\n"),
        ["a", "b", "c"]
    );
}
