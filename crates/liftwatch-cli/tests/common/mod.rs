//! What the CLI test binaries share: a scratch directory per case.

// Each test binary uses its own subset of these helpers.
#![allow(dead_code)]

pub mod serve;

use std::path::{Path, PathBuf};

/// A fresh directory for one case under the target's tmp dir, removed at the end.
pub struct Dir(pub PathBuf);

impl Dir {
    /// Creates `<target tmp>/<name>-<pid>`, empty.
    pub fn new(name: &str) -> Dir {
        let dir =
            Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("the target's tmp dir is writable");
        Dir(dir)
    }

    /// A path inside the directory.
    pub fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }

    /// Writes `bytes` to `name` inside the directory and returns its path.
    pub fn file(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let path = self.0.join(name);
        std::fs::write(&path, bytes).expect("case dir is writable");
        path
    }

    /// The names of the entries, sorted.
    pub fn names(&self) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(&self.0)
            .expect("dir exists")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
