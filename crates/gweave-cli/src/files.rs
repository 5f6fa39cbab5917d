//! The files one run reads and writes, each with the flag that named it, checked before
//! anything is read: no output may name an input, and no two outputs may name one file.
//!
//! Every command lists all its paths here (the G-code, profiles, snippets, images; `-o`,
//! `--report`, pictures, folders of layers) and calls [`Files::check`] first, so a typo such as
//! `--plot in.gcode` is refused with both flags named instead of replacing the input.
//!
//! Two paths are the same file when they reach the same inode (links and hard links included)
//! or, for files that do not exist yet, when they are equal once their folder is resolved
//! (`./x` and `sub/../x`). Devices and pipes (`/dev/null`, `/dev/stdout`) are exempt: writing
//! to them replaces nothing.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use gweave::Target;

/// Which file names in an output folder a command writes (e.g. `layer_00012.png`).
pub type Owns = fn(&OsStr) -> bool;

/// The layer images `slice-raster -o DIR` and `sim --raster-out DIR` write: `layer_*.png`.
pub fn layer_png(name: &OsStr) -> bool {
    let name = name.to_string_lossy();
    name.starts_with("layer_") && name.ends_with(".png")
}

/// The paths of one run.
#[derive(Default)]
pub struct Files {
    inputs: Vec<Entry>,
    outputs: Vec<Entry>,
}

struct Entry {
    flag: String,
    path: PathBuf,
    /// The folder's pattern for an output folder.
    dir: Option<Owns>,
    /// An in-place output may be the input it replaces (this input's index).
    replaces: Option<usize>,
}

impl Files {
    pub fn new() -> Files {
        Files::default()
    }

    /// A file the run reads, named by `flag` (`INPUT` for the positional argument).
    pub fn read(mut self, flag: &str, path: Option<&Path>) -> Files {
        if let Some(path) = path {
            self.inputs.push(Entry { flag: flag.into(), path: path.into(), dir: None, replaces: None });
        }
        self
    }

    /// Several files read under one flag (raster's images, once folders and globs are listed).
    pub fn read_all<'a>(self, flag: &str, paths: impl IntoIterator<Item = &'a Path>) -> Files {
        paths.into_iter().fold(self, |files, p| files.read(flag, Some(p)))
    }

    /// A file the run writes; `-` (standard output) is no file.
    pub fn write(mut self, flag: &str, path: Option<&Path>) -> Files {
        if let Some(path) = path.filter(|p| *p != Path::new("-")) {
            self.outputs.push(Entry { flag: flag.into(), path: path.into(), dir: None, replaces: None });
        }
        self
    }

    /// A folder the run writes files into, those whose names `owns` accepts.
    pub fn write_dir(mut self, flag: &str, dir: Option<&Path>, owns: Owns) -> Files {
        if let Some(dir) = dir {
            self.outputs.push(Entry { flag: flag.into(), path: dir.into(), dir: Some(owns), replaces: None });
        }
        self
    }

    /// The G-code output of a transform of `input` (`INPUT`): `-o`, or the input itself and its
    /// backup with `--in-place`. Call after [`Files::read`] of the input.
    pub fn target(mut self, target: &Target, input: &Path) -> Files {
        match target {
            Target::File(path) => self.write("-o", Some(path)),
            // A scratch file is the run's own, not a file the user named.
            Target::Stdout(_) | Target::Scratch(_) => self,
            Target::InPlace { keep_backup, .. } => {
                let replaces = self.inputs.iter().position(|e| e.path == input);
                let entry = Entry { flag: "--in-place".into(), path: input.into(), dir: None, replaces };
                self.outputs.push(entry);
                let mut backup = input.as_os_str().to_owned();
                backup.push(".bak");
                let backup = PathBuf::from(backup);
                self.write("--in-place's backup", keep_backup.then_some(backup.as_path()))
            }
        }
    }

    /// Refuses an output that names an input or another output.
    pub fn check(&self) -> Result<()> {
        if self.outputs.iter().any(|e| e.flag == "--in-place" && e.path == Path::new("-")) {
            bail!("--in-place needs a file to replace, not standard input (-): write with -o OUT or -o -");
        }
        let inputs: Vec<(&Entry, Option<Id>)> = self.inputs.iter().map(|e| (e, Id::of(&e.path))).collect();
        let outputs: Vec<(&Entry, Option<Id>)> = self.outputs.iter().map(|e| (e, Id::of(&e.path))).collect();
        for (k, (out, out_id)) in outputs.iter().enumerate() {
            for (i, (input, in_id)) in inputs.iter().enumerate() {
                if out.replaces == Some(i) {
                    continue;
                }
                if collide(out, out_id.as_ref(), input, in_id.as_ref()) {
                    let (flag, path, input) = (&out.flag, out.path.display(), read_by(input));
                    match out.dir {
                        Some(_) => bail!("{flag} {path} would write over {input}; name another folder"),
                        None => bail!("{flag} {path} would overwrite {input}; name another file"),
                    }
                }
            }
            for (earlier, earlier_id) in &outputs[..k] {
                if !collide(out, out_id.as_ref(), earlier, earlier_id.as_ref()) {
                    continue;
                }
                let (file, folder) = match (out.dir, earlier.dir) {
                    (None, Some(_)) => (out, earlier),
                    (Some(_), None) => (earlier, out),
                    _ => bail!(
                        "{} {} names the same file as {} {}; name another file",
                        out.flag,
                        out.path.display(),
                        earlier.flag,
                        earlier.path.display()
                    ),
                };
                bail!(
                    "{} {} is one of the files {} {} writes; name another file",
                    file.flag,
                    file.path.display(),
                    folder.flag,
                    folder.path.display()
                );
            }
        }
        // Every output file can be written, checked before the run: the outputs are renamed
        // into place one after the other at its end, so a report that failed there (a missing
        // folder, a folder where the file should be) came after `-o` or `--in-place` had been
        // written, and the run failed with the input already replaced.
        for (out, id) in &outputs {
            if out.dir.is_some() || id.is_none() {
                continue;
            }
            if out.path.is_dir() {
                bail!("{} {} is a folder: name a file", out.flag, out.path.display());
            }
            check_writable(&out.flag, &out.path)?;
        }
        Ok(())
    }
}

