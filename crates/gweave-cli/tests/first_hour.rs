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

/// `check` on a file whose wipe tower is off the bed printed one warning per move (40 364, 1 000
/// of them line by line): each kind is one line with its count, range and lines.
#[test]
fn check_shows_a_wipe_tower_off_the_bed_as_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("tower.gcode");
    let mut g = String::from("M104 S200\n;TYPE:Perimeter\nG1 X10 Y10 E1\n;TYPE:Wipe tower\n");
    for i in 0..3000 {
        g.push_str(&format!("G1 X{} Y20 E{}\n", 201 + i % 49, 2 + i));
    }
    std::fs::write(&file, g).unwrap();
    let out = gweave(&["check", file.to_str().unwrap(), "--bed", "200,200,200"]);
    let said = text(&out.stdout);
    let name = file.display();
    assert_eq!(
        said.lines().next().unwrap(),
        format!("{name}:5:4: warning: wipe tower moves outside the bed: X 201.000 .. 249.000 mm, 3000 moves, lines 5 .. 3004")
    );
    assert!(said.contains("3004 lines, 0 errors, 3000 warnings"), "{said}");
    assert_eq!(said.lines().count(), 3, "{said}");
}

/// purge-shift listed each shortfall as a warning (95 lines on a user's file): one line per
/// kind, and `-q` keeps them (docs/pipeline.md: -q hides the summary only).
#[test]
fn purge_shift_groups_its_shortfalls_and_keeps_them_with_q() {
    let dir = tempfile::tempdir().unwrap();
    let out_file = dir.path().join("cone.gcode");
    let cone = fixture("slic3r/slic3r_cone_2tool.gcode");
    let out = gweave(&["purge-shift", &cone, "-o", out_file.to_str().unwrap(), "--purge-mm", "40", "-q"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let said = text(&out.stderr);
    let warnings: Vec<&str> = said.lines().filter(|l| l.starts_with("gweave: warning: ")).collect();
    assert!(!warnings.is_empty(), "-q hid the warnings: {said}");
    assert!(warnings.len() <= 4, "{said}");
    assert!(warnings.iter().any(|w| w.contains(" changes purge short by ")), "{said}");
    assert!(out.stdout.is_empty());
}

/// `preview --layer 5000` wrote a blank picture and exited 0.
#[test]
fn preview_past_the_last_layer_fails_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("l.png");
    let out = gweave(&[
        "preview",
        &fixture("cura/cura_dual.gcode"),
        "-o",
        png.to_str().unwrap(),
        "--layer",
        "5000",
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        text(&out.stderr).contains("layer 5000 is past the file's last layer, 203"),
        "{}",
        text(&out.stderr)
    );
    assert!(!png.exists());
}

/// A stack of images has no layer height: it was printed at 0.1 mm without a word (a voxel
/// stack came out squashed tenfold).
#[test]
fn a_bmp_stack_hints_at_its_layer_height() {
    let dir = tempfile::tempdir().unwrap();
    let out_file = dir.path().join("badge.gcode");
    let layers = root().join("examples/raster/layers");
    let out = gweave(&[
        "raster",
        layers.to_str().unwrap(),
        "-o",
        out_file.to_str().unwrap(),
        "--pixel-mm",
        "0.2",
        "-q",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let said = text(&out.stderr);
    assert!(said.contains("images carry no layer height: the layers are 0.1 mm apart"), "{said}");
    assert!(said.contains("--layer-height 0.2000 (the pixel size given)"), "{said}");
    // The pixel size was given: no word on it.
    assert!(!said.contains("images carry no pixel size"), "{said}");
    let given = gweave(&[
        "raster",
        layers.to_str().unwrap(),
        "-o",
        out_file.to_str().unwrap(),
        "--layer-height",
        "0.2",
        "-q",
    ]);
    // Without --pixel-mm or --dpi each pixel is one nozzle pitch: a stack drawn at another
    // resolution came out 1.32 times too large per side without a word (a new user's torus).
    assert_eq!(
        text(&given.stderr),
        "gweave: note: images carry no pixel size: each pixel is one nozzle pitch (0.2646 mm, 96 dpi); \
         if they were drawn at another resolution give --pixel-mm P or --dpi D so the part keeps its size\n"
    );
}

/// `rotary wrap --helical` said "seam at flat y = 0": a helical wrap has no seam.
#[test]
fn the_helical_wrap_summary_says_it_has_no_seam() {
    let dir = tempfile::tempdir().unwrap();
    let out_file = dir.path().join("sleeve.gcode");
    let plate = fixture("rotary/plate.gcode");
    let out = gweave(&[
        "rotary",
        "wrap",
        &plate,
        "-o",
        out_file.to_str().unwrap(),
        "--mandrel-diameter",
        "30",
        "--helical",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let said = text(&out.stdout);
    assert!(!said.contains("at flat y = 0"), "{said}");
    assert!(said.contains("  seam            none: each layer is one turn of a helix"), "{said}");
}

/// A user with a profile of their printer checked files against a bed typed again by hand
/// (`--bed 0,-4,250,210,210`): `--machine` takes the profile's.
#[test]
fn check_takes_the_bed_of_a_machine_profile() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("purge-line.gcode");
    // Prusa's purge line runs at Y -3, on the MK3S's bed (Y from -4), off a bed from Y 0.
    std::fs::write(&file, "M104 S215\nG1 Y-3.0 F1000\nG1 X60 E9\nG1 X250 Y200 Z200\n").unwrap();
    let check =
        |machine: &str| text(&gweave(&["check", file.to_str().unwrap(), "--machine", machine]).stdout);
    let mk3 = check("prusa-mk3");
    assert!(mk3.contains("bed X 0 .. 255, Y -4 .. 212.5, Z 0 .. 210 mm"), "{mk3}");
    assert!(mk3.contains("4 lines, 0 errors, 0 warnings"), "{mk3}");
    let ramps = check("marlin-ramps");
    assert!(
        ramps.contains(":2:4: warning: moves outside the bed: Y=-3.000 mm, 2 moves, lines 2 .. 3"),
        "{ramps}"
    );
    assert!(ramps.contains(":4:4: warning: move outside the bed: X=250.000 mm"), "{ramps}");
}

/// Regression (review of `check`'s long-extrusion warning: `--machine` took the profile's bed
/// but always held moves to Marlin's shipped 200 mm): the profile's `[firmware]
/// extrude_max_mm` is the limit, as `sim` holds moves to it; 0 is no limit.
#[test]
fn check_holds_extrusion_to_the_machine_profiles_limit() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("load.gcode");
    std::fs::write(&file, "M104 S215\nM83\nG1 E250 F300\n").unwrap();
    let check = |extrude_max: &str| {
        let machine = dir.path().join(format!("m{extrude_max}.toml"));
        std::fs::write(&machine, format!("[firmware]\nextrude_max_mm = {extrude_max}\n")).unwrap();
        let out = gweave(&["check", file.to_str().unwrap(), "--machine", machine.to_str().unwrap()]);
        text(&out.stdout)
    };
    let short = check("100");
    assert!(
        short.contains(
            ":3:4: warning: a move feeding 250.000 mm of filament: marlin skips the E of a move past 100 mm"
        ),
        "{short}"
    );
    for no_warning in ["300", "0"] {
        let said = check(no_warning);
        assert!(said.contains("3 lines, 0 errors, 0 warnings"), "{no_warning}: {said}");
    }
}

/// `raster` counts 800 us after every fire (the InkShield library waits that long after each
/// spray) but the virtual printer counted nothing for a fire: on a sphere `sim` came out
/// 2 min 48 s shorter than the raster's own figure. And `raster --machine` planned its time on
/// Marlin's defaults whatever the machine (the binder jet's pistons, 400 steps/mm, took 0.5 s
/// more in `sim` on the badge). Both now agree: the raster's motion and firing equal the
/// virtual printer's motion and dwells on the same machine (800 us a fire, the recoats'
/// dwells), homing aside. `estimate --machine` counted no fire either (the wait was the virtual
/// printer's alone, 2 min 52 s short on a sphere): it is the estimator's now, which all three
/// share, and `estimate` says the raster's total to the microsecond.
#[test]
fn sim_and_estimate_wait_after_each_fire_as_raster_counts_it() {
    let dir = tempfile::tempdir().unwrap();
    let gcode = dir.path().join("badge.gcode");
    let layers = root().join("examples/raster/layers");
    let args = ["raster", layers.to_str().unwrap(), "-o", gcode.to_str().unwrap()];
    // The badge's 8 layers: 7 recoats of 0.5 s on the binder jet, none on the bare printhead.
    for (machine, recoat_dwells_s) in [("inkjet-c6602", 0.0), ("binder-jet", 7.0 * 0.5)] {
        let out = gweave(&[&args[..], &["--machine", machine, "--json", "-q"]].concat());
        assert!(out.status.success(), "{}", text(&out.stderr));
        let raster: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let fires = raster["fire_commands"].as_f64().unwrap();
        assert_eq!(raster["time"]["fire_s"].as_f64().unwrap(), fires * 800.0 * 1e-6);
        let out = gweave(&["sim", gcode.to_str().unwrap(), "--machine", machine, "--json", "-q"]);
        let sim: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let t = &sim["time"];
        let sim_s = t["motion_s"].as_f64().unwrap() + t["dwell_s"].as_f64().unwrap();
        let raster_s = raster["time"]["total_s"].as_f64().unwrap();
        assert!((sim_s - raster_s).abs() < 1e-6, "{machine}: sim {sim_s} s, raster {raster_s} s");
        let dwell_s = t["dwell_s"].as_f64().unwrap();
        assert!((dwell_s - (recoat_dwells_s + fires * 800e-6)).abs() < 1e-9, "{machine}: {t}");
        let out = gweave(&["estimate", gcode.to_str().unwrap(), "--machine", machine, "--json"]);
        let estimate: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let estimate_s = estimate["total_s"].as_f64().unwrap();
        assert!(
            (estimate_s - raster_s).abs() < 1e-6,
            "{machine}: estimate {estimate_s} s, raster {raster_s} s"
        );
        assert_eq!(estimate["dwell_s"], t["dwell_s"], "{machine}");
    }
    // The summary says which motion the time was planned on.
    let out = gweave(&[&args[..], &["--machine", "binder-jet"]].concat());
    assert!(
        text(&out.stdout).contains("(planner, Binder jet, HP C6602, powder recoat: motion"),
        "{}",
        text(&out.stdout)
    );
}

/// A binder-jet user rasterised the badge and checked it on their machine: `sim --machine
/// binder-jet` warned on every layer ("fired during a recoat", "the spreader reached 20.132 ..
/// 29.657 mm, not across the bed"), since `raster` wrote the default recoat (an `M400`) and knew
/// nothing of the machine. `raster --machine binder-jet` writes for its printhead, recoat and
/// canvas: the virtual printer with the same machine finds every recoat whole.
#[test]
fn raster_for_the_binder_jet_machine_passes_its_recoat_checks() {
    let dir = tempfile::tempdir().unwrap();
    let layers = root().join("examples/raster/layers");
    let sim_warnings = |gcode: &Path| {
        let out = gweave(&["sim", gcode.to_str().unwrap(), "--machine", "binder-jet", "--json", "-q"]);
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let warnings = report["warnings"].as_array().unwrap().clone();
        (report, warnings)
    };
    let raster = |extra: &[&str], name: &str| {
        let out_file = dir.path().join(name);
        let mut args = vec!["raster", layers.to_str().unwrap(), "-o", out_file.to_str().unwrap(), "-q"];
        args.extend_from_slice(extra);
        let out = gweave(&args);
        assert!(out.status.success(), "{}", text(&out.stderr));
        out_file
    };

    // Without the machine: the default recoat, which this machine's checks refuse on each of
    // the 7 layers after the first (a fire during the recoat and a spreader short of the bed).
    let plain = raster(&[], "plain.gcode");
    let (_, warnings) = sim_warnings(&plain);
    assert_eq!(warnings.len(), 14, "{warnings:?}");

    let for_machine = raster(&["--machine", "binder-jet"], "machine.gcode");
    let gcode = std::fs::read_to_string(&for_machine).unwrap();
    // The profile's recoat before the second layer (0.1 mm layers from Z 0.1, powder ratio 1.5,
    // spreader on Y from 5 mm across 190 mm).
    let recoat = gcode.find("; gweave raster: recoat for layer 1\n").expect("the profile's recoat");
    let block: Vec<&str> = gcode[recoat..].lines().take(9).collect();
    assert_eq!(
        block[1..],
        [
            "M400",
            "G1 Z0.2 F120",
            "G1 A0.15",
            "G1 Y5 F3000",
            "G1 Y195 F300",
            "G1 Y5 F3000",
            "G4 P500",
            "G1 Z0.2"
        ]
    );
    let (report, warnings) = sim_warnings(&for_machine);
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(report["inkjet"]["layers"], 8, "{report}");

    // --head and --machine both name the printhead: one is refused.
    let head = root().join("examples/raster/c6602.toml");
    let both = gweave(&[
        "raster",
        layers.to_str().unwrap(),
        "-o",
        dir.path().join("both.gcode").to_str().unwrap(),
        "--machine",
        "binder-jet",
        "--head",
        head.to_str().unwrap(),
    ]);
    assert!(!both.status.success());
    // A machine without a printhead is refused with what to give instead.
    let fdm = gweave(&[
        "raster",
        layers.to_str().unwrap(),
        "-o",
        dir.path().join("fdm.gcode").to_str().unwrap(),
        "--machine",
        "prusa-mk3",
    ]);
    assert!(!fdm.status.success());
    assert!(text(&fdm.stderr).contains("has no inkjet printhead"), "{}", text(&fdm.stderr));
    assert!(!dir.path().join("fdm.gcode").exists());
}

/// `slice-raster` ends with the command to run next, but it left out the layer height: the
/// PNGs carry their pixel size and no layer height, so `raster` stacked the 52 layers of a
/// part sliced at 0.25 mm 0.1 mm apart (its default), and the part came out 5.2 mm tall
/// instead of 13. The suggested command now prints the part at its own height.
#[test]
fn slice_rasters_next_command_keeps_the_layer_height() {
    let dir = tempfile::tempdir().unwrap();
    let layers = dir.path().join("layers");
    let stl = root().join("crates/gweave/tests/data/raster/torus.stl");
    let out = gweave(&[
        "slice-raster",
        stl.to_str().unwrap(),
        "--layer-height",
        "0.25",
        "--dpi",
        "96",
        "-o",
        layers.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let said = text(&out.stdout);
    let next = said.lines().find_map(|l| l.trim().strip_prefix("next")).expect("a next command");
    let gcode = dir.path().join("part.gcode");
    let args: Vec<String> = next
        .split_whitespace()
        .skip(1) // `gweave`
        .map(|a| if a == "part.gcode" { gcode.to_str().unwrap().to_owned() } else { a.to_owned() })
        .chain(["-q".to_owned()])
        .collect();
    let run = gweave(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(run.status.success(), "{next}: {}", text(&run.stderr));
    // The stack's layers 0.25 mm apart: the last one at (layers - 1) x 0.25 mm above the first.
    let zs: Vec<f64> = std::fs::read_to_string(&gcode)
        .unwrap()
        .lines()
        .filter(|l| l.starts_with("G1") || l.starts_with("G0"))
        .flat_map(|l| l.split_whitespace().filter_map(|w| w.strip_prefix('Z')?.parse().ok()))
        .collect();
    let images = std::fs::read_dir(&layers).unwrap().count();
    let (low, high) = zs.iter().fold((f64::MAX, f64::MIN), |(a, b), &z| (a.min(z), b.max(z)));
    assert!(
        (high - low - (images - 1) as f64 * 0.25).abs() < 1e-6,
        "{next}: Z {low} .. {high}, {images} layers"
    );
}
