//! `gweave serve` as real hosts configure it (#20): the SD card folder, the pacing factor and the
//! `[firmware]` table are checked before any host connects, with a message naming what is wrong.

use std::time::Duration;

use crate::harness::*;

fn serve_refused(dir: &std::path::Path, args: &[&str], needle: &str) {
    let mut all = vec!["serve", "--tcp", "127.0.0.1:0"];
    all.extend_from_slice(args);
    gweave(dir, &all).limit(Duration::from_secs(20)).run().assert_refused(needle);
}

#[test]
fn serve_an_sd_card_that_is_not_a_folder_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("card"), "not a folder").unwrap();
    serve_refused(dir.path(), &["--sd", "card"], "--sd card: not a folder");
    serve_refused(dir.path(), &["--sd", "missing"], "--sd missing: not a folder");
}

#[test]
fn serve_a_speed_out_of_range_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for speed in [
        "--speed-factor=0",
        "--speed-factor=-3",
        "--speed-factor=NaN",
        "--speed-factor=inf",
        "--speed-factor=1e9",
    ] {
        let args = ["serve", "--tcp", "127.0.0.1:0", speed];
        assert_flag_refused(dir.path(), &args, "--speed-factor", "0.1 to 1000 x real time");
    }
    // clap's own refusal (usage error, exit code 2).
    let out =
        gweave(dir.path(), &["serve", "--tcp", "127.0.0.1:0", "--speed-factor", "2", "--realtime"]).run();
    out.assert_sound();
    assert_eq!(out.code, Some(2), "{}", out.stderr);
    assert!(out.stderr.contains("cannot be used with"), "{}", out.stderr);
}

#[test]
fn serve_a_firmware_table_that_contradicts_itself_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("[firmware]\nsdcard = false\n", "firmware.long_filenames needs firmware.sdcard"),
        ("[firmware]\nmesh = [3]\n", "firmware.mesh must be [] or two grid sizes"),
        ("[firmware]\nmesh = [3, 40]\n", "firmware.mesh must be [] or two grid sizes"),
        ("[firmware]\nsd_card = true\n", "unknown field `sd_card`"),
    ];
    for (text, needle) in cases {
        std::fs::write(dir.path().join("m.toml"), text).unwrap();
        serve_refused(dir.path(), &["--machine", "m.toml"], needle);
    }
}
