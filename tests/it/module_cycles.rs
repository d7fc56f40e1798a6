//! No module cycles inside any crate of the workspace (docs/ARCHITECTURE.md §2):
//! every `super::…`, `self::…` and `crate::…` path in the sources is resolved to the module it
//! names, each reference is lifted to the two sibling modules under the pair's lowest common
//! ancestor, and the graph of siblings must have no cycle. A parent using its child, or a child
//! using its parent (`use super::*`), is not a cycle between siblings and is not counted.
//!
//! Written by hand: the crates that draw module graphs (cargo-modules) are command-line tools
//! that build the whole workspace with rust-analyzer; this reads the sources in milliseconds.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// A module path inside one crate, e.g. `["model", "surface"]`.
type ModPath = Vec<String>;

/// One source file: its module path and its text with comments and literals blanked.
struct Source {
    module: ModPath,
    file: PathBuf,
    code: String,
}

/// Every `.rs` file under `src` with the module path it defines. Files named by `#[path]`
/// attributes are placed under the module whose file declares them.
fn sources(src: &Path) -> Vec<Source> {
    let mut out = Vec::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in fs::read_dir(&dir).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "rs") {
                let rel = p.strip_prefix(src).unwrap();
                let mut module: ModPath = rel
                    .parent()
                    .unwrap()
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                let stem = p.file_stem().unwrap().to_string_lossy().into_owned();
                if stem != "mod" && stem != "lib" && stem != "main" {
                    module.push(stem);
                }
                let code = blank_comments_and_literals(&fs::read_to_string(&p).unwrap());
                out.push(Source { module, file: p, code });
            }
        }
    }
    // `#[path = "x.rs"] mod y;` makes x.rs the child `y` of the declaring module.
    let renames: Vec<(PathBuf, ModPath)> = out
        .iter()
        .flat_map(|s| {
            let raw = fs::read_to_string(&s.file).unwrap();
            let mut found = Vec::new();
            let mut rest = raw.as_str();
            while let Some(i) = rest.find("#[path = \"") {
                rest = &rest[i + 10..];
                let end = rest.find('"').unwrap();
                let target = s.file.parent().unwrap().join(&rest[..end]);
                if let Some(m) = rest.find("mod ") {
                    let name: String =
                        rest[m + 4..].chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                    let mut module = s.module.clone();
                    module.push(name);
                    found.push((target, module));
                }
            }
            found
        })
        .collect();
    for (target, module) in renames {
        if let Some(s) = out.iter_mut().find(|s| s.file == target) {
            s.module = module;
        }
    }
    // Files of modules declared `#[cfg(test)] mod name;` are tests, which may use any sibling.
    let test_modules: Vec<ModPath> = out
        .iter()
        .flat_map(|s| {
            let chars: Vec<char> = s.code.chars().collect();
            let text = &s.code;
            let mut found = Vec::new();
            let mut from = 0;
            while let Some(k) = text[from..].find("mod ") {
                let at = from + k;
                from = at + 4;
                let name: String =
                    text[at + 4..].chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                let tail = text[at + 4 + name.len()..].trim_start();
                let char_at = text[..at].chars().count();
                if !name.is_empty() && tail.starts_with(';') && after_cfg_test(&chars, char_at) {
                    let mut m = s.module.clone();
                    m.push(name);
                    found.push(m);
                }
            }
            found
        })
        .collect();
    out.retain(|s| !test_modules.iter().any(|t| s.module.starts_with(t)));
    out
}

