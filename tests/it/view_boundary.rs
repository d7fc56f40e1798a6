//! Renderers and panels read each domain through its view and public API, never through its
//! model or scenario internals (docs/ARCHITECTURE.md §2.3): no source file of
//! `volcano_render`, `volcano_egui` or the umbrella crate (`src/`) names a module `model` or
//! `scenario` in a path (`volcano_lava::model::thermal`, `volcano_atmosphere::{model::…}`,
//! `volcano::lava::scenario::…`, a `use …::model;` followed by `model::…`). None of those crates
//! has a module of that name of its own, so every such path is a domain crate's.
//!
//! Comments (doc comments included) and string literals are left out: a comment may point the
//! reader at the model law a view re-exports without depending on it. Integration tests
//! (`crates/*/tests`) are left out too: a test may look inside a model to check it.
//!
//! Reads the sources as text, like `tests/it/module_cycles.rs`; a planted file checks that it can
//! fail. (With renderers and panels reading the models directly instead of through the views,
//! it lists 20 such segments on 18 lines of 11 files.)

use std::fs;
use std::path::{Path, PathBuf};

/// The module names a consumer must not reach into.
const INTERNAL: [&str; 2] = ["model", "scenario"];

/// The directories whose sources are consumers.
fn consumer_dirs(root: &Path) -> Vec<PathBuf> {
    vec![root.join("crates/volcano_render/src"), root.join("crates/volcano_egui/src"), root.join("src")]
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in fs::read_dir(dir).unwrap() {
        let p = entry.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// `text` with comments and the contents of string and char literals replaced by spaces (line
/// breaks kept, so line numbers stay right).
fn code_only(text: &str) -> String {
    let b: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let blank = |c: char| if c == '\n' { '\n' } else { ' ' };
    let mut i = 0;
    while i < b.len() {
        let (c, next) = (b[i], b.get(i + 1).copied());
        let ident_before = i > 0 && (b[i - 1].is_alphanumeric() || b[i - 1] == '_');
        if c == '/' && next == Some('/') {
            while i < b.len() && b[i] != '\n' {
                out.push(' ');
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            let mut depth = 0;
            while i < b.len() {
                if b[i] == '/' && b.get(i + 1) == Some(&'*') {
                    depth += 1;
                    out.push_str("  ");
                    i += 2;
                } else if b[i] == '*' && b.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    out.push(blank(b[i]));
                    i += 1;
                }
            }
        } else if c == 'r' && matches!(next, Some('"') | Some('#')) && !ident_before {
            // Raw string r"…" or r#"…"#.
            let mut j = i + 1;
            let mut hashes = 0;
            while b.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if b.get(j) != Some(&'"') {
                out.push(c);
                i += 1;
                continue;
            }
            out.extend(std::iter::repeat_n(' ', j + 1 - i));
            i = j + 1;
            while i < b.len() {
                if b[i] == '"' && (1..=hashes).all(|h| b.get(i + h) == Some(&'#')) {
                    out.extend(std::iter::repeat_n(' ', 1 + hashes));
                    i += 1 + hashes;
                    break;
                }
                out.push(blank(b[i]));
                i += 1;
            }
        } else if c == '"' {
            out.push(' ');
            i += 1;
            while i < b.len() && b[i] != '"' {
                let step = if b[i] == '\\' { 2 } else { 1 };
                out.extend(b[i..(i + step).min(b.len())].iter().map(|&c| blank(c)));
                i += step;
            }
            out.push(' ');
            i += 1;
        } else if c == '\'' && b.get(i + 2) == Some(&'\'') {
            out.push_str("   ");
            i += 3;
        } else if c == '\'' && next == Some('\\') {
            // Escaped char literal: '\n', '\'', '\\', '\u{…}'.
            let mut j = (i + 3).min(b.len());
            while j < b.len() && b[j] != '\'' {
                j += 1;
            }
            let end = (j + 1).min(b.len());
            out.extend(std::iter::repeat_n(' ', end - i));
            i = end;
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

/// Every `model` or `scenario` path segment in `code`: the word, not part of a longer
/// identifier, with `::` right before or after it. Returns (line, the word).
fn internal_paths(code: &str) -> Vec<(usize, &'static str)> {
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    let mut found = Vec::new();
    for (n, line) in code.lines().enumerate() {
        for word in INTERNAL {
            for (at, _) in line.match_indices(word) {
                let before = &line[..at];
                let after = &line[at + word.len()..];
                if before.chars().next_back().is_some_and(ident) || after.chars().next().is_some_and(ident) {
                    continue;
                }
                if before.trim_end().ends_with("::") || after.trim_start().starts_with("::") {
                    found.push((n + 1, word));
                }
            }
        }
    }
    found
}

/// `file:line: word` for every internal path under `dirs`.
fn report(dirs: &[PathBuf]) -> Vec<String> {
    let mut files = Vec::new();
    for dir in dirs {
        rust_files(dir, &mut files);
    }
    files.sort();
    let mut out = Vec::new();
    for file in files {
        let code = code_only(&fs::read_to_string(&file).unwrap());
        for (line, word) in internal_paths(&code) {
            out.push(format!("{}:{line}: `{word}`", file.display()));
        }
    }
    out
}

#[test]
fn renderers_and_panels_use_no_model_or_scenario_internals() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let found = report(&consumer_dirs(root));
    assert!(
        found.is_empty(),
        "renderer, panel or umbrella sources reach into a domain's model or scenario modules \
         (use the domain's `view` module or its crate-root API):\n{}",
        found.join("\n")
    );
}

/// The checker finds planted paths (plain, grouped, a module imported then used) and ignores
/// comments, strings and longer identifiers.
#[test]
fn the_checker_sees_planted_internal_paths() {
    let dir = std::env::temp_dir().join(format!("volcano_view_boundary_{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(dir.join("sub")).unwrap();
    fs::write(
        dir.join("clean.rs"),
        "//! Reads `volcano_lava::model::thermal` through the view.\n\
         use volcano_lava::{scenario_terrain, view::surface_temperature};\n\
         /* volcano_atmosphere::model::volume */\n\
         const S: &str = \"volcano_lava::model::x\";\n\
         const R: &str = r#\"scenario::y\"#;\n\
         const Q: [char; 3] = ['\\'', '\\\\', '\"'];\n\
         fn f(model: u32, scenario: &WeatherScenario) -> u32 { WeatherScenario::builtin(); model }\n",
    )
    .unwrap();
    assert_eq!(report(std::slice::from_ref(&dir)), Vec::<String>::new());
    fs::write(
        dir.join("sub/dirty.rs"),
        "use volcano_lava::model::thermal::surface_temperature;\n\
         use volcano_atmosphere::{\n    view::GridSpec,\n    model::maps::MapField,\n};\n\
         use volcano::lava::scenario;\n\
         fn g() { let c = '\"'; scenario :: terrains::x(); }\n",
    )
    .unwrap();
    let found = report(std::slice::from_ref(&dir));
    let lines: Vec<&str> = found.iter().map(|l| l.rsplit_once("dirty.rs:").unwrap().1).collect();
    assert_eq!(lines, ["1: `model`", "4: `model`", "6: `scenario`", "7: `scenario`"], "{found:#?}");
    let _ = fs::remove_dir_all(&dir);
}
