//! The house rule, checked: every module of the library imports only modules declared above it
//! in `src/lib.rs` (the stage order of the pipeline), so no import runs back up a stage and the
//! module graph has no circle. Unit tests at the bottom of a file (after `#[cfg(test)]`) and
//! comments are exempt: tests may build inputs with any stage, and a doc link is not an import.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// The `pub mod` declarations of `lib.rs`, in order.
fn stage_order() -> Vec<String> {
    let lib = std::fs::read_to_string(src().join("lib.rs")).expect("lib.rs is readable");
    lib.lines()
        .filter_map(|l| l.trim().strip_prefix("pub mod "))
        .map(|m| m.trim_end_matches(';').to_string())
        .collect()
}

/// The source files of module `name`: `name.rs`, or every file under `name/` except test files.
fn files_of(name: &str) -> Vec<PathBuf> {
    let single = src().join(format!("{name}.rs"));
    if single.exists() {
        return vec![single];
    }
    let mut out = Vec::new();
    let mut stack = vec![src().join(name)];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).expect("a module folder is readable") {
            let p = e.expect("a directory entry").path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs")
                && p.file_stem().is_some_and(|s| s != "tests")
            {
                out.push(p);
            }
        }
    }
    out
}

/// The crate modules a file's code (not its tests, not its comments) refers to.
fn references(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).expect("a source file is readable");
    let mut out = Vec::new();
    for line in text.lines() {
        let code = line.trim_start();
        if code.starts_with("#[cfg(test)]") {
            break;
        }
        if code.starts_with("//") {
            continue;
        }
        let code = code.split(" //").next().unwrap_or(code);
        let mut rest = code;
        while let Some(i) = rest.find("crate::") {
            rest = &rest[i + "crate::".len()..];
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() {
                out.push(name);
            }
        }
    }
    out
}

#[test]
fn no_module_imports_a_later_stage() {
    let order = stage_order();
    assert!(order.len() > 10, "lib.rs declares the stages: {order:?}");
    let rank: HashMap<&str, usize> = order
        .iter()
        .enumerate()
        .map(|(i, m)| (m.as_str(), i))
        .collect();
    let mut violations = Vec::new();
    for (i, module) in order.iter().enumerate() {
        let files = files_of(module);
        assert!(!files.is_empty(), "module {module} has no source file");
        for f in files {
            for r in references(&f) {
                if rank.get(r.as_str()).is_some_and(|&j| j > i) {
                    violations.push(format!("{} uses crate::{r}, a later stage", f.display()));
                }
            }
        }
    }
    assert!(violations.is_empty(), "{}", violations.join("\n"));
}

#[test]
fn the_checker_sees_a_reference_to_a_later_stage() {
    // The rule must be able to fail: a line as a back-import would be written is found.
    let dir = std::env::temp_dir().join(format!("liftwatch-layers-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir is writable");
    let f = dir.join("x.rs");
    std::fs::write(
        &f,
        "//! see crate::monitor\nuse crate::fit::FittedModel; // crate::file\n#[cfg(test)]\nuse crate::sim;\n",
    )
    .expect("temp file is writable");
    assert_eq!(references(&f), ["fit"]);
    let _ = std::fs::remove_dir_all(&dir);
}