/// An input in a user's words, by its path (perhaps spelled otherwise than the output that
/// names it: `./in.gcode`, a link): "the input file in.gcode" for the command's own input (a
/// positional argument, `INPUT`), "m.toml, the file --machine reads" for a flag's.
fn read_by(input: &Entry) -> String {
    match input.flag.starts_with('-') {
        true => format!("{}, the file {} reads", input.path.display(), input.flag),
        false => format!("the input file {}", input.path.display()),
    }
}

/// Whether output `a` would write the file `b` names (or, both folders' patterns, the same).
fn collide(a: &Entry, a_id: Option<&Id>, b: &Entry, b_id: Option<&Id>) -> bool {
    let (Some(a_id), Some(b_id)) = (a_id, b_id) else {
        return false;
    };
    if a_id.same(b_id) {
        return true;
    }
    let inside = |dir: &Id, owns: Owns, file: &Id| {
        file.path.parent() == Some(&dir.path) && file.path.file_name().is_some_and(owns)
    };
    match (a.dir, b.dir) {
        (Some(owns), None) => inside(a_id, owns, b_id),
        (None, Some(owns)) => inside(b_id, owns, a_id),
        _ => false,
    }
}

/// What a path names: its inode when it exists, and its resolved path.
struct Id {
    inode: Option<(u64, u64)>,
    path: PathBuf,
}

impl Id {
    /// `None` for devices and pipes, which an output writes through rather than replaces.
    fn of(path: &Path) -> Option<Id> {
        match std::fs::metadata(path) {
            Ok(meta) if !meta.is_file() && !meta.is_dir() => None,
            Ok(meta) => {
                Some(Id { inode: inode(&meta), path: std::fs::canonicalize(path).unwrap_or(path.into()) })
            }
            Err(_) => Some(Id { inode: None, path: resolve_new(path) }),
        }
    }

    fn same(&self, other: &Id) -> bool {
        match (self.inode, other.inode) {
            (Some(a), Some(b)) => a == b,
            _ => self.path == other.path,
        }
    }
}

#[cfg(unix)]
fn inode(meta: &std::fs::Metadata) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    Some((meta.dev(), meta.ino()))
}

#[cfg(not(unix))]
fn inode(_meta: &std::fs::Metadata) -> Option<(u64, u64)> {
    None
}

/// Checks now that `path`, named by `flag`, can be written, for an output written only later
/// (`serve --report`, at each host's disconnection): its folder must take the temporary file
/// every output is written through.
pub fn check_writable(flag: &str, path: &Path) -> Result<()> {
    let folder = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    match gweave::TempFile::new_in(folder) {
        Ok(_) => Ok(()),
        Err(e) => bail!("{flag} {}: {e}", path.display()),
    }
}

