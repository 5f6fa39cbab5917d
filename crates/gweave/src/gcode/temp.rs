//! Temporary files beside their destination, each registered while it lives so that a program
//! interrupted by a signal can remove them all ([`remove_all`]) before it exits.
//!
//! Every output is written to a hidden `.gweave-*.tmp` file in the destination's folder and
//! renamed into place at the end (see [`super::writer`]). Dropping a [`TempFile`] removes it; a
//! signal does not run destructors, hence the registry. The CLI's signal thread calls
//! [`remove_all`] and exits; the registry then stays closed, so a file being created at that
//! moment is refused rather than left behind.

use std::fs;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Paths of the live temporary files; `None` once [`remove_all`] has run (the process is
/// exiting).
static LIVE: Mutex<Option<Vec<PathBuf>>> = Mutex::new(Some(Vec::new()));

/// A temporary file beside a destination: removed when dropped unless persisted.
pub struct TempFile {
    file: Option<tempfile::NamedTempFile>,
    /// The creating thread's run, checked before every write: a stopped run writes no more
    /// and unwinds, dropping (removing) the file.
    stop: Option<crate::interrupt::Token>,
}

impl TempFile {
    /// Creates `.gweave-XXXXXX.tmp` in `dir`. Creation and registration happen under the
    /// registry's lock, so a signal's clean-up sees either no file or a registered one.
    pub fn new_in(dir: &Path) -> io::Result<TempFile> {
        let mut live = lock();
        let Some(paths) = live.as_mut() else {
            return Err(io::Error::new(io::ErrorKind::Interrupted, "interrupted"));
        };
        let file = tempfile::Builder::new()
            .prefix(".gweave-")
            .suffix(".tmp")
            .tempfile_in(dir)
            .map_err(without_temp_name)?;
        paths.push(file.path().to_path_buf());
        Ok(TempFile { file: Some(file), stop: crate::interrupt::Token::current() })
    }

    /// The open file.
    pub fn as_file(&self) -> &fs::File {
        self.inner().as_file()
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        self.inner().path()
    }

    /// Renames the file to `dest` (atomically, on the same file system) and forgets it.
    pub(crate) fn persist(mut self, dest: &Path) -> io::Result<()> {
        let file = self.file.take().expect("a live temporary file");
        let path = file.path().to_path_buf();
        match file.persist(dest) {
            Ok(_) => {
                forget(&path);
                Ok(())
            }
            Err(e) => {
                self.file = Some(e.file);
                Err(e.error)
            }
        }
    }

    fn inner(&self) -> &tempfile::NamedTempFile {
        self.file.as_ref().expect("a live temporary file")
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if let Some(file) = self.file.take() {
            let path = file.path().to_path_buf();
            drop(file);
            forget(&path);
        }
    }
}

impl Write for TempFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if let Some(stop) = &self.stop {
            stop.check()?;
        }
        self.file.as_mut().expect("a live temporary file").write(buf).map_err(without_temp_name)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.as_mut().expect("a live temporary file").flush().map_err(without_temp_name)
    }
}

/// Removes every live temporary file and closes the registry: later [`TempFile::new_in`] calls
/// fail. For a signal handler's thread just before the process exits; returns how many were
/// removed.
pub fn remove_all() -> usize {
    let mut live = lock();
    let paths = live.take().unwrap_or_default();
    paths.iter().filter(|p| fs::remove_file(p).is_ok()).count()
}

/// tempfile's error names the temporary file ("No such file or directory (os error 2) at path
/// \".gweave-XXXX.tmp\""), which means nothing to the user, and hides the system's error
/// inside a private type: keep the message before the path; the caller names the destination.
fn without_temp_name(e: io::Error) -> io::Error {
    let text = e.to_string();
    match text.rfind(" at path ") {
        Some(end) => io::Error::new(e.kind(), text[..end].to_owned()),
        None => e,
    }
}

fn forget(path: &Path) {
    if let Some(paths) = lock().as_mut() {
        paths.retain(|p| p != path);
    }
}

/// The registry, even if a thread panicked while holding it (a list of paths stays valid).
fn lock() -> std::sync::MutexGuard<'static, Option<Vec<PathBuf>>> {
    LIVE.lock().unwrap_or_else(|e| e.into_inner())
}

#[cfg(test)]
pub(crate) fn live_count() -> usize {
    lock().as_ref().map_or(0, Vec::len)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file is registered while it lives and forgotten when dropped or persisted. (The
    /// registry is global; only this test counts it, and other tests' files come and go, so
    /// it checks the presence of its own paths.)
    #[test]
    fn live_files_are_registered_until_dropped_or_persisted() {
        let dir = tempfile::tempdir().unwrap();
        let registered = |p: &Path| lock().as_ref().unwrap().iter().any(|q| q == p);
        let a = TempFile::new_in(dir.path()).unwrap();
        let a_path = a.path().to_path_buf();
        assert!(registered(&a_path) && live_count() >= 1);
        drop(a);
        assert!(!registered(&a_path) && !a_path.exists());
        let b = TempFile::new_in(dir.path()).unwrap();
        let b_path = b.path().to_path_buf();
        b.persist(&dir.path().join("kept")).unwrap();
        assert!(!registered(&b_path));
        assert!(dir.path().join("kept").exists());
    }
}
