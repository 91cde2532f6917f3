//! The crate's structure as tests: every `crate::` path in `src/` against the layer table
//! (`shvis::LAYERS`: no import goes up a layer, none closes a cycle between top-level
//! modules), `unsafe` only where `shvis::UNSAFE_MODULES` allows it, and no wildcard arm in
//! a `match` over `Technique` or its families (a new family must be placed by every match,
//! never priced or bound by a default).
//!
//! The checks read the source text: a line's code up to its comment, string literals
//! skipped. Each failure names the file and line.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A `crate::` path's first segment, where it appears.
#[derive(Debug)]
struct Use {
    from: String,
    to: String,
    at: String,
}

/// Every `.rs` file under `dir`, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// The library's sources as (path relative to `src/`, text); the binary's (`main.rs`,
/// `cli`) stand above every layer and are left out.
fn library_sources() -> Vec<(String, String)> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    rust_files(&src)
        .into_iter()
        .map(|p| {
            let rel = p
                .strip_prefix(&src)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            (rel, std::fs::read_to_string(&p).unwrap())
        })
        .filter(|(rel, _)| !(rel == "main.rs" || rel == "cli.rs" || rel.starts_with("cli/")))
        .collect()
}

/// The top-level module a file under `src/` belongs to (`None` for `lib.rs`).
fn top_module(rel: &str) -> Option<String> {
    let first = rel.split('/').next()?;
    let name = first.strip_suffix(".rs").unwrap_or(first);
    (name != "lib").then(|| name.to_string())
}

/// A line's code: up to a `//` comment, with string and char literals blanked.
fn code_of(line: &str) -> String {
    let mut out = String::with_capacity(line.len());
    let mut chars = line.chars().peekable();
    let mut in_string = false;
    while let Some(c) = chars.next() {
        if in_string {
            match c {
                '\\' => {
                    chars.next();
                }
                '"' => {
                    in_string = false;
                    out.push('"');
                }
                _ => {}
            }
            continue;
        }
        match c {
            '"' => {
                in_string = true;
                out.push('"');
            }
            '/' if chars.peek() == Some(&'/') => break,
            _ => out.push(c),
        }
    }
    out
}

/// The top-level modules a line of code names through `crate::` (`crate::a::…` and
/// `crate::{a, b::c}`).
fn crate_paths(code: &str) -> Vec<String> {
    let mut found = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        let before = rest[..i].chars().last();
        rest = &rest[i + "crate::".len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue; // `$crate::`, `my_crate::`
        }
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            let mut depth = 0;
            let mut item = String::new();
            for c in group[..end].chars() {
                match c {
                    '{' => depth += 1,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        found.extend(first_segment(&item));
                        item.clear();
                    }
                    _ => item.push(c),
                }
            }
            found.extend(first_segment(&item));
        } else {
            found.extend(first_segment(rest));
        }
    }
    found
}

fn first_segment(path: &str) -> Option<String> {
    let name: String = path
        .trim_start()
        .chars()
        .take_while(|c| c.is_alphanumeric() || *c == '_')
        .collect();
    (!name.is_empty() && name != "self").then_some(name)
}

/// Every use of another top-level module in `sources`.
fn uses(sources: &[(String, String)]) -> Vec<Use> {
    let mut all = Vec::new();
    for (rel, text) in sources {
        let Some(from) = top_module(rel) else {
            continue;
        };
        for (i, line) in text.lines().enumerate() {
            for to in crate_paths(&code_of(line)) {
                if to != from {
                    all.push(Use {
                        from: from.clone(),
                        to,
                        at: format!("src/{rel}:{}", i + 1),
                    });
                }
            }
        }
    }
    all
}

