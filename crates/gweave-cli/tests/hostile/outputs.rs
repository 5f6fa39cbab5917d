//! Output paths: no output may name an input, two outputs may not name one file, `--in-place`
//! keeps what the user had, signals and a full disk leave no temporary file, and a full
//! standard output is an error, not a panic.

use std::fs;
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::thread;
use std::time::{Duration, Instant};

use crate::harness::*;

/// Runs `args` in a directory holding `in.gcode` and asserts a refusal with `message`, exit
/// code 1, every file unchanged and no temporary file left.
#[track_caller]
fn refused_in(dir: &Path, args: &[&str], message: &str) {
    let before = snapshot(dir);
    gweave(dir, args).run().assert_refused(message);
    assert_eq!(snapshot(dir), before, "files changed by a refused run of {args:?}");
    assert_no_temp_left(dir);
}

fn torus() -> (tempfile::TempDir, PathBuf) {
    dir_with_fixture("cura/cura_torus.gcode", "in.gcode")
}

/// Regression: `gweave cat in -o x --report x` replaced the G-code output by the JSON report.
#[test]
fn report_naming_the_input_is_refused() {
    let (dir, _) = torus();
    refused_in(
        dir.path(),
        &["stats", "in.gcode", "--report", "in.gcode"],
        "--report in.gcode would overwrite the input file in.gcode; name another file",
    );
}

/// A breaking session found a report that could not be written failing the run after the
/// other outputs were in place: `cat in -o out --report rep` (a folder) wrote `out`, and
/// `purge-shift in --in-place --report nodir/r.json` replaced the input and kept a `.bak`, then
/// exited 1. Every output file is checked before anything is read.
#[test]
fn a_report_that_cannot_be_written_stops_the_run_before_any_output() {
    let (dir, _) = torus();
    fs::create_dir(dir.path().join("rep")).unwrap();
    refused_in(
        dir.path(),
        &["cat", "in.gcode", "-o", "out.gcode", "--report", "rep"],
        "--report rep is a folder: name a file",
    );
    refused_in(
        dir.path(),
        &["purge-shift", "in.gcode", "--in-place", "--purge-mm", "1", "--report", "nodir/r.json"],
        "--report nodir/r.json: No such file or directory",
    );
    refused_in(
        dir.path(),
        &["mix", "in.gcode", "-o", "out.gcode", "--map", "T0=Cyan", "--report", "nodir/r.json"],
        "--report nodir/r.json: No such file or directory",
    );
}

/// Regression: `sim in.gcode --plot in.gcode` (and `--plot-speed`) replaced the input by a PNG.
#[test]
fn sim_plot_naming_the_input_is_refused() {
    let (dir, _) = torus();
    for flag in ["--plot", "--plot-speed"] {
        let message = format!("{flag} in.gcode would overwrite the input file in.gcode; name another file");
        refused_in(dir.path(), &["sim", "in.gcode", flag, "in.gcode", "-q"], &message);
    }
    // Another spelling of the input is the same file.
    refused_in(
        dir.path(),
        &["sim", "in.gcode", "--plot", "./in.gcode", "-q"],
        "--plot ./in.gcode would overwrite the input file in.gcode;",
    );
}

/// Regression (a new user's trial): `cat same.gcode -o same.gcode` was refused with "-o
/// same.gcode names the input (INPUT)", which reads like a placeholder; the input is named by
/// its path, as given (`./same.gcode` for `same.gcode` is the same file).
#[test]
fn output_naming_the_input_says_which_input_not_input() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("same.gcode"), "G1 X1\n").unwrap();
    refused_in(
        dir.path(),
        &["cat", "./same.gcode", "-o", "same.gcode"],
        "-o same.gcode would overwrite the input file ./same.gcode; name another file",
    );
}

/// Regression: `rotary wrap in.gcode -o x --preview in.gcode` replaced the input by a PNG.
#[test]
fn rotary_wrap_preview_naming_the_input_is_refused() {
    let (dir, _) = torus();
    refused_in(
        dir.path(),
        &["rotary", "wrap", "in.gcode", "-o", "x.gcode", "--mandrel-diameter", "30", "--preview", "in.gcode"],
        "--preview in.gcode would overwrite the input file in.gcode; name another file",
    );
    refused_in(
        dir.path(),
        &["rotary", "wrap", "in.gcode", "-o", "x.gcode", "--mandrel-diameter", "30", "--preview", "x.gcode"],
        "--preview x.gcode names the same file as -o x.gcode; name another file",
    );
}