/// A path that does not exist yet, with its folder resolved as far as it exists (links,
/// `..`), so that two spellings of one new file compare equal.
fn resolve_new(path: &Path) -> PathBuf {
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    match (absolute.parent(), absolute.file_name()) {
        (Some(parent), Some(name)) => match std::fs::canonicalize(parent) {
            Ok(parent) => parent.join(name),
            Err(_) => resolve_new(parent).join(name),
        },
        _ => absolute,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(files: Files) -> String {
        files.check().unwrap_err().to_string()
    }

    #[test]
    fn an_output_naming_an_input_is_refused_with_both_flags() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.gcode");
        std::fs::write(&input, "G1\n").unwrap();
        let err = refused(Files::new().read("INPUT", Some(&input)).write("--plot", Some(&input)));
        let input_path = input.display();
        assert_eq!(
            err,
            format!("--plot {input_path} would overwrite the input file {input_path}; name another file")
        );
        // Another spelling of the same file, and a hard link to it.
        let other = dir.path().join(".").join("in.gcode");
        assert!(Files::new().read("INPUT", Some(&input)).write("--plot", Some(&other)).check().is_err());
        std::fs::hard_link(&input, dir.path().join("link.gcode")).unwrap();
        let link = dir.path().join("link.gcode");
        assert!(Files::new().read("INPUT", Some(&input)).write("-o", Some(&link)).check().is_err());
    }

    /// A breaking session found a report that could not be written failing the run after
    /// `-o` or `--in-place` had been written: each output file is checked first.
    #[test]
    fn an_output_that_cannot_be_written_is_refused_before_the_run() {
        let dir = tempfile::tempdir().unwrap();
        let err = refused(Files::new().write("--report", Some(dir.path())));
        assert_eq!(err, format!("--report {} is a folder: name a file", dir.path().display()));
        let missing = dir.path().join("nodir").join("r.json");
        let out = dir.path().join("out.gcode");
        let err = refused(Files::new().write("-o", Some(&out)).write("--report", Some(&missing)));
        assert!(err.starts_with(&format!("--report {}: ", missing.display())), "{err}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "a probe was left behind");
    }

    #[test]
    fn two_outputs_naming_one_new_file_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let a = dir.path().join("x.gcode");
        let b = dir.path().join("sub").join("..").join("x.gcode");
        let err = refused(Files::new().write("-o", Some(&a)).write("--report", Some(&b)));
        assert!(err.contains("--report") && err.contains("names the same file as -o"), "{err}");
        // Standard output and devices are no files.
        let ok = Files::new().write("-o", Some(Path::new("-"))).write("--report", Some(Path::new("-")));
        ok.check().unwrap();
        Files::new()
            .write("-o", Some(Path::new("/dev/null")))
            .write("--report", Some(Path::new("/dev/null")))
            .check()
            .unwrap();
    }

    #[test]
    fn an_output_folder_may_not_hold_an_input_of_its_pattern() {
        let dir = tempfile::tempdir().unwrap();
        let layer = dir.path().join("layer_00003.png");
        std::fs::write(&layer, "").unwrap();
        let owns: Owns = |n| n.to_string_lossy().starts_with("layer_");
        let err = refused(Files::new().read("--head", Some(&layer)).write_dir("-o", Some(dir.path()), owns));
        let head =
            format!("would write over {}, the file --head reads; name another folder", layer.display());
        assert!(err.ends_with(&head), "{err}");
        let other = dir.path().join("part.stl");
        Files::new().read("MODEL", Some(&other)).write_dir("-o", Some(dir.path()), owns).check().unwrap();
    }

    #[test]
    fn in_place_may_replace_its_input_but_not_its_backup() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.gcode");
        std::fs::write(&input, "G1\n").unwrap();
        let target = Target::InPlace { keep_backup: true, force: false };
        Files::new().read("INPUT", Some(&input)).target(&target, &input).check().unwrap();
        let bak = dir.path().join("in.gcode.bak");
        let err = refused(
            Files::new().read("INPUT", Some(&input)).target(&target, &input).write("--report", Some(&bak)),
        );
        assert!(err.contains("--in-place's backup"), "{err}");
        let err = refused(
            Files::new().read("INPUT", Some(&input)).target(&target, &input).write("--report", Some(&input)),
        );
        assert!(err.contains("would overwrite the input file"), "{err}");
    }
}