/// What breaks the layering: modules in no layer, imports that go up a layer, cycles
/// between modules of one layer.
fn layering_violations(sources: &[(String, String)], layers: &[&[&str]]) -> Vec<String> {
    let layer_of: BTreeMap<&str, usize> = layers
        .iter()
        .enumerate()
        .flat_map(|(i, l)| l.iter().map(move |m| (*m, i)))
        .collect();
    let mut problems = Vec::new();
    let modules: BTreeSet<String> = sources.iter().filter_map(|(r, _)| top_module(r)).collect();
    for m in &modules {
        if !layer_of.contains_key(m.as_str()) {
            problems.push(format!(
                "module `{m}` is in no layer of shvis::LAYERS (src/lib.rs)"
            ));
        }
    }
    let mut same_layer: BTreeMap<(String, String), String> = BTreeMap::new();
    for u in uses(sources) {
        let (Some(&a), Some(&b)) = (layer_of.get(u.from.as_str()), layer_of.get(u.to.as_str()))
        else {
            continue;
        };
        if b > a {
            problems.push(format!(
                "{}: `{}` (layer {a}) uses `crate::{}` (layer {b}): an import up a layer",
                u.at, u.from, u.to
            ));
        } else if a == b {
            same_layer.entry((u.from, u.to)).or_insert(u.at);
        }
    }
    // A cycle within a layer: an edge a → b where b reaches a again.
    let reaches = |start: &str, goal: &str| {
        let mut seen = BTreeSet::new();
        let mut stack = vec![start.to_string()];
        while let Some(m) = stack.pop() {
            if m == goal {
                return true;
            }
            if seen.insert(m.clone()) {
                stack.extend(
                    same_layer
                        .keys()
                        .filter(|(f, _)| *f == m)
                        .map(|(_, t)| t.clone()),
                );
            }
        }
        false
    };
    for ((from, to), at) in &same_layer {
        if reaches(to, from) {
            problems.push(format!(
                "{at}: `{from}` uses `crate::{to}`, which uses `{from}` again: an import cycle"
            ));
        }
    }
    problems
}

#[test]
fn no_import_goes_up_a_layer_or_closes_a_cycle() {
    let problems = layering_violations(&library_sources(), shvis::LAYERS);
    assert!(problems.is_empty(), "\n{}", problems.join("\n"));
}

#[test]
fn the_check_catches_a_planted_upward_import_and_a_planted_cycle() {
    let layers: &[&[&str]] = &[&["low"], &["mid", "side"], &["high"]];
    let file = |rel: &str, text: &str| (rel.to_string(), text.to_string());
    let clean = vec![
        file("low.rs", "pub fn f() {}\n"),
        file(
            "mid/mod.rs",
            "use crate::low::f;\n// crate::high in a comment\n",
        ),
        file(
            "side.rs",
            "use crate::{low, mid::x};\nlet s = \"crate::high\";\n",
        ),
        file("high.rs", "use crate::{mid, side};\n"),
    ];
    assert_eq!(layering_violations(&clean, layers), Vec::<String>::new());

    let mut upward = clean.clone();
    upward[0].1 += "fn g() { crate::high::h() }\n";
    let problems = layering_violations(&upward, layers);
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(
        problems[0].starts_with("src/low.rs:2: `low` (layer 0) uses `crate::high`"),
        "{problems:?}"
    );

    let mut cycle = clean.clone();
    cycle[1].1 += "use crate::side::y;\n";
    let problems = layering_violations(&cycle, layers);
    assert_eq!(problems.len(), 2, "both edges of the cycle: {problems:?}");
    assert!(
        problems.iter().any(|p| p.starts_with("src/mid/mod.rs:3:")),
        "{problems:?}"
    );

    let mut unplaced = clean;
    unplaced.push(file("stray.rs", ""));
    assert_eq!(layering_violations(&unplaced, layers).len(), 1);
}

#[test]
fn every_layer_names_a_module_that_exists_once() {
    let modules: BTreeSet<String> = library_sources()
        .iter()
        .filter_map(|(r, _)| top_module(r))
        .collect();
    let mut named = BTreeSet::new();
    for m in shvis::LAYERS.iter().flat_map(|l| l.iter()) {
        assert!(named.insert(*m), "`{m}` is in two layers");
        assert!(
            modules.contains(*m),
            "layer entry `{m}` is no module of src/"
        );
    }
}

/// The module path (`bake::trace`) of a file under `src/`.
fn module_path(rel: &str) -> String {
    let trimmed = rel.strip_suffix(".rs").unwrap_or(rel);
    let trimmed = trimmed.strip_suffix("/mod").unwrap_or(trimmed);
    trimmed.replace('/', "::")
}

