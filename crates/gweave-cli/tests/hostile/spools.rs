//! Standard input and other streams (`-`, `/dev/zero`, a FIFO) are copied to the temporary
//! directory before they are read: `yes G1 X1 | gweave stats -` wrote about 300 MB/s there with
//! no limit, and when the disk filled the error named `-`, not the copy. A copy stops at its
//! ceiling (8 GiB, `GWEAVE_SPOOL_LIMIT` to change it), and a copy that cannot be written names
//! the temporary directory.

use std::time::Duration;

use crate::containers::shell;
use crate::harness::*;
use crate::outputs::Tmpfs;

/// Regression: `stats /dev/zero` and `check /dev/urandom` spooled without end. With a limit of
/// 1 MiB they stop after it, saying what and where, in budget and at once.
#[test]
fn an_endless_stream_stops_at_the_spool_ceiling() {
    let dir = tempfile::tempdir().unwrap();
    for args in [&["stats", "/dev/zero"][..], &["check", "/dev/urandom"], &["sim", "/dev/zero"]] {
        let out = gweave(dir.path(), args)
            .env("GWEAVE_SPOOL_LIMIT", "1M")
            .env("TMPDIR", dir.path())
            .limit(Duration::from_secs(30))
            .run();
        out.assert_sound().assert_peak_under(64.0);
        assert_eq!(out.code, Some(1), "{args:?}: {}", out.stderr);
        assert!(
            out.stderr.contains(
                "the stream is longer than the limit of 1 MiB copied to the temporary directory \
                 (GWEAVE_SPOOL_LIMIT sets another)"
            ),
            "{args:?}: {}",
            out.stderr
        );
        assert!(out.stderr.contains(args[1]), "the input is named: {}", out.stderr);
    }
    // The copy is unnamed: nothing is left in the temporary directory.
    assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none());
}

/// `yes G1 X1 | gweave stats -` through a real pipe, and a limit written wrongly is refused.
#[test]
fn standard_input_without_end_stops_at_the_ceiling() {
    let dir = tempfile::tempdir().unwrap();
    let (code, _, err) = shell(dir.path(), "yes G1 X1 | GWEAVE_SPOOL_LIMIT=2M \"$G\" stats -");
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("gweave: error: -: the stream is longer than the limit of 2 MiB"), "{err}");
    let (code, _, err) = shell(dir.path(), "echo G1 X1 | GWEAVE_SPOOL_LIMIT=lots \"$G\" stats -");
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("GWEAVE_SPOOL_LIMIT=lots: give a size in bytes, or with K, M or G"), "{err}");
    // Within the limit, standard input reads as before.
    let (code, out, err) =
        shell(dir.path(), "printf 'G1 X1 E1\\n' | GWEAVE_SPOOL_LIMIT=1K \"$G\" stats - --json");
    assert_eq!(code, 0, "{err}");
    assert!(String::from_utf8_lossy(&out).contains("\"lines\": 1"));
}

/// Regression: when the temporary directory filled, the error named `-` and the disk, as if the
/// input were at fault. It names the temporary directory and `$TMPDIR` now.
#[test]
fn a_full_temporary_directory_is_named_in_the_error() {
    let Some(fs) = Tmpfs::mount("1m") else { return };
    let tmp = fs.0.path().display().to_string();
    let dir = tempfile::tempdir().unwrap();
    let script = format!("head -c 3000000 /dev/zero | TMPDIR={tmp} \"$G\" stats -");
    let (code, _, err) = shell(dir.path(), &script);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains(&format!("copying the stream to a file in {tmp} ($TMPDIR): No space left on device")),
        "{err}"
    );
    let (code, _, err) = shell(dir.path(), "echo G1 | TMPDIR=/nonexistent/dir \"$G\" stats -");
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("copying the stream to a file in /nonexistent/dir ($TMPDIR)"), "{err}");
}
