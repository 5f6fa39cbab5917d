//! The estimate of every fixture is the same to the bit as before the lexer and planner work of
//! issue 35 (line lengths handed over in the batch, rounding without branches, no copy of the
//! planner's settings per move): work that makes the readers and planners cheaper must not move
//! a single figure. `tests/data/estimate_golden.txt` holds what the build before it printed
//! (`gweave estimate FILE --json`), for Marlin junction deviation (the default machine), Marlin
//! classic jerk (`prusa-mk3`) and Klipper (the benchmark's profile).

use std::path::{Path, PathBuf};

use gweave_sim::{estimate_report, MachineProfile};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn machine(name: &str) -> MachineProfile {
    let path = match name {
        "default" => return MachineProfile::default(),
        "prusa-mk3" => root().join("examples/machines/prusa-mk3.toml"),
        "klipper" => root().join("bench/klipper-big-bed.toml"),
        other => panic!("no machine {other}"),
    };
    let text = std::fs::read_to_string(&path).unwrap();
    MachineProfile::from_toml_in(&text, path.parent().unwrap()).unwrap()
}

#[test]
fn every_fixtures_estimate_is_the_same_to_the_bit() {
    let golden =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/estimate_golden.txt"))
            .unwrap();
    let mut checked = 0;
    for line in golden.lines().filter(|l| !l.starts_with('#')) {
        let mut fields = line.split(' ');
        let (fixture, name) = (fields.next().unwrap(), fields.next().unwrap());
        let blocks: u64 = fields.next().unwrap().parse().unwrap();
        let figures: Vec<f64> = fields.map(|f| f.parse().unwrap()).collect();
        let path = root().join("tests/data").join(fixture);
        let firmware = gweave::gcode::flavour::read_firmware(&path, None).unwrap();
        let file = std::fs::File::open(&path).unwrap();
        let report = estimate_report(file, &machine(name), firmware, false).unwrap();
        let est = &report.estimate;
        let what = format!("{fixture} on {name}");
        assert_eq!(est.blocks as u64, blocks, "{what}: blocks");
        assert_eq!(
            est.total_s.to_bits(),
            figures[0].to_bits(),
            "{what}: total {} s, was {} s",
            est.total_s,
            figures[0]
        );
        let layers: Vec<u64> = est.layer_s.iter().map(|s| s.to_bits()).collect();
        let was: Vec<u64> = figures[1..].iter().map(|s| s.to_bits()).collect();
        assert_eq!(layers, was, "{what}: the layers' seconds");
        checked += 1;
    }
    assert_eq!(checked, 21, "seven fixtures, three machines");
}