/// The text with `//` and `/* */` comments and string and char literals replaced by spaces,
/// so paths in docs and messages are not read as references.
fn blank_comments_and_literals(text: &str) -> String {
    let b: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        let next = b.get(i + 1).copied();
        if c == '/' && next == Some('/') {
            while i < b.len() && b[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            while i + 1 < b.len() && !(b[i] == '*' && b[i + 1] == '/') {
                i += 1;
            }
            i += 2;
        } else if c == 'r' && (next == Some('"') || next == Some('#')) && !prev_is_ident(&b, i) {
            // Raw string r"…" or r#"…"#.
            let mut j = i + 1;
            let mut hashes = 0;
            while j < b.len() && b[j] == '#' {
                hashes += 1;
                j += 1;
            }
            if b.get(j) == Some(&'"') {
                let close: String = std::iter::once('"').chain(std::iter::repeat_n('#', hashes)).collect();
                let rest: String = b[j + 1..].iter().collect();
                let end =
                    rest.find(&close).map_or(b.len(), |e| j + 1 + rest[..e].chars().count() + close.len());
                out.push(' ');
                i = end;
            } else {
                out.push(c);
                i += 1;
            }
        } else if c == '"' {
            i += 1;
            while i < b.len() && b[i] != '"' {
                i += if b[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
            out.push(' ');
        } else if c == '\'' && b.get(i + 2) == Some(&'\'') {
            i += 3;
            out.push(' ');
        } else if c == '\'' && next == Some('\\') {
            i += 2;
            while i < b.len() && b[i] != '\'' {
                i += 1;
            }
            i += 1;
            out.push(' ');
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

/// Whether the item starting at `i` carries `#[cfg(test)]` (among the attributes before it).
fn after_cfg_test(chars: &[char], i: usize) -> bool {
    let before: String = chars[i.saturating_sub(120)..i].iter().collect();
    let item_start = before.rfind([';', '}', '{']).map_or(0, |k| k + 1);
    before[item_start..].contains("#[cfg(test)]")
}

fn prev_is_ident(b: &[char], i: usize) -> bool {
    i > 0 && (b[i - 1].is_alphanumeric() || b[i - 1] == '_')
}

/// Every path that starts with `super::`, `self::` or `crate::` in `code`, expanded over
/// `{a, b::c}` groups, each as the module the path starts from plus its segments.
fn paths(code: &str, module: &ModPath) -> Vec<ModPath> {
    let chars: Vec<char> = code.chars().collect();
    let mut out = Vec::new();
    // Inline `mod name {` blocks shift what `super` and `self` mean.
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0usize;
    let mut i = 0;
    while i < chars.len() {
        match chars[i] {
            '{' => depth += 1,
            '}' => {
                depth = depth.saturating_sub(1);
                if inline.last().is_some_and(|(_, d)| *d == depth) {
                    inline.pop();
                }
            }
            _ => {}
        }
        if prev_is_ident(&chars, i) || !(chars[i].is_alphabetic() || chars[i] == '_') {
            i += 1;
            continue;
        }
        let word: String = chars[i..].iter().take_while(|c| c.is_alphanumeric() || **c == '_').collect();
        let after = i + word.chars().count();
        if word == "mod" {
            let rest: String = chars[after..].iter().take(200).collect();
            let name: String =
                rest.trim_start().chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            let tail = rest.trim_start()[name.len()..].trim_start();
            if tail.starts_with('{') {
                inline.push((name, depth));
                if after_cfg_test(&chars, i) {
                    // Skip the whole test module: tests may use any sibling.
                    let mut d = 0usize;
                    let mut j = after;
                    while j < chars.len() {
                        match chars[j] {
                            '{' => d += 1,
                            '}' => {
                                d -= 1;
                                if d == 0 {
                                    break;
                                }
                            }
                            _ => {}
                        }
                        j += 1;
                    }
                    inline.pop();
                    i = j + 1;
                    continue;
                }
            }
        }
        let here: ModPath = module.iter().cloned().chain(inline.iter().map(|(n, _)| n.clone())).collect();
        let starts_path = chars.get(after) == Some(&':') && chars.get(after + 1) == Some(&':');
        if starts_path && (word == "super" || word == "self" || word == "crate") {
            let (trees, end) = parse_tree(&chars, i);
            for segs in trees {
                let mut base: ModPath = if segs[0] == "crate" { Vec::new() } else { here.clone() };
                let mut k = 0;
                while k < segs.len() && (segs[k] == "super" || segs[k] == "self" || segs[k] == "crate") {
                    if segs[k] == "super" {
                        base.pop();
                    }
                    k += 1;
                }
                base.extend(segs[k..].iter().cloned());
                out.push(base);
            }
            i = end;
            continue;
        }
        i = after;
    }
    out
}

/// Parses `a::b::{c, d::e}` starting at `i`: the expanded segment lists and the end index.
fn parse_tree(chars: &[char], mut i: usize) -> (Vec<Vec<String>>, usize) {
    let mut prefix = Vec::new();
    loop {
        while chars.get(i).is_some_and(|c| c.is_whitespace()) {
            i += 1;
        }
        if chars.get(i) == Some(&'{') {
            let mut out = Vec::new();
            i += 1;
            loop {
                while chars.get(i).is_some_and(|c| c.is_whitespace() || *c == ',') {
                    i += 1;
                }
                if chars.get(i).is_none_or(|c| *c == '}') {
                    return (out, i + 1);
                }
                let (sub, end) = parse_tree(chars, i);
                for s in sub {
                    out.push(prefix.iter().cloned().chain(s).collect());
                }
                // Skip `as name` and anything else up to the next item.
                i = end;
                while chars.get(i).is_some_and(|c| *c != ',' && *c != '}') {
                    i += 1;
                }
            }
        }
        let word: String = chars[i..].iter().take_while(|c| c.is_alphanumeric() || **c == '_').collect();
        if word.is_empty() {
            return (vec![prefix], i);
        }
        i += word.chars().count();
        prefix.push(word);
        if chars.get(i) == Some(&':') && chars.get(i + 1) == Some(&':') {
            i += 2;
        } else {
            return (vec![prefix], i);
        }
    }
}

/// The cycles among sibling modules of one crate, each as a list of module paths.
fn cycles(src: &Path) -> Vec<Vec<String>> {
    let files = sources(src);
    let modules: BTreeSet<ModPath> =
        files.iter().flat_map(|s| (0..=s.module.len()).map(move |n| s.module[..n].to_vec())).collect();
    // Sibling edges keyed by their common parent.
    let mut edges: BTreeMap<ModPath, BTreeSet<(String, String)>> = BTreeMap::new();
    for s in &files {
        for p in paths(&s.code, &s.module) {
            // The deepest known module the path names or passes through.
            let target = (0..=p.len()).rev().map(|n| p[..n].to_vec()).find(|m| modules.contains(m)).unwrap();
            let common = s.module.iter().zip(&target).take_while(|(a, b)| a == b).count();
            if common == s.module.len() || common == target.len() {
                continue; // ancestor or descendant
            }
            edges
                .entry(s.module[..common].to_vec())
                .or_default()
                .insert((s.module[common].clone(), target[common].clone()));
        }
    }
    let mut found = Vec::new();
    for (parent, pairs) in edges {
        // Depth-first search for a back edge.
        let nodes: BTreeSet<&String> = pairs.iter().flat_map(|(a, b)| [a, b]).collect();
        let mut state: BTreeMap<&String, u8> = nodes.iter().map(|n| (*n, 0)).collect();
        fn visit<'a>(
            n: &'a String,
            pairs: &'a BTreeSet<(String, String)>,
            state: &mut BTreeMap<&'a String, u8>,
            path: &mut Vec<&'a String>,
            found: &mut Vec<Vec<String>>,
            parent: &ModPath,
        ) {
            state.insert(n, 1);
            path.push(n);
            for (_, to) in pairs.iter().filter(|(a, _)| a == n) {
                match state[to] {
                    1 => {
                        let start = path.iter().position(|p| *p == to).unwrap();
                        found.push(
                            path[start..]
                                .iter()
                                .chain(std::iter::once(&to))
                                .map(|m| {
                                    parent
                                        .iter()
                                        .chain(std::iter::once(*m))
                                        .cloned()
                                        .collect::<Vec<_>>()
                                        .join("::")
                                })
                                .collect(),
                        );
                    }
                    0 => visit(to, pairs, state, path, found, parent),
                    _ => {}
                }
            }
            path.pop();
            state.insert(n, 2);
        }
        for n in &nodes {
            if state[n] == 0 {
                visit(n, &pairs, &mut state, &mut Vec::new(), &mut found, &parent);
            }
        }
    }
    found
}

fn crate_sources() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut dirs = vec![root.join("src")];
    for entry in fs::read_dir(root.join("crates")).unwrap() {
        let src = entry.unwrap().path().join("src");
        if src.is_dir() {
            dirs.push(src);
        }
    }
    dirs.sort();
    dirs
}

#[test]
fn no_crate_has_a_module_cycle() {
    let mut report = Vec::new();
    for src in crate_sources() {
        for cycle in cycles(&src) {
            report.push(format!("{}: {}", src.display(), cycle.join(" -> ")));
        }
    }
    assert!(report.is_empty(), "module cycles:\n{}", report.join("\n"));
}

/// The checker finds a cycle when there is one (two sibling files that use each other through
/// `super::` and a grouped `crate::` path), and none in a parent/child pair.
#[test]
fn the_checker_sees_a_planted_cycle() {
    let dir = std::env::temp_dir().join(format!("volcano_cycles_{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(dir.join("model")).unwrap();
    fs::write(dir.join("lib.rs"), "pub mod model;\n// use crate::model::a; in a comment\n").unwrap();
    fs::write(dir.join("model/mod.rs"), "pub mod a;\npub mod b;\nuse a::A;\n").unwrap();
    fs::write(dir.join("model/a.rs"), "use super::*;\npub struct A(super::b::B);\n").unwrap();
    fs::write(
        dir.join("model/b.rs"),
        "pub struct B;\nconst S: &str = \"crate::model::a\";\n#[cfg(test)]\nmod tests {\n    use crate::model::a::A;\n}\n",
    )
    .unwrap();
    assert!(cycles(&dir).is_empty(), "{:?}", cycles(&dir));
    fs::write(dir.join("model/b.rs"), "pub struct B;\nuse crate::model::{a::A as Z, b};\n").unwrap();
    assert_eq!(cycles(&dir), vec![vec!["model::a", "model::b", "model::a"]]);
    let _ = fs::remove_dir_all(&dir);
}