/// A folder with a copy of the badge layers of `examples/raster/layers`.
fn badge_layers() -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("temp dir");
    let layers = dir.path().join("layers");
    fs::create_dir(&layers).unwrap();
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/raster/layers");
    for entry in fs::read_dir(examples).unwrap().flatten() {
        fs::copy(entry.path(), layers.join(entry.file_name())).unwrap();
    }
    dir
}

/// Regression: `raster b0.bmp -o b0.bmp` and `raster DIR -o DIR/badge_3.bmp` replaced a layer.
#[test]
fn raster_output_naming_an_input_image_is_refused() {
    let dir = badge_layers();
    refused_in(
        dir.path(),
        &["raster", "layers/badge_0.bmp", "-o", "layers/badge_0.bmp"],
        "-o layers/badge_0.bmp would overwrite the input file layers/badge_0.bmp; name another file",
    );
    refused_in(
        dir.path(),
        &["raster", "layers", "-o", "layers/badge_3.bmp"],
        "-o layers/badge_3.bmp would overwrite the input file layers/badge_3.bmp",
    );
    refused_in(
        dir.path(),
        &["raster", "layers/badge_?.bmp", "-o", "layers/badge_7.bmp"],
        "would overwrite the input file",
    );
}

/// Regression: `raster ... --recoat r.gcode --report r.gcode` replaced the recoat snippet.
#[test]
fn raster_report_naming_the_recoat_snippet_is_refused() {
    let dir = badge_layers();
    fs::write(dir.path().join("r.gcode"), "G1 Z{z}\n").unwrap();
    refused_in(
        dir.path(),
        &["raster", "layers", "-o", "out.gcode", "--recoat", "r.gcode", "--report", "r.gcode"],
        "--report r.gcode would overwrite r.gcode, the file --recoat reads; name another file",
    );
}

/// Regression: `mix in.gcode --palette-png in.gcode` replaced the input by the swatch, then
/// failed on it: input gone, no output.
#[test]
fn mix_palette_png_naming_the_input_is_refused() {
    let (dir, _) = torus();
    refused_in(
        dir.path(),
        &["mix", "in.gcode", "--at-layer", "0=Orange", "-o", "m.gcode", "--palette-png", "in.gcode", "-q"],
        "--palette-png in.gcode would overwrite the input file in.gcode; name another file",
    );
}

/// Regression: `cat in -o x --report x` (and mix) replaced the G-code output by the report.
#[test]
fn output_and_report_naming_one_file_are_refused() {
    let (dir, _) = torus();
    refused_in(
        dir.path(),
        &["cat", "in.gcode", "-o", "x.gcode", "--report", "x.gcode"],
        "--report x.gcode names the same file as -o x.gcode; name another file",
    );
    refused_in(
        dir.path(),
        &["mix", "in.gcode", "--at-layer", "0=Orange", "-o", "x.gcode", "--report", "x.gcode"],
        "--report x.gcode names the same file as -o x.gcode",
    );
    // With --in-place, the report may not be the input nor its backup.
    refused_in(
        dir.path(),
        &["cat", "in.gcode", "--in-place", "--report", "in.gcode.bak"],
        "--report in.gcode.bak names the same file as --in-place's backup",
    );
}

/// The layer images of `slice-raster -o DIR` and `sim --raster-out DIR` are outputs too.
#[test]
fn a_file_among_the_layers_an_output_folder_gets_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir(dir.path().join("layers")).unwrap();
    fs::write(dir.path().join("m.stl"), "solid m\nendsolid m\n").unwrap();
    refused_in(
        dir.path(),
        &[
            "slice-raster",
            "m.stl",
            "--layer-height",
            "0.1",
            "-o",
            "layers",
            "--report",
            "layers/layer_00000.png",
        ],
        "--report layers/layer_00000.png is one of the files -o layers writes; name another file",
    );
    let gcode = dir.path().join("layers").join("layer_00001_head0.png");
    fs::copy(fixture_path("cura/cura_torus.gcode"), &gcode).unwrap();
    refused_in(
        dir.path(),
        &["sim", "layers/layer_00001_head0.png", "--raster-out", "layers", "-q"],
        "--raster-out layers would write over the input file layers/layer_00001_head0.png; name another folder",
    );
}

