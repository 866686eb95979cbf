//! The README and the guide (docs/): the README stays a front page, every
//! link resolves, and every command block marked to run runs (a renamed
//! flag breaks this test, not the user).

use std::path::{Path, PathBuf};

use crate::support::{TempDir, command, root};

/// The README's most lines.
const README_LINES: usize = 300;

/// The marker on the line before a code block that the tests run.
const RUN: &str = "<!-- run -->";

/// The Markdown files a reader follows links through.
fn pages() -> Vec<PathBuf> {
    let root = root();
    let mut pages = vec![
        root.join("README.md"),
        root.join("ARCHITECTURE.md"),
        root.join("CHANGELOG.md"),
    ];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .expect("docs/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    docs.sort();
    assert!(docs.len() >= 10, "the guide's pages: {docs:?}");
    pages.extend(docs);
    pages
}

/// GitHub's anchor of a heading: lower case, spaces to hyphens, other
/// punctuation dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of a page's headings (outside code blocks).
fn anchors(text: &str) -> Vec<String> {
    let mut fenced = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.starts_with("```") {
            fenced = !fenced;
        } else if !fenced && line.starts_with('#') {
            out.push(slug(line.trim_start_matches('#')));
        }
    }
    out
}

/// The targets of a page's inline links `[text](target)` outside code.
fn links(text: &str) -> Vec<String> {
    let mut fenced = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        let mut rest = line;
        while let Some(at) = rest.find("](") {
            let tail = &rest[at + 2..];
            let Some(end) = tail.find(')') else { break };
            out.push(tail[..end].to_owned());
            rest = &tail[end..];
        }
    }
    out
}

#[test]
fn the_readme_is_a_front_page_and_every_link_resolves() {
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README");
    let lines = readme.lines().count();
    assert!(
        lines <= README_LINES,
        "README.md has {lines} lines (at most {README_LINES})"
    );
    let (mut broken, mut checked) = (Vec::new(), 0);
    for page in pages() {
        let text = std::fs::read_to_string(&page).expect("page");
        for target in links(&text) {
            checked += 1;
            if target.starts_with("http://") || target.starts_with("https://") {
                continue;
            }
            let (file, anchor) = target.split_once('#').unwrap_or((&target, ""));
            let dir = page.parent().unwrap_or(Path::new("."));
            let file_path = if file.is_empty() {
                page.clone()
            } else {
                dir.join(file)
            };
            if !file_path.exists() {
                broken.push(format!("{}: {target} (no such file)", page.display()));
                continue;
            }
            if !anchor.is_empty() {
                let there = std::fs::read_to_string(&file_path).unwrap_or_default();
                if !anchors(&there).iter().any(|a| a == anchor) {
                    broken.push(format!("{}: {target} (no such heading)", page.display()));
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
    assert!(checked >= 20, "only {checked} links found");
}

/// Every `sh` block marked to run, line by line: each line a `csrbf`
/// command (comments dropped), run in a folder where the checkout's
/// `assets/` are and `out/` is made.
#[test]
fn the_command_blocks_marked_to_run_run() {
    let dir = TempDir::new("docs-blocks");
    let work = dir.path("");
    copy_dir(&root().join("assets"), &work.join("assets"));
    std::fs::create_dir_all(work.join("out")).expect("out/");
    let mut ran = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).expect("page");
        for block in marked_blocks(&text, "sh") {
            for line in block.lines() {
                let line = line.split(" #").next().unwrap_or("").trim();
                if line.is_empty() || line.starts_with('#') {
                    continue;
                }
                let words: Vec<&str> = line.split_whitespace().collect();
                assert_eq!(
                    words[0],
                    "csrbf",
                    "{}: a block marked to run holds csrbf commands only: {line}",
                    page.display()
                );
                let out = command()
                    .args(&words[1..])
                    .current_dir(&work)
                    .output()
                    .expect("run csrbf");
                assert!(
                    out.status.success(),
                    "{}: `{line}` failed: {}",
                    page.display(),
                    String::from_utf8_lossy(&out.stderr)
                );
                ran += 1;
            }
        }
    }
    assert!(ran >= 3, "only {ran} commands marked to run");
}

/// Every `json` block marked to run is read as what its page describes: a
/// control file (docs/control-files.md), a scene file (docs/scenes.md) or
/// a boundary-driven morph (docs/volume.md), with no warning (a misspelt
/// key would be one; a morph refuses it).
#[test]
fn the_json_blocks_marked_to_run_are_read_as_their_pages_say() {
    let mut read = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).expect("page");
        let name = page.file_name().and_then(|n| n.to_str()).unwrap_or("");
        for block in marked_blocks(&text, "json") {
            match name {
                "control-files.md" => {
                    let file = csrbf_edit::ControlFile::parse(&block)
                        .unwrap_or_else(|e| panic!("{name}: {e}\n{block}"));
                    assert!(file.warnings.is_empty(), "{name}: {:?}", file.warnings);
                }
                "scenes.md" => {
                    csrbf_anim::SceneFile::parse(&block)
                        .unwrap_or_else(|e| panic!("{name}: {e}\n{block}"));
                }
                "volume.md" => {
                    let v: serde_json::Value = serde_json::from_str(&block)
                        .unwrap_or_else(|e| panic!("{name}: {e}\n{block}"));
                    csrbf_edit::volume::BoundaryMorph::from_value(&v, "volume.md".as_ref())
                        .unwrap_or_else(|e| panic!("{name}: {e}\n{block}"));
                }
                other => panic!("{other}: a json block marked to run, but of what?"),
            }
            read += 1;
        }
    }
    assert!(read >= 2, "only {read} json blocks marked to run");
}

/// The bodies of the code blocks of `language` marked to run.
pub fn marked_blocks(text: &str, language: &str) -> Vec<String> {
    let mut out = Vec::new();
    let lines: Vec<&str> = text.lines().collect();
    let mut i = 0;
    while i < lines.len() {
        if lines[i].trim() == RUN
            && lines
                .get(i + 1)
                .is_some_and(|l| l.trim() == format!("```{language}"))
        {
            let body: Vec<&str> = lines[i + 2..]
                .iter()
                .take_while(|l| !l.starts_with("```"))
                .copied()
                .collect();
            i += 2 + body.len();
            out.push(body.join("\n"));
        }
        i += 1;
    }
    out
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("dir");
    for e in std::fs::read_dir(from).expect("read dir").flatten() {
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()));
        } else {
            std::fs::copy(&p, to.join(e.file_name())).expect("copy");
        }
    }
}
