//! What a new user met in the first hour (issue 39), through the real binary: profiles by
//! name, one line per kind of warning, and the small traps of `preview`, `raster` and `rotary`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn gweave(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gweave")).args(args).output().unwrap()
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn fixture(name: &str) -> String {
    root().join("tests/data").join(name).to_str().unwrap().to_owned()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// `--machine klipper` said "reading klipper: No such file": the example profiles are built in,
/// by name, wherever gweave runs from (and the Python package has them too).
#[test]
fn machine_klipper_is_a_built_in_profile_not_a_missing_file() {
    let torus = fixture("cura/cura_torus.gcode");
    let by_name = gweave(&["estimate", &torus, "--machine", "klipper", "--json", "-q"]);
    assert!(by_name.status.success(), "{}", text(&by_name.stderr));
    let file = root().join("examples/machines/klipper.toml");
    let by_path = gweave(&["estimate", &torus, "--machine", file.to_str().unwrap(), "--json", "-q"]);
    assert_eq!(text(&by_name.stdout), text(&by_path.stdout));

    let list = text(&gweave(&["machine", "list"]).stdout);
    for name in ["marlin-ramps", "prusa-mk3", "klipper", "mixing-4in", "rotary", "inkjet-c6602"] {
        assert!(list.lines().any(|l| l.starts_with(name)), "{name} in {list}");
    }
    let shown = gweave(&["machine", "show", "prusa-mk3"]);
    assert_eq!(text(&shown.stdout), include_str!("../../../examples/machines/prusa-mk3.toml"));

    let typo = gweave(&["sim", &torus, "--machine", "klipperr"]);
    assert_eq!(typo.status.code(), Some(1));
    let said = text(&typo.stderr);
    assert!(said.contains("reading klipperr: "), "{said}");
    assert!(said.contains("built in: marlin-ramps, prusa-mk3, klipper,"), "{said}");
}