/// A profile or snippet named as an output is an input too.
#[test]
fn an_output_naming_a_profile_is_refused() {
    let (dir, _) = torus();
    let machine = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines/marlin-ramps.toml");
    fs::copy(machine, dir.path().join("m.toml")).unwrap();
    refused_in(
        dir.path(),
        &["estimate", "in.gcode", "--machine", "m.toml", "--report", "m.toml"],
        "--report m.toml would overwrite m.toml, the file --machine reads",
    );
}

/// Regression: `--in-place` changed the owner to the running user. The mode is kept too.
#[test]
fn in_place_keeps_mode_and_owner() {
    let (dir, input) = torus();
    fs::set_permissions(&input, fs::Permissions::from_mode(0o640)).unwrap();
    // SAFETY: geteuid has no preconditions.
    let root = unsafe { libc::geteuid() } == 0;
    if root {
        std::os::unix::fs::chown(&input, Some(1234), Some(1234)).unwrap();
    } else {
        println!("not root: the owner is not tested");
    }
    gweave(dir.path(), &["cat", "in.gcode", "--in-place", "-q"]).run().assert_ok();
    for path in [input.clone(), dir.path().join("in.gcode.bak")] {
        let meta = fs::metadata(&path).unwrap();
        assert_eq!(meta.mode() & 0o777, 0o640, "{}", path.display());
        if root {
            assert_eq!((meta.uid(), meta.gid()), (1234, 1234), "{}", path.display());
        }
    }
    assert_no_temp_left(dir.path());
}

/// Regression: `--in-place` replaced a read-only file; `--force` still can.
#[test]
fn in_place_refuses_a_read_only_file_unless_forced() {
    let (dir, input) = torus();
    fs::set_permissions(&input, fs::Permissions::from_mode(0o444)).unwrap();
    refused_in(
        dir.path(),
        &["purge-shift", "in.gcode", "--purge-mm", "2", "--in-place"],
        "in.gcode is read-only: it is replaced in place only when forced",
    );
    gweave(dir.path(), &["cat", "in.gcode", "--in-place", "--force", "-q"]).run().assert_ok();
    assert_eq!(fs::metadata(&input).unwrap().mode() & 0o777, 0o444);
    assert_no_temp_left(dir.path());
}

/// Regression: a second `--in-place` run overwrote the `.bak`, so the original was gone; an
/// existing `.bak` of the user's was replaced too.
#[test]
fn in_place_never_loses_an_existing_backup() {
    let (dir, input) = torus();
    let original = fs::read(&input).unwrap();
    let bak = dir.path().join("in.gcode.bak");
    fs::write(&bak, b"the user's own notes\n").unwrap();
    gweave(dir.path(), &["cat", "in.gcode", "--in-place", "-q"]).run().assert_ok();
    assert_eq!(fs::read(&bak).unwrap(), original);
    assert_eq!(fs::read(dir.path().join("in.gcode.bak.1")).unwrap(), b"the user's own notes\n");
    // A second run on a changed file (as after a first transform) keeps the original.
    let changed = [&original[..], b"; changed\n"].concat();
    fs::write(&input, &changed).unwrap();
    gweave(dir.path(), &["cat", "in.gcode", "--in-place", "-q"]).run().assert_ok();
    assert_eq!(fs::read(&bak).unwrap(), changed);
    assert_eq!(fs::read(dir.path().join("in.gcode.bak.2")).unwrap(), original);
    assert_no_temp_left(dir.path());
}

/// A ~100 MB file of plain moves.
fn big_input(dir: &Path) -> PathBuf {
    let path = dir.join("big.gcode");
    fs::write(&path, b"G1 X1.5 Y2.25 E0.125\n".repeat(5_000_000)).unwrap();
    path
}

pub(crate) fn temp_files(dir: &Path) -> Vec<PathBuf> {
    fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with(".gweave-")))
        .collect()
}

