//! Issue 39: the engine's modules import one way. Reads the sources: which
//! top-level module each file names through `crate::` (directly, or an item
//! `lib.rs` re-exports), and checks that no circle of modules is longer than
//! two (`error` and `kernel` name each other).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Identifiers at the start of `text` (letters, digits, `_`).
fn ident(text: &str) -> &str {
    let end = text
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(text.len());
    &text[..end]
}

/// The code of a file: no comments, nothing from its test module on.
fn code(text: &str) -> String {
    let text = text.split("#[cfg(test)]\nmod tests").next().unwrap_or("");
    text.lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Every name a file reaches through `crate::`: `crate::x`, `crate::X` and
/// the names in `crate::{a, B, ...}`.
fn named(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for (i, _) in text.match_indices("crate::") {
        let rest = &text[i + 7..];
        if let Some(group) = rest.strip_prefix('{') {
            let inner = &group[..group.find('}').unwrap_or(group.len())];
            for part in inner.split(',') {
                let name = ident(part.trim());
                if !name.is_empty() {
                    out.push(name.to_owned());
                }
            }
        } else {
            out.push(ident(rest).to_owned());
        }
    }
    out
}

/// The modules of the crate, each with the modules it names.
fn graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let lib = std::fs::read_to_string(src.join("lib.rs")).expect("lib.rs");
    // Items `lib.rs` re-exports, by the module they come from.
    let mut home = BTreeMap::new();
    for stmt in code(&lib).split(';') {
        let Some(rest) = stmt.trim().strip_prefix("pub use ") else {
            continue;
        };
        let module = ident(rest).to_owned();
        let items = rest[module.len()..].trim_start_matches("::");
        for item in items.split([',', '{', '}', ' ', '\n']) {
            let item = ident(item.trim());
            if !item.is_empty() {
                home.insert(item.to_owned(), module.clone());
            }
        }
    }
    let mut files = Vec::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).expect("src").flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                files.push(p);
            }
        }
    }
    let top = |p: &Path| -> String {
        let rel = p.strip_prefix(src).expect("under src");
        let first = rel.components().next().expect("a file");
        first
            .as_os_str()
            .to_string_lossy()
            .trim_end_matches(".rs")
            .to_owned()
    };
    let skip = ["lib", "tests", "testing", "fuzz", "layering_tests"];
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for p in &files {
        let m = top(p);
        if skip.contains(&m.as_str()) || p.ends_with("tests.rs") {
            continue;
        }
        g.entry(m.clone()).or_default();
    }
    let modules: BTreeSet<String> = g.keys().cloned().collect();
    for p in &files {
        let m = top(p);
        if !modules.contains(&m) || p.ends_with("tests.rs") {
            continue;
        }
        let text = code(&std::fs::read_to_string(p).expect("source"));
        for name in named(&text) {
            let target = if modules.contains(&name) {
                Some(name)
            } else {
                home.get(&name).filter(|t| modules.contains(*t)).cloned()
            };
            if let Some(t) = target.filter(|t| *t != m) {
                g.get_mut(&m).expect("module").insert(t);
            }
        }
    }
    g
}

/// The strongly connected components of `g` with more than one module.
fn circles(g: &BTreeMap<String, BTreeSet<String>>) -> Vec<BTreeSet<String>> {
    // Reachability by repeated search: the engine has a few dozen modules.
    let reach = |from: &String| -> BTreeSet<String> {
        let mut seen = BTreeSet::new();
        let mut stack = vec![from.clone()];
        while let Some(m) = stack.pop() {
            for t in g.get(&m).into_iter().flatten() {
                if seen.insert(t.clone()) {
                    stack.push(t.clone());
                }
            }
        }
        seen
    };
    let all: BTreeMap<&String, BTreeSet<String>> = g.keys().map(|m| (m, reach(m))).collect();
    let mut out: Vec<BTreeSet<String>> = Vec::new();
    for (m, r) in &all {
        let comp: BTreeSet<String> = r
            .iter()
            .filter(|t| all.get(t).is_some_and(|back| back.contains(*m)))
            .cloned()
            .chain(std::iter::once((*m).clone()))
            .collect();
        if comp.len() > 1 && !out.contains(&comp) {
            out.push(comp);
        }
    }
    out
}

#[test]
fn no_circle_of_modules_is_longer_than_two() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let g = graph(&src);
    assert!(g.len() > 20, "{g:?}");
    // The reader sees the edges it should: the evaluation reads the data.
    assert!(g["displace"].contains("deformation"), "{:?}", g["displace"]);
    let long: Vec<_> = circles(&g).into_iter().filter(|c| c.len() > 2).collect();
    assert!(long.is_empty(), "import circles: {long:?}");
}

#[test]
fn the_reader_finds_a_circle_when_there_is_one() {
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (a, b) in [("a", "b"), ("b", "c"), ("c", "a"), ("c", "d")] {
        g.entry(a.into()).or_default().insert(b.into());
        g.entry(b.into()).or_default();
    }
    g.entry("d".into()).or_default();
    let c = circles(&g);
    assert_eq!(c.len(), 1);
    assert_eq!(c[0].len(), 3);
    assert_eq!(
        named("use crate::{a::B, C};\nlet x = crate::d::e(crate::F);"),
        ["a", "C", "d", "F"]
    );
}
