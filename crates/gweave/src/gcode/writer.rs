//! Safe output: every command writes to a temporary file beside the target and renames it into
//! place only when all went well, so a failure never leaves partial output and the input is only
//! replaced when the user asks (`--in-place`, keeping a `.bak` unless told not to).
//!
//! Replacing a file keeps what the user had: its mode, its owner (when running as root, the
//! only user who can give a file away), and the previous backup. `--in-place` refuses a
//! read-only file unless forced. The backup is itself written to a temporary file, synced and
//! renamed, so `<input>.bak` is either absent or whole; an existing `.bak` that is not a byte
//! copy of the input is renamed to the first free `.bak.1` .. `.bak.9`, never replaced.

use std::fs;
use std::io::{self, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use super::container::{self, Container, Encoder};
use super::scratch::Scratch;
use super::temp::TempFile;
use crate::error::{Error, Result};

/// Where a command's output goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target {
    /// A new file (replaced atomically if it exists). Refuses to be the input itself.
    File(PathBuf),
    /// Replace the input, optionally keeping `<input>.bak`. A read-only input is refused unless
    /// `force`.
    InPlace {
        /// Keep the original as `<input>.bak`.
        keep_backup: bool,
        /// Replace a read-only input.
        force: bool,
    },
    /// Standard output (`-o -`), stored in this container (the CLI's `--format`): a pipe has no
    /// name to say how its G-code is stored, so the target says it.
    Stdout(Container),
    /// A transform's scratch file, which the finishing step reads as it grows and then copies
    /// to the real target: written in place, as text, each write waking its reader.
    Scratch(Scratch),
}

impl Target {
    /// Whether the output goes to standard output, whatever its container.
    pub fn is_stdout(&self) -> bool {
        matches!(self, Target::Stdout(_))
    }
}

/// Older backups kept beside `<input>.bak`: `.bak.1` .. `.bak.9`.
pub const BACKUP_SLOTS: u32 = 9;

/// An output being written. Call [`Output::commit`] at the end; dropping it without committing
/// deletes the temporary file. A file named `*.gz` or `*.bgcode` is written compressed or as
/// binary G-code ([`Container::of_output`]); standard output as its [`Target::Stdout`] says.
pub struct Output {
    /// The one buffer between a pass and the system: a pass writes each line in two or three
    /// small writes, which cost an inlined copy each here rather than a call through the
    /// container and the sink (about 50 instructions a write, a tenth of a transform's work
    /// per line on top of its pass); the container and the sink behind it are unbuffered and
    /// take a [`BUFFER`] at a time (a compressing container writes its own blocks: gzip's
    /// 32 KiB, binary G-code's spool copied in 8 KiB pieces: 2 403 and 14 355 writes for the
    /// 224 MB bench file, whose system time is no more than the text copy's 1 MiB writes',
    /// against 16.6 s and 4.3 s of compressing it; docs/performance.md).
    sink: BufWriter<Encoder<Sink>>,
}

/// What [`Output`] gathers before a write reaches the container: 1 MiB, a few hundred
/// microseconds of a transform's output, so a write costs one system call per 1 MiB.
const BUFFER: usize = 1 << 20;

enum Sink {
    File {
        file: TempFile,
        /// The file replaced in the end, the name errors show (not the temporary file's).
        dest: PathBuf,
        backup: Option<PathBuf>,
    },
    /// A device or pipe (`/dev/null`, a FIFO): written directly, since renaming a file over it
    /// would replace the device itself.
    Special {
        file: fs::File,
        dest: PathBuf,
    },
    /// A scratch file ([`Target::Scratch`]): already removed by its owner and on a signal, so a
    /// second temporary file and a rename would add nothing but hide the bytes from the reader
    /// following it as it grows.
    Scratch(Scratch),
    Stdout(io::Stdout),
}

