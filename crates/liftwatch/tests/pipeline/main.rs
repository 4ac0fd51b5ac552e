//! Integration tests of the pipeline, one module per stage.
mod align;
mod drive;
mod evaluate;
mod features;
mod forecast;
mod layers;
mod monitor;
mod operation;
mod paper;
mod sim;
mod tester;

use std::path::PathBuf;

/// A fresh directory for one test, removed at the end.
pub(crate) struct Dir(pub(crate) PathBuf);

impl Dir {
    pub(crate) fn new(name: &str) -> Dir {
        let dir =
            std::env::temp_dir().join(format!("liftwatch-pipeline-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp dir is writable");
        Dir(dir)
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
