//! Safe output: every command writes to a temporary file beside the target and renames it into
//! place only when all went well, so a failure never leaves partial output and the input is only
//! replaced when the user asks (`--in-place`, keeping a `.bak` unless told not to).

use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// Where a command's output goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target {
    /// A new file (replaced atomically if it exists). Refuses to be the input itself.
    File(PathBuf),
    /// Replace the input, optionally keeping `<input>.bak`.
    InPlace { keep_backup: bool },
    /// Standard output (`-o -`).
    Stdout,
}

/// An output being written. Call [`Output::commit`] at the end; dropping it without committing
/// deletes the temporary file.
pub struct Output {
    sink: Sink,
}

enum Sink {
    File {
        file: BufWriter<tempfile::NamedTempFile>,
        dest: PathBuf,
        backup: Option<PathBuf>,
    },
    /// A device or pipe (`/dev/null`, a FIFO): written directly, since renaming a file over it
    /// would replace the device itself.
    Special {
        file: BufWriter<fs::File>,
        dest: PathBuf,
    },
    Stdout(BufWriter<io::Stdout>),
}

const BUFFER: usize = 1 << 20;

impl Output {
    /// Opens the output for `target`, given the `input` the command reads (for in-place and for
    /// refusing to overwrite the input by accident).
    pub fn create(target: &Target, input: Option<&Path>) -> Result<Output> {
        let (dest, backup) = match target {
            Target::Stdout => {
                return Ok(Output { sink: Sink::Stdout(BufWriter::with_capacity(BUFFER, io::stdout())) })
            }
            Target::File(path) => {
                if let Some(input) = input {
                    if same_file(input, path) {
                        return Err(Error::WouldOverwriteInput { path: path.clone() });
                    }
                }
                if fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
                    let file =
                        fs::OpenOptions::new().write(true).open(path).map_err(|e| Error::io(path, e))?;
                    let file = BufWriter::with_capacity(BUFFER, file);
                    return Ok(Output { sink: Sink::Special { file, dest: path.clone() } });
                }
                (path.clone(), None)
            }
            Target::InPlace { keep_backup } => {
                let input = input.ok_or(Error::InPlaceWithoutInput)?;
                let backup = keep_backup.then(|| backup_path(input));
                (input.to_path_buf(), backup)
            }
        };
        let dir = match dest.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let tmp = tempfile::Builder::new()
            .prefix(".gweave-")
            .suffix(".tmp")
            .tempfile_in(&dir)
            .map_err(|e| Error::io(&dir, e))?;
        Ok(Output { sink: Sink::File { file: BufWriter::with_capacity(BUFFER, tmp), dest, backup } })
    }

    /// Flushes, keeps the backup if asked, and renames the temporary file into place.
    pub fn commit(self) -> Result<()> {
        match self.sink {
            Sink::Special { mut file, dest } => file.flush().map_err(|e| Error::io(&dest, e)),
            Sink::Stdout(mut w) => match w.flush() {
                Err(e) if e.kind() != io::ErrorKind::BrokenPipe => Err(Error::io("<stdout>", e)),
                _ => Ok(()),
            },
            Sink::File { file, dest, backup } => {
                let tmp = file.into_inner().map_err(|e| Error::io(&dest, e.into_error()))?;
                tmp.as_file().sync_all().map_err(|e| Error::io(&dest, e))?;
                // Keep the permissions of the file being replaced (an executable script stays
                // one); a new file gets the usual rw-r--r-- instead of the temporary file's 0600.
                match fs::metadata(&dest) {
                    Ok(meta) => fs::set_permissions(tmp.path(), meta.permissions()),
                    Err(_) => set_new_file_mode(tmp.path()),
                }
                .map_err(|e| Error::io(&dest, e))?;
                if let Some(backup) = backup {
                    fs::copy(&dest, &backup).map_err(|e| Error::io(&backup, e))?;
                }
                tmp.persist(&dest).map_err(|e| Error::io(&dest, e.error))?;
                Ok(())
            }
        }
    }
}

/// Writes a whole side file (a JSON report, an image, a profile) the way every output is
/// written: into a temporary file beside `path`, renamed into place only once `write` has
/// succeeded, so a failure leaves the old file (or none) rather than part of a new one.
pub fn write_file<E: From<Error>>(
    path: &Path,
    write: impl FnOnce(&mut Output) -> Result<(), E>,
) -> Result<(), E> {
    let mut out = Output::create(&Target::File(path.to_path_buf()), None)?;
    write(&mut out)?;
    Ok(out.commit()?)
}

