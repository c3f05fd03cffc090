//! Every repository path the docs cite exists: README.md, docs/*.md and the comments of every
//! Rust source name files and folders of this tree, and a path that moved or went away is a
//! failure naming the file and line that cite it (CHANGELOG.md is history and is not read).
//!
//! A citation is a word that starts with a top-level folder of the repository and a `/`.
//! Templates are not citations: a path followed by `<`, `{`, `*` or `.{`, one with a placeholder
//! segment in capitals (`reports/NAME`), the folder a command writes (`--out`, `--record`), and
//! a path git ignores (the caches' folders, absent from a fresh clone).

use std::fs;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    dynotraj_tests::manifest_dir().join("..")
}

/// The top-level folders of the tree (not hidden, not build output).
fn top_folders(root: &Path) -> Vec<String> {
    let mut out: Vec<String> = fs::read_dir(root)
        .unwrap()
        .filter_map(Result::ok)
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.') && n != "target")
        .collect();
    out.sort();
    out
}

/// Every `.rs` file under `dir` (not hidden folders, not build output).
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in fs::read_dir(dir).unwrap().filter_map(Result::ok) {
        let (path, name) = (e.path(), e.file_name().to_string_lossy().into_owned());
        if path.is_dir() {
            if !name.starts_with('.') && name != "target" {
                rust_files(&path, out);
            }
        } else if name.ends_with(".rs") {
            out.push(path);
        }
    }
}

fn is_path_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || matches!(c, '_' | '.' | '/' | '-')
}

/// The repository paths `line` cites (see the module docs).
fn citations(line: &str, tops: &[String]) -> Vec<String> {
    let mut out = Vec::new();
    let chars: Vec<char> = line.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let starts = i == 0 || !is_path_char(chars[i - 1]);
        let rest: String = chars[i..].iter().collect();
        let top = tops.iter().find(|t| rest.starts_with(&format!("{t}/")));
        let (Some(_), true) = (top, starts) else {
            i += 1;
            continue;
        };
        let mut j = i;
        while j < chars.len() && is_path_char(chars[j]) {
            j += 1;
        }
        let mut word: String = chars[i..j].iter().collect();
        let next: String = chars[j..chars.len().min(j + 2)].iter().collect();
        while word.ends_with(['.', '-']) {
            word.pop();
        }
        let before: String = chars[..i].iter().collect();
        let template = next.starts_with(['<', '{', '*'])
            || next.starts_with(".{")
            || word.ends_with('/') && next.starts_with('<')
            || word.split(['/', '_', '.', '-']).any(|s| s.len() >= 2 && s.chars().all(|c| c.is_ascii_uppercase()))
            || before.trim_end().ends_with("--out")
            || before.trim_end().ends_with("--record");
        if !template {
            out.push(word);
        }
        i = j;
    }
    out
}

/// Whether git ignores `path` (a cache or output folder the commands write, such as
/// `reports/kitti/cache`: cited as where things go, absent from a fresh clone).
fn ignored(root: &Path, path: &str) -> bool {
    std::process::Command::new("git")
        .arg("-C")
        .arg(root)
        .args(["check-ignore", "-q", "--no-index", path])
        .status()
        .is_ok_and(|s| s.success())
}

#[test]
fn every_path_the_docs_cite_exists() {
    let root = root();
    let tops = top_folders(&root);
    let mut sources: Vec<PathBuf> = vec![root.join("README.md")];
    let mut docs: Vec<PathBuf> = fs::read_dir(root.join("docs"))
        .unwrap()
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    docs.sort();
    sources.extend(docs);
    let mut code = Vec::new();
    rust_files(&root, &mut code);
    code.sort();
    let (mut cited, mut missing) = (0, Vec::new());
    for file in sources.iter().map(|p| (p, false)).chain(code.iter().map(|p| (p, true))) {
        let (path, comments_only) = file;
        let text = fs::read_to_string(path).unwrap();
        for (n, line) in text.lines().enumerate() {
            if comments_only && !line.trim_start().starts_with("//") {
                continue;
            }
            for c in citations(line, &tops) {
                cited += 1;
                if !root.join(&c).exists() && !ignored(&root, &c) {
                    missing.push(format!("{}:{}: {c}", path.strip_prefix(&root).unwrap_or(path).display(), n + 1));
                }
            }
        }
    }
    println!("{cited} repository paths cited in README.md, docs/*.md and Rust comments");
    assert!(cited > 100, "the scan finds the docs' citations ({cited})");
    assert!(missing.is_empty(), "cited paths that do not exist:\n{}", missing.join("\n"));
}

#[test]
fn templates_and_outputs_are_not_citations() {
    let tops = vec!["docs".to_string(), "reports".to_string(), "fuzz".to_string(), "keys".to_string()];
    let found = |line: &str| citations(line, &tops);
    assert_eq!(found("see docs/decisions.md."), ["docs/decisions.md"]);
    assert_eq!(found("in `reports/kitti/cache` and mydocs/x"), ["reports/kitti/cache"]);
    assert!(found("--out reports/NAME").is_empty());
    assert!(found("--out reports/kitti-full").is_empty());
    assert!(found("`fuzz/corpus/<target>/`").is_empty());
    assert!(found("`keys/dev-model-signing.{key,pub}`").is_empty());
    assert!(found("reports/*/REPORT.md").is_empty());
}