impl Output {
    /// Opens the output for `target`, given the `input` the command reads (for in-place and for
    /// refusing to overwrite the input by accident).
    pub fn create(target: &Target, input: Option<&Path>) -> Result<Output> {
        let sink = Self::sink(target, input)?;
        let shown = sink.name();
        // The container follows the file really written (not the name errors show): a scratch
        // file that stands for a `.gz` output is written as text, the finishing copy compresses.
        let container = match (&sink, target) {
            (Sink::File { dest, .. } | Sink::Special { dest, .. }, _) => Container::of_output(dest),
            (Sink::Stdout(_), Target::Stdout(container)) => *container,
            (Sink::Stdout(_) | Sink::Scratch(_), _) => Container::Text,
        };
        // A binary input's metadata and thumbnails go into a binary output.
        let carried = match (container, input) {
            (Container::Bgcode, Some(input)) => {
                container::preamble(input).map_err(|e| Error::io(input, e))?
            }
            _ => None,
        };
        let sink = Encoder::new(container, sink, carried).map_err(|e| Error::io(shown, e))?;
        Ok(Output { sink: BufWriter::with_capacity(BUFFER, sink) })
    }

    /// An output written as it is, whatever its name (side files: reports, images).
    fn plain(target: &Target) -> Result<Output> {
        Ok(Output { sink: BufWriter::with_capacity(BUFFER, Encoder::Text(Self::sink(target, None)?)) })
    }

    fn sink(target: &Target, input: Option<&Path>) -> Result<Sink> {
        let (dest, backup) = match target {
            Target::Stdout(_) => return Ok(Sink::Stdout(io::stdout())),
            Target::Scratch(scratch) => return Ok(Sink::Scratch(scratch.clone())),
            Target::File(path) => {
                if let Some(input) = input {
                    if same_file(input, path) {
                        return Err(Error::WouldOverwriteInput { path: path.clone() });
                    }
                }
                if fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
                    let file =
                        fs::OpenOptions::new().write(true).open(path).map_err(|e| Error::io(path, e))?;
                    return Ok(Sink::Special { file, dest: path.clone() });
                }
                (through_link(path)?, None)
            }
            Target::InPlace { keep_backup, force } => {
                let input = input.ok_or(Error::InPlaceWithoutInput)?;
                let meta = fs::metadata(input).map_err(|e| Error::io(input, e))?;
                // A pipe or a device cannot be replaced (a FIFO read to its end and opened again
                // waited for a writer forever), and a name under /dev or /proc (`/dev/stdin`)
                // is the system's alias of an open file, where the backup has no place.
                let alias =
                    std::path::absolute(input).is_ok_and(|p| p.starts_with("/dev") || p.starts_with("/proc"));
                if !meta.is_file() || alias {
                    return Err(Error::NotAFileToReplace { path: input.to_path_buf() });
                }
                if !force && is_read_only(input, &meta) {
                    return Err(Error::ReadOnly { path: input.to_path_buf() });
                }
                let backup = keep_backup.then(|| backup_path(input));
                if let Some(backup) = &backup {
                    // Fail before the work, not after it, when no slot is free for the old one.
                    if backup.symlink_metadata().is_ok() && free_slot(backup).is_none() {
                        return Err(Error::BackupSlotsFull { path: backup.clone(), slots: BACKUP_SLOTS });
                    }
                }
                (through_link(input)?, backup)
            }
        };
        let file = TempFile::new_in(&parent_dir(&dest)).map_err(|e| Error::io(&dest, e))?;
        Ok(Sink::File { file, dest, backup })
    }

    /// The file being written (`None` for standard output): the name write errors should show.
    pub fn dest(&self) -> Option<&Path> {
        match self.inner_sink() {
            Sink::File { dest, .. } | Sink::Special { dest, .. } => Some(dest),
            Sink::Scratch(scratch) => Some(scratch.shown()),
            Sink::Stdout(_) => None,
        }
    }

    /// The name write errors show: the file the user named (not its temporary file), or
    /// `<stdout>`.
    pub fn shown(&self) -> PathBuf {
        self.inner_sink().name()
    }

    fn inner_sink(&self) -> &Sink {
        match self.sink.get_ref() {
            Encoder::Text(s) => s,
            Encoder::Gzip(z) => z.get_ref(),
            Encoder::Bgcode(b) => b.get_ref(),
        }
    }

    /// Ends the container, flushes, keeps the backup if asked, and renames the temporary file
    /// into place.
    pub fn commit(self) -> Result<()> {
        let name = self.dest().map_or_else(|| PathBuf::from("<stdout>"), Path::to_path_buf);
        let encoder = match self.sink.into_inner() {
            Ok(encoder) => encoder,
            Err(e) if e.error().kind() == io::ErrorKind::BrokenPipe => return Ok(()),
            Err(e) => return Err(Error::io(name, e.into_error())),
        };
        let sink = match encoder.finish() {
            Ok(sink) => sink,
            Err(e) if e.kind() == io::ErrorKind::BrokenPipe => return Ok(()),
            Err(e) => return Err(Error::io(name, e)),
        };
        match sink {
            // Unbuffered: every byte has reached the file.
            Sink::Special { .. } | Sink::Scratch(_) => Ok(()),
            Sink::Stdout(mut w) => match w.flush() {
                Err(e) if e.kind() != io::ErrorKind::BrokenPipe => Err(Error::io("<stdout>", e)),
                _ => Ok(()),
            },
            Sink::File { file: tmp, dest, backup } => {
                tmp.as_file().sync_all().map_err(|e| Error::io(&dest, e))?;
                let replaced = fs::metadata(&dest).ok();
                keep_metadata(&tmp, replaced.as_ref()).map_err(|e| Error::io(&dest, e))?;
                if let Some(backup) = backup {
                    write_backup(&dest, &backup, replaced.as_ref())?;
                }
                tmp.persist(&dest).map_err(|e| Error::io(&dest, e))
            }
        }
    }
}