/// Regression: SIGINT or SIGTERM during `--in-place` left a hidden `.gweave-*.tmp` of up to
/// 309 MB in 18 of 20 runs.
#[test]
fn signals_during_in_place_leave_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let input = big_input(dir.path());
    let before = snapshot(dir.path());
    for signal in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
        let run = gweave(dir.path(), &["cat", "big.gcode", "--in-place", "-q"]).spawn();
        let start = Instant::now();
        while temp_files(dir.path()).is_empty() {
            assert!(start.elapsed() < Duration::from_secs(30), "no temporary file appeared");
            thread::sleep(Duration::from_millis(2));
        }
        thread::sleep(Duration::from_millis(50));
        run.signal(signal);
        let outcome = run.wait();
        if outcome.code == Some(0) {
            println!("signal {signal}: the run had finished");
        } else {
            // Ended by the signal itself, re-raised after the clean-up (see signals.rs).
            assert_eq!(
                outcome.signal,
                Some(signal),
                "signal {signal}: {:?} {}",
                outcome.code,
                outcome.stderr
            );
        }
        assert_no_temp_left(dir.path());
        assert_eq!(fs::read(&input).unwrap().len(), 105_000_000);
        let bak = dir.path().join("big.gcode.bak");
        if bak.exists() {
            assert_eq!(fs::read(&bak).unwrap(), fs::read(&input).unwrap(), "a partial .bak");
            fs::remove_file(&bak).unwrap();
        }
    }
    assert_eq!(snapshot(dir.path()), before);
}

/// Regression: `gweave stats FILE > /dev/full` panicked with "failed printing to stdout".
#[test]
fn a_full_standard_output_is_an_error_not_a_panic() {
    let (dir, _) = torus();
    for command in ["stats", "check", "sim", "estimate"] {
        // The summary (-q would hide it: nothing written, nothing to fail).
        gweave(dir.path(), &[command, "in.gcode"])
            .stdout_file(Path::new("/dev/full"))
            .run()
            .assert_refused("gweave: error: writing to standard output");
        gweave(dir.path(), &[command, "in.gcode", "-q", "--json"])
            .stdout_file(Path::new("/dev/full"))
            .run()
            .assert_refused("No space left on device");
    }
}

/// Regression: a failed `--report` printed its cause twice and named the temporary file.
#[test]
fn a_failed_report_names_its_path_once() {
    let (dir, _) = torus();
    let out = gweave(dir.path(), &["stats", "in.gcode", "--report", "missing/r.json"]).run();
    out.assert_refused("missing/r.json");
    assert_eq!(out.stderr.matches("No such file or directory").count(), 1, "{}", out.stderr);
    assert!(!out.stderr.contains(".gweave-"), "{}", out.stderr);
}

/// A small tmpfs, unmounted when dropped.
pub(crate) struct Tmpfs(pub(crate) tempfile::TempDir);

impl Tmpfs {
    pub(crate) fn mount(size: &str) -> Option<Tmpfs> {
        let dir = tempfile::tempdir().unwrap();
        let status = std::process::Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "none"])
            .arg(dir.path())
            .stderr(std::process::Stdio::null())
            .status();
        match status {
            Ok(s) if s.success() => Some(Tmpfs(dir)),
            _ => {
                println!("skipped: mounting a tmpfs is not permitted here");
                None
            }
        }
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = std::process::Command::new("umount").arg(self.0.path()).status();
    }
}

/// Regression: a full disk left a truncated `.bak`. Nothing may be left, and the message names
/// the destination, not the temporary file.
#[test]
fn a_full_disk_leaves_nothing_behind() {
    let Some(fs1) = Tmpfs::mount("1m") else { return };
    let disk = fs1.0.path();
    // The output does not fit.
    let out =
        gweave(disk, &["cat", &fixture_path("cura/cura_dual.gcode").to_string_lossy(), "-o", "out.gcode"])
            .run();
    out.assert_refused("out.gcode: No space left on device");
    assert!(!out.stderr.contains(".gweave-"), "{}", out.stderr);
    assert!(!disk.join("out.gcode").exists());
    assert_no_temp_left(disk);
    // The output fits, its backup does not: the input stays, with no partial .bak.
    fs::write(disk.join("in.gcode"), b"G1 X1.5 Y2.25 E0.125\n".repeat(18_000)).unwrap();
    let before = snapshot(disk);
    let out = gweave(disk, &["cat", "in.gcode", "--in-place"]).run();
    out.assert_refused("in.gcode.bak: No space left on device");
    assert_eq!(snapshot(disk), before);
    assert_no_temp_left(disk);
}

