//! Rules of the host code that a compiler does not check, held by reading the sources: every
//! output file goes through `dynotraj_formats::atomic` (written under a temporary name and
//! renamed when complete), never a bare `std::fs::write`.

use std::path::{Path, PathBuf};

use dynotraj_tests::manifest_dir;

/// The host crates that write files.
const HOST_CRATES: [&str; 9] = ["cli", "eval", "formats", "sources", "link", "train", "frontend", "bag", "sim"];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The file's code before its test module (tests write fixtures as they like): up to the
/// `#[cfg(test)]` of an inline `mod tests {`, not of a test-only item declared above it.
fn code_before_tests(text: &str) -> &str {
    let Some(module) = text.find("\nmod tests {") else { return text };
    text[..module].rfind("#[cfg(test)]").map_or(&text[..module], |at| &text[..at])
}

#[test]
fn output_files_are_written_whole_or_not_at_all() {
    let root = manifest_dir().join("..");
    let mut files = Vec::new();
    for krate in HOST_CRATES {
        rust_files(&root.join(krate).join("src"), &mut files);
    }
    assert!(files.len() > 100, "{} files read", files.len());
    let mut offenders = Vec::new();
    for file in &files {
        // A module's tests in a file of their own (`<module>/tests.rs`) write fixtures as
        // they like, as a test module does.
        if file.ends_with("formats/src/atomic.rs") || file.file_name().is_some_and(|n| n == "tests.rs") {
            continue;
        }
        let text = std::fs::read_to_string(file).unwrap();
        for (i, line) in code_before_tests(&text).lines().enumerate() {
            if line.contains("std::fs::write(") || line.contains("fs::write(&") {
                offenders.push(format!("{}:{}: {}", file.display(), i + 1, line.trim()));
            }
        }
    }
    assert!(
        offenders.is_empty(),
        "output written in place (use dynotraj_formats::atomic::write_file):\n{}",
        offenders.join("\n")
    );
}

/// With the integration tests gathered into one binary per crate (tests/tests/suite.rs, cli/tests/suite.rs) rather
/// than found by cargo, a test file that neither the suite nor the crate's manifest names would
/// never be built or run: every file must be named by one of them.
#[test]
fn every_integration_test_file_is_built() {
    let root = manifest_dir().join("..");
    let mut files = 0;
    let mut unnamed = Vec::new();
    for krate in ["tests", "cli"] {
        let dir = root.join(krate).join("tests");
        let suite = std::fs::read_to_string(dir.join("suite.rs")).unwrap();
        let manifest = std::fs::read_to_string(root.join(krate).join("Cargo.toml")).unwrap();
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let Some(stem) = path.file_stem().and_then(|s| s.to_str()) else { continue };
            if path.extension().is_none_or(|e| e != "rs") || stem == "suite" {
                continue;
            }
            files += 1;
            let in_suite = suite.lines().any(|l| l.trim() == format!("mod {stem};"));
            let own_target = manifest.contains(&format!("path = \"tests/{stem}.rs\""));
            if !in_suite && !own_target {
                unnamed.push(format!("{krate}/tests/{stem}.rs"));
            }
        }
    }
    assert!(files > 50, "{files} test files read");
    assert!(
        unnamed.is_empty(),
        "test files built by nothing (add `mod NAME;` to the crate's tests/suite.rs): {unnamed:?}"
    );
}