/// Where a file named `path` is written: the file a link names, so that the link is kept and
/// its target replaced, as an editor saving through the link does and `cp` writes through it
/// (renaming the new file onto the link's own name replaced the link by a file and left the
/// target as it was: `sed -i` without `--follow-symlinks` does that). A link to nothing is an
/// error naming the link, as `cp` refuses to write through a dangling link.
fn through_link(path: &Path) -> Result<PathBuf> {
    match path.symlink_metadata() {
        Ok(meta) if meta.file_type().is_symlink() => fs::canonicalize(path).map_err(|e| {
            // "No such file or directory" of a name `ls` shows would puzzle: say it is a link.
            let to = fs::read_link(path).map_or_else(|_| "?".into(), |t| t.display().to_string());
            Error::io(
                path,
                io::Error::new(e.kind(), format!("a link to {to}, which cannot be written through: {e}")),
            )
        }),
        _ => Ok(path.to_path_buf()),
    }
}

/// Writes a whole side file (a JSON report, an image, a profile) the way every output is
/// written: into a temporary file beside `path`, renamed into place only once `write` has
/// succeeded, so a failure leaves the old file (or none) rather than part of a new one.
pub fn write_file<E: From<Error>>(
    path: &Path,
    write: impl FnOnce(&mut Output) -> Result<(), E>,
) -> Result<(), E> {
    let mut out = Output::plain(&Target::File(path.to_path_buf()))?;
    write(&mut out)?;
    Ok(out.commit()?)
}

impl Write for Output {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.sink.write(buf)
    }

    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.sink.write_all(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.sink.flush()
    }
}