/// Regression: a transform's write error named its scratch file (the `.gweave-XXXX.tmp` it
/// writes before the header and metadata go on), not the output the user gave.
#[test]
fn write_errors_during_a_transform_name_the_output() {
    // Cura's dual file as for one nozzle: purge-shift refuses a nozzle per tool.
    let dir = tempfile::tempdir().unwrap();
    let input = crate::one_nozzle::one_nozzle_in(dir.path(), "cura/cura_dual.gcode");
    let input = input.to_string_lossy();
    for args in [
        &["purge-shift", &input, "--purge-mm", "25", "-o", "out.gcode", "-q"][..],
        &["mix", &input, "--at-layer", "0=Orange", "-o", "out.gcode", "-q"][..],
    ] {
        write_error_names_the_output("1m", args);
    }
}

/// Regression: a disk filling up while the metadata was written (the transform's output, 3 MB,
/// fits on a 4 MB disk; it and the final file together do not) named the scratch file,
/// `.gweave-XXXX.tmp (output)`, not the output.
#[test]
fn write_errors_while_the_metadata_is_written_name_the_output() {
    let dir = tempfile::tempdir().unwrap();
    let input = crate::one_nozzle::one_nozzle_in(dir.path(), "cura/cura_dual.gcode");
    write_error_names_the_output(
        "4m",
        &["purge-shift", &input.to_string_lossy(), "--purge-mm", "25", "-o", "out.gcode", "-q"],
    );
}

/// Runs `args` writing `out.gcode` on a tmpfs of `size`: refused for want of space, naming
/// `out.gcode` and not a scratch file, leaving nothing behind.
fn write_error_names_the_output(size: &str, args: &[&str]) {
    let Some(fs) = Tmpfs::mount(size) else { return };
    let disk = fs.0.path();
    let out = gweave(disk, args).run();
    out.assert_refused("out.gcode: No space left on device");
    assert!(!out.stderr.contains(".gweave-"), "{}", out.stderr);
    assert!(!disk.join("out.gcode").exists());
    assert_no_temp_left(disk);
}

/// Regression: a reader that stops early (`gweave purge-shift in.gcode -o - | head -1`) killed
/// the process by SIGPIPE, the command line leaving it at its default as Unix tools do, and the
/// scratch file the output is made in (in the temporary directory, for standard output) stayed.
#[test]
fn a_closed_pipe_leaves_no_scratch_file() {
    use std::io::Read;
    let tmp = tempfile::tempdir().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let input = crate::one_nozzle::one_nozzle_in(dir.path(), "cura/cura_dual.gcode");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_gweave"))
        .args(["purge-shift", &input.to_string_lossy(), "--purge-mm", "25", "-o", "-", "-q"])
        .env("TMPDIR", tmp.path())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut first = [0u8; 16];
    child.stdout.take().unwrap().read_exact(&mut first).unwrap();
    // The pipe's read end is dropped here: the next write of the 3 MB output meets it closed.
    let status = child.wait().unwrap();
    assert_eq!(std::os::unix::process::ExitStatusExt::signal(&status), Some(libc::SIGPIPE), "{status:?}");
    assert_no_temp_left(tmp.path());
}

/// Regression: `serve --report PATH` was written only when a host disconnected, so a report in
/// a missing folder, or naming the EEPROM file the server reads, was found out after serving.
#[test]
fn serve_report_path_is_checked_before_serving() {
    let dir = tempfile::tempdir().unwrap();
    let serve = ["serve", "--tcp", "127.0.0.1:0", "--exit-after-idle", "3"];
    let args = [&serve[..], &["--report", "missing/r.json"]].concat();
    refused_in(dir.path(), &args, "--report missing/r.json: No such file or directory");
    let args = [&serve[..], &["--eeprom", "e.gcode", "--report", "e.gcode"]].concat();
    refused_in(
        dir.path(),
        &args,
        "--report e.gcode would overwrite e.gcode, the file --eeprom reads; name another file",
    );
}

/// Regression (a new user's trial): `machine from-m503 m.txt -o m.txt` read the transcript and
/// printed its notes before refusing, with a wording of its own.
#[test]
fn machine_from_m503_naming_its_input_is_refused_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("m.txt"), "echo:  M92 X80.00 Y80.00 Z400.00 E93.00\necho:  M900 K0.05\n")
        .unwrap();
    let before = snapshot(dir.path());
    let out = gweave(dir.path(), &["machine", "from-m503", "m.txt", "-o", "m.txt"]).run();
    out.assert_refused("-o m.txt would overwrite the input file m.txt; name another file");
    assert!(!out.stderr.contains("not used"), "read before refusing: {}", out.stderr);
    assert_eq!(snapshot(dir.path()), before);
}