#[test]
fn unsafe_code_is_allowed_only_where_the_module_map_says() {
    let mut stray = Vec::new();
    for (rel, text) in library_sources() {
        let module = module_path(&rel);
        let allowed = shvis::UNSAFE_MODULES
            .iter()
            .any(|m| module == *m || module.starts_with(&format!("{m}::")));
        for (i, line) in text.lines().enumerate() {
            if code_of(line).contains("allow(unsafe_code)") && !allowed && rel != "lib.rs" {
                stray.push(format!("src/{rel}:{}: unsafe allowed in `{module}`", i + 1));
            }
        }
    }
    assert!(stray.is_empty(), "\n{}", stray.join("\n"));
    // Every module the map names uses it (the map says no more than is true).
    let sources = library_sources();
    for m in shvis::UNSAFE_MODULES {
        let uses_unsafe = sources.iter().any(|(rel, text)| {
            let module = module_path(rel);
            (module == *m || module.starts_with(&format!("{m}::")))
                && text.lines().any(|l| code_of(l).contains("unsafe {"))
        });
        assert!(
            uses_unsafe,
            "shvis::UNSAFE_MODULES names `{m}`, which has no unsafe block"
        );
    }
}

/// Patterns of `Technique` and its families.
const FAMILY_PATTERNS: &[&str] = &[
    "Technique::",
    "NdfBase::",
    "NmprtVariant::",
    "RnmVariant::",
    "SeamMode::",
];

/// `_ =>` arms of matches whose other arms match `Technique` or a family, as "file:line".
fn wildcard_arms_over_families(rel: &str, text: &str) -> Vec<String> {
    let lines: Vec<String> = text.lines().map(code_of).collect();
    let indent = |l: &str| l.len() - l.trim_start().len();
    let mut found = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        if !line.trim_start().starts_with("_ =>") {
            continue;
        }
        let arm_indent = indent(line);
        // The arms above it at its indentation, up to the `match` that opens them.
        let mut family = false;
        for above in lines[..i].iter().rev() {
            if above.trim().is_empty() {
                continue;
            }
            let n = indent(above);
            if n < arm_indent {
                if above.contains("match ") {
                    break;
                }
                continue;
            }
            if n == arm_indent {
                let pattern = above.split("=>").next().unwrap_or("");
                if FAMILY_PATTERNS.iter().any(|p| pattern.contains(p)) {
                    family = true;
                }
            }
        }
        if family {
            found.push(format!("src/{rel}:{}", i + 1));
        }
    }
    found
}

#[test]
fn no_wildcard_arm_over_technique_or_its_families() {
    let found: Vec<String> = library_sources()
        .iter()
        .flat_map(|(rel, text)| wildcard_arms_over_families(rel, text))
        .collect();
    assert!(
        found.is_empty(),
        "list every family in these matches instead of `_ =>`:\n{}",
        found.join("\n")
    );
    // The check itself: it finds a planted one and passes the exhaustive form.
    let planted =
        "match t {\n    Technique::Unc(shvis::technique::Unc { .. }) => 1,\n    _ => 0,\n}\n";
    assert_eq!(wildcard_arms_over_families("x.rs", planted), ["src/x.rs:3"]);
    let tuple = "match (kind, t) {\n    (Kind::A, Technique::Sh2(shvis::technique::Sh2)) => 1,\n    _ => 0,\n}\n";
    assert_eq!(wildcard_arms_over_families("x.rs", tuple).len(), 1);
    let other = "match kind {\n    Kind::A => Technique::Sh2(shvis::technique::Sh2),\n    _ => Technique::Shlmap(shvis::technique::Shlmap),\n}\n";
    assert!(wildcard_arms_over_families("x.rs", other).is_empty());
    let exhaustive = "match t {\n    Technique::Unc(shvis::technique::Unc { .. }) => 1,\n    Technique::Sh2(shvis::technique::Sh2) => 0,\n}\n";
    assert!(wildcard_arms_over_families("x.rs", exhaustive).is_empty());
}