impl Sink {
    /// The name errors show.
    fn name(&self) -> PathBuf {
        match self {
            Sink::File { dest, .. } | Sink::Special { dest, .. } => dest.clone(),
            Sink::Scratch(scratch) => scratch.shown().to_path_buf(),
            Sink::Stdout(_) => PathBuf::from("<stdout>"),
        }
    }
}

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self {
            Sink::File { file, .. } => file.write(buf),
            Sink::Special { file, .. } => file.write(buf),
            Sink::Scratch(scratch) => scratch.write(buf),
            Sink::Stdout(w) => w.write(buf),
        }
    }

    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        match self {
            Sink::File { file, .. } => file.write_all(buf),
            Sink::Special { file, .. } => file.write_all(buf),
            Sink::Scratch(scratch) => scratch.write_all(buf),
            Sink::Stdout(w) => w.write_all(buf),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        match self {
            Sink::File { file, .. } => file.flush(),
            Sink::Special { file, .. } => file.flush(),
            Sink::Scratch(scratch) => scratch.flush(),
            Sink::Stdout(w) => w.flush(),
        }
    }
}

/// The folder a temporary file for `dest` goes in (renames only work within one file system).
fn parent_dir(dest: &Path) -> PathBuf {
    match dest.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Copies `input` to `backup` through a synced temporary file, so the `.bak` is whole or
/// absent. An existing backup with the input's bytes is kept as it is; any other is moved to
/// the first free `.bak.N`.
fn write_backup(input: &Path, backup: &Path, meta: Option<&fs::Metadata>) -> Result<()> {
    if backup.symlink_metadata().is_ok() {
        if same_bytes(input, backup).map_err(|e| Error::io(backup, e))? {
            return Ok(());
        }
        let slot = free_slot(backup)
            .ok_or_else(|| Error::BackupSlotsFull { path: backup.to_path_buf(), slots: BACKUP_SLOTS })?;
        fs::rename(backup, &slot).map_err(|e| Error::io(backup, e))?;
    }
    let mut tmp = TempFile::new_in(&parent_dir(backup)).map_err(|e| Error::io(backup, e))?;
    let mut from = fs::File::open(input).map_err(|e| Error::io(input, e))?;
    io::copy(&mut from, &mut tmp).map_err(|e| Error::io(backup, e))?;
    tmp.as_file().sync_all().map_err(|e| Error::io(backup, e))?;
    keep_metadata(&tmp, meta).map_err(|e| Error::io(backup, e))?;
    tmp.persist(backup).map_err(|e| Error::io(backup, e))
}

/// The first of `<backup>.1` .. `<backup>.9` that does not exist.
fn free_slot(backup: &Path) -> Option<PathBuf> {
    (1..=BACKUP_SLOTS).map(|n| numbered(backup, n)).find(|p| p.symlink_metadata().is_err())
}

fn numbered(path: &Path, n: u32) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(format!(".{n}"));
    PathBuf::from(name)
}

/// Whether two files hold the same bytes (read in step, stopping at the first difference).
fn same_bytes(a: &Path, b: &Path) -> io::Result<bool> {
    let (mut fa, mut fb) = (fs::File::open(a)?, fs::File::open(b)?);
    if fa.metadata()?.len() != fb.metadata()?.len() {
        return Ok(false);
    }
    let (mut ba, mut bb) = (vec![0u8; 1 << 16], vec![0u8; 1 << 16]);
    loop {
        let n = fa.read(&mut ba)?;
        if n == 0 {
            return Ok(true);
        }
        fb.read_exact(&mut bb[..n])?;
        if ba[..n] != bb[..n] {
            return Ok(false);
        }
    }
}

/// Gives the temporary file the mode (and, as root, the owner) of the file it replaces; a new
/// file gets the usual rw-r--r-- instead of the temporary file's 0600.
#[cfg(unix)]
fn keep_metadata(tmp: &TempFile, replaced: Option<&fs::Metadata>) -> io::Result<()> {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let Some(meta) = replaced else {
        return fs::set_permissions(tmp.path(), fs::Permissions::from_mode(0o644));
    };
    // SAFETY: geteuid has no preconditions and cannot fail.
    if unsafe { libc::geteuid() } == 0 {
        std::os::unix::fs::fchown(tmp.as_file(), Some(meta.uid()), Some(meta.gid()))?;
    }
    // After the chown, which clears set-id bits.
    fs::set_permissions(tmp.path(), meta.permissions())
}