impl Write for Output {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match &mut self.sink {
            Sink::File { file, .. } => file.write(buf),
            Sink::Special { file, .. } => file.write(buf),
            Sink::Stdout(w) => w.write(buf),
        }
    }

    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        match &mut self.sink {
            Sink::File { file, .. } => file.write_all(buf),
            Sink::Special { file, .. } => file.write_all(buf),
            Sink::Stdout(w) => w.write_all(buf),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        match &mut self.sink {
            Sink::File { file, .. } => file.flush(),
            Sink::Special { file, .. } => file.flush(),
            Sink::Stdout(w) => w.flush(),
        }
    }
}

#[cfg(unix)]
fn set_new_file_mode(path: &Path) -> io::Result<()> {
    use std::os::unix::fs::PermissionsExt;
    fs::set_permissions(path, fs::Permissions::from_mode(0o644))
}

#[cfg(not(unix))]
fn set_new_file_mode(_path: &Path) -> io::Result<()> {
    Ok(())
}

fn backup_path(input: &Path) -> PathBuf {
    let mut name = input.as_os_str().to_owned();
    name.push(".bak");
    PathBuf::from(name)
}

/// Whether two paths name the same existing file.
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (fs::canonicalize(a), fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nothing_is_left_behind_without_commit() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("out.gcode");
        {
            let mut out = Output::create(&Target::File(dest.clone()), None).unwrap();
            out.write_all(b"G1 X1\n").unwrap();
        }
        assert!(!dest.exists());
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    /// A report or image whose writing fails half-way leaves the previous file whole.
    #[test]
    fn a_side_file_is_replaced_only_when_written_whole() {
        let dir = tempfile::tempdir().unwrap();
        let report = dir.path().join("r.json");
        fs::write(&report, b"{\"old\": 1}\n").unwrap();
        let failed: Result<(), Error> = write_file(&report, |out| {
            out.write_all(b"{\"new\":").map_err(|e| Error::io("r.json", e))?;
            Err(Error::io("r.json", io::Error::other("encoder failed")))
        });
        assert!(failed.is_err());
        assert_eq!(fs::read(&report).unwrap(), b"{\"old\": 1}\n");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
        write_file(&report, |out| out.write_all(b"{}\n").map_err(|e| Error::io("r.json", e))).unwrap();
        assert_eq!(fs::read(&report).unwrap(), b"{}\n");
    }

    #[test]
    fn in_place_keeps_a_backup() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.gcode");
        fs::write(&input, b"old\n").unwrap();
        let mut out = Output::create(&Target::InPlace { keep_backup: true }, Some(&input)).unwrap();
        out.write_all(b"new\n").unwrap();
        out.commit().unwrap();
        assert_eq!(fs::read(&input).unwrap(), b"new\n");
        assert_eq!(fs::read(dir.path().join("in.gcode.bak")).unwrap(), b"old\n");
    }

    /// Regression: `-o /dev/null` once renamed a regular file over the device.
    #[cfg(unix)]
    #[test]
    fn devices_are_written_not_replaced() {
        use std::os::unix::fs::FileTypeExt;
        let mut out = Output::create(&Target::File(PathBuf::from("/dev/null")), None).unwrap();
        out.write_all(b"G1 X1\n").unwrap();
        out.commit().unwrap();
        assert!(fs::metadata("/dev/null").unwrap().file_type().is_char_device());
    }

    #[cfg(unix)]
    #[test]
    fn new_files_are_readable_by_others() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("new.gcode");
        let mut out = Output::create(&Target::File(dest.clone()), None).unwrap();
        out.write_all(b"G1\n").unwrap();
        out.commit().unwrap();
        assert_eq!(fs::metadata(&dest).unwrap().permissions().mode() & 0o777, 0o644);
    }

    #[test]
    fn refuses_to_overwrite_the_input() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.gcode");
        fs::write(&input, b"old\n").unwrap();
        let err = Output::create(&Target::File(input.clone()), Some(&input)).err().unwrap();
        assert!(matches!(err, Error::WouldOverwriteInput { .. }));
    }
}
