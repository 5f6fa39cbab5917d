//! Replays what fuzzing kept for a target (`fuzz/corpus/<target>/`, `fuzz/crashes/<target>/`)
//! through the target's own check: the regression tests of the crates include this file.

use std::fs;
use std::panic::{self, AssertUnwindSafe};
use std::path::{Path, PathBuf};

/// Runs `check` on every file kept for `target` under `fuzz_dir`, and fails naming each file
/// that made it panic. The corpus must not be empty; a target may have no crashes.
pub fn replay(fuzz_dir: &Path, target: &str, check: impl Fn(&[u8])) {
    let corpus = files(&fuzz_dir.join("corpus").join(target));
    assert!(!corpus.is_empty(), "no corpus for the fuzz target {target} in {}", fuzz_dir.display());
    let crashes = files(&fuzz_dir.join("crashes").join(target));
    let failed: Vec<String> = corpus
        .iter()
        .chain(&crashes)
        .filter(|path| {
            let bytes = fs::read(path).expect("a kept fuzz input is readable");
            panic::catch_unwind(AssertUnwindSafe(|| check(&bytes))).is_err()
        })
        .map(|path| path.display().to_string())
        .collect();
    assert!(failed.is_empty(), "fuzz target {target} panics on:\n{}", failed.join("\n"));
}

/// The files in `dir`, sorted; none when it does not exist.
fn files(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut paths: Vec<PathBuf> =
        entries.map(|e| e.expect("a fuzz directory is listable").path()).filter(|p| p.is_file()).collect();
    paths.sort();
    paths
}