#[cfg(not(unix))]
fn keep_metadata(tmp: &TempFile, replaced: Option<&fs::Metadata>) -> io::Result<()> {
    match replaced {
        Some(meta) => fs::set_permissions(tmp.path(), meta.permissions()),
        None => Ok(()),
    }
}

/// A file the user cannot write, or whose mode has no write bit at all (root can write any
/// file, but a file made read-only says "do not change me").
#[cfg(unix)]
fn is_read_only(path: &Path, meta: &fs::Metadata) -> bool {
    use std::ffi::CString;
    use std::os::unix::ffi::OsStrExt;
    if meta.permissions().readonly() {
        return true;
    }
    let Ok(c_path) = CString::new(path.as_os_str().as_bytes()) else {
        return false;
    };
    // SAFETY: access(2) reads a valid NUL-terminated path and touches no other memory.
    unsafe { libc::access(c_path.as_ptr(), libc::W_OK) != 0 }
}

#[cfg(not(unix))]
fn is_read_only(_path: &Path, meta: &fs::Metadata) -> bool {
    meta.permissions().readonly()
}

fn backup_path(input: &Path) -> PathBuf {
    let mut name = input.as_os_str().to_owned();
    name.push(".bak");
    PathBuf::from(name)
}

/// Whether two paths name the same existing file (through links, hard links included).
#[cfg(unix)]
pub(crate) fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (fs::metadata(a), fs::metadata(b)) {
        (Ok(a), Ok(b)) => (a.dev(), a.ino()) == (b.dev(), b.ino()),
        _ => false,
    }
}

/// Whether two paths name the same existing file.
#[cfg(not(unix))]
pub(crate) fn same_file(a: &Path, b: &Path) -> bool {
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
        let mut out =
            Output::create(&Target::InPlace { keep_backup: true, force: false }, Some(&input)).unwrap();
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

    /// Regression (a breaking session): `-o link.gcode` renamed the new file onto the link,
    /// replacing the link by a file and leaving its target as it was. The target is written
    /// and the link kept, as `cp` does; a link to nothing is refused, nothing created.
    #[cfg(unix)]
    #[test]
    fn an_output_through_a_link_writes_its_target() {
        let dir = tempfile::tempdir().unwrap();
        let (target, link) = (dir.path().join("target.gcode"), dir.path().join("link.gcode"));
        fs::write(&target, b"old\n").unwrap();
        std::os::unix::fs::symlink(&target, &link).unwrap();
        let mut out = Output::create(&Target::File(link.clone()), None).unwrap();
        out.write_all(b"new\n").unwrap();
        out.commit().unwrap();
        assert!(link.symlink_metadata().unwrap().file_type().is_symlink());
        assert_eq!(fs::read(&target).unwrap(), b"new\n");
        let dangling = dir.path().join("dangling.gcode");
        std::os::unix::fs::symlink(dir.path().join("nowhere.gcode"), &dangling).unwrap();
        let err = Output::create(&Target::File(dangling.clone()), None).err().unwrap();
        let to = dir.path().join("nowhere.gcode");
        assert!(
            err.to_string().starts_with(&format!(
                "{}: a link to {}, which cannot be written through: No such file or directory",
                dangling.display(),
                to.display()
            )),
            "{err}"
        );
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 3);
    }

    fn in_place(input: &Path, bytes: &[u8], force: bool) -> Result<()> {
        let mut out = Output::create(&Target::InPlace { keep_backup: true, force }, Some(input))?;
        out.write_all(bytes).unwrap();
        out.commit()
    }

    /// Regression: a second `--in-place` run replaced the `.bak` holding the original.
    #[test]
    fn a_foreign_backup_is_rotated_not_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.gcode");
        fs::write(&input, b"original\n").unwrap();
        in_place(&input, b"first\n", false).unwrap();
        in_place(&input, b"second\n", false).unwrap();
        assert_eq!(fs::read(&input).unwrap(), b"second\n");
        assert_eq!(fs::read(dir.path().join("in.gcode.bak")).unwrap(), b"first\n");
        assert_eq!(fs::read(dir.path().join("in.gcode.bak.1")).unwrap(), b"original\n");
        // A backup that is already a copy of the input is kept, not rotated.
        fs::write(&input, b"first\n").unwrap();
        in_place(&input, b"third\n", false).unwrap();
        assert!(!dir.path().join("in.gcode.bak.2").exists());
        // With every slot taken, the run is refused before anything changes.
        for n in 2..=BACKUP_SLOTS {
            fs::write(dir.path().join(format!("in.gcode.bak.{n}")), b"old\n").unwrap();
        }
        let err = in_place(&input, b"fourth\n", false).unwrap_err();
        assert!(matches!(err, Error::BackupSlotsFull { .. }), "{err}");
        assert_eq!(fs::read(&input).unwrap(), b"third\n");
        assert!(fs::read_dir(dir.path()).unwrap().all(|e| !e
            .unwrap()
            .file_name()
            .to_string_lossy()
            .ends_with(".tmp")));
    }

    /// A breaking session found `cat FIFO --in-place` waiting for a writer forever (the pipe,
    /// read to its end, was opened again), and `cat /dev/stdin --in-place < in.gcode` writing
    /// `/dev/stdin.bak` into /dev: only a file of the user's is replaced in place.
    #[cfg(unix)]
    #[test]
    fn a_pipe_or_a_system_alias_is_not_replaced_in_place() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe.gcode");
        assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
        // What `/dev/stdin` names when standard input is a file: the file, through /proc.
        let file = dir.path().join("in.gcode");
        fs::write(&file, b"old\n").unwrap();
        let open = fs::File::open(&file).unwrap();
        let alias = PathBuf::from(format!("/proc/self/fd/{}", std::os::fd::AsRawFd::as_raw_fd(&open)));
        for input in [fifo.as_path(), Path::new("/dev/null"), alias.as_path()] {
            let err = in_place(input, b"new\n", true).unwrap_err();
            assert!(matches!(err, Error::NotAFileToReplace { .. }), "{}: {err}", input.display());
        }
        assert_eq!(fs::read(&file).unwrap(), b"old\n");
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 2);
    }

    /// Regression: `--in-place` replaced a read-only file.
    #[cfg(unix)]
    #[test]
    fn a_read_only_input_needs_force() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.gcode");
        fs::write(&input, b"old\n").unwrap();
        fs::set_permissions(&input, fs::Permissions::from_mode(0o444)).unwrap();
        let err = in_place(&input, b"new\n", false).unwrap_err();
        assert!(matches!(err, Error::ReadOnly { .. }), "{err}");
        assert_eq!(fs::read(&input).unwrap(), b"old\n");
        in_place(&input, b"new\n", true).unwrap();
        assert_eq!(fs::read(&input).unwrap(), b"new\n");
        assert_eq!(fs::metadata(&input).unwrap().permissions().mode() & 0o777, 0o444);
    }

    #[cfg(unix)]
    #[test]
    fn in_place_keeps_the_mode() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.gcode");
        fs::write(&input, b"old\n").unwrap();
        fs::set_permissions(&input, fs::Permissions::from_mode(0o754)).unwrap();
        in_place(&input, b"new\n", false).unwrap();
        assert_eq!(fs::metadata(&input).unwrap().permissions().mode() & 0o777, 0o754);
        let bak = dir.path().join("in.gcode.bak");
        assert_eq!(fs::metadata(bak).unwrap().permissions().mode() & 0o777, 0o754);
    }

    #[cfg(unix)]
    #[test]
    fn hard_links_are_the_same_file() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a");
        fs::write(&a, b"x").unwrap();
        fs::hard_link(&a, dir.path().join("b")).unwrap();
        assert!(same_file(&a, &dir.path().join("b")));
        assert!(!same_file(&a, &dir.path().join("missing")));
    }
}
