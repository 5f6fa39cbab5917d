//! Every settings file shipped with gweave (examples/, bench/) loads through its loader, and the
//! loaders refuse a mutated copy with a message naming the table, the key and the range.

use std::path::{Path, PathBuf};

use gweave::gen::printhead::PrintheadProfile;
use gweave::post::mix::profile::MixProfile;
use gweave::rotary::helix::TubeParams;
use gweave::rotary::wrap::WrapConfig;
use gweave_sim::MachineProfile;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn toml_files(dir: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(repo().join(dir))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no TOML in {dir}");
    files
}

/// Loads `file` with the loader of its folder; `Err` carries the loader's message.
fn load(file: &Path) -> Result<(), String> {
    let text = std::fs::read_to_string(file).unwrap();
    let dir = file.parent().unwrap().file_name().unwrap().to_str().unwrap();
    let name = file.file_name().unwrap().to_str().unwrap();
    match dir {
        // Files a profile names (a thermistor table) are the shipped ones, beside the examples.
        "machines" | "bench" => MachineProfile::from_toml_in(&text, &repo().join("examples/machines"))
            .map(drop)
            .map_err(|e| e.to_string()),
        "mix" => MixProfile::from_toml_str(&text).map(drop).map_err(|e| e.to_string()),
        "raster" => PrintheadProfile::from_toml(&text).map(drop).map_err(|e| e.to_string()),
        "rotary" if name.starts_with("wrap") => {
            WrapConfig::from_toml_str(&text).map(drop).map_err(|e| e.to_string())
        }
        "rotary" => TubeParams::from_toml_str(&text).map(drop).map_err(|e| e.to_string()),
        _ => panic!("no loader for {}", file.display()),
    }
}

fn all_files() -> Vec<PathBuf> {
    ["examples/machines", "bench", "examples/mix", "examples/raster", "examples/rotary"]
        .into_iter()
        .flat_map(toml_files)
        .collect()
}

#[test]
fn every_shipped_settings_file_loads() {
    for file in all_files() {
        load(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    }
}

/// Each numeric `key = value` line of every shipped file set to 1e308, -1, nan and inf: the
/// loader refuses it naming the key (or accepts it, for a value inside the range), never panics.
#[test]
fn every_numeric_key_of_every_file_is_bounded() {
    let copy = tempfile::tempdir().unwrap();
    for file in all_files() {
        let text = std::fs::read_to_string(&file).unwrap();
        for (i, line) in text.lines().enumerate() {
            let Some((key, value)) = line.split_once(" = ") else { continue };
            let value = value.split('#').next().unwrap().trim();
            if value.parse::<f64>().is_err() || key.starts_with('#') {
                continue;
            }
            for bad in ["1e308", "-1", "nan", "inf"] {
                let mut lines: Vec<&str> = text.lines().collect();
                let mutated = format!("{key} = {bad}");
                lines[i] = &mutated;
                let dir = copy.path().join(file.parent().unwrap().file_name().unwrap());
                std::fs::create_dir_all(&dir).unwrap();
                let path = dir.join(file.file_name().unwrap());
                std::fs::write(&path, lines.join("\n")).unwrap();
                match load(&path) {
                    Ok(()) => assert_eq!(bad, "-1", "{}: {mutated} accepted", file.display()),
                    Err(e) => {
                        let key = key.trim();
                        // An integer key given a float is a type error of the TOML reader.
                        let named =
                            ["out of range", "invalid type", "invalid value"].iter().any(|m| e.contains(m));
                        // The reader's errors point at the line (or, for a tagged table such as
                        // [motion.corners], at the table) rather than naming the key.
                        let located = e.contains(key) || e.contains("TOML parse error at line");
                        assert!(located && named, "{}: {mutated}: {e}", file.display());
                        let digits = e.split(|c: char| !c.is_ascii_digit()).map(str::len).max();
                        assert!(digits < Some(20), "{}: {mutated}: a long number in {e}", file.display());
                    }
                }
            }
        }
    }
}

/// `nozzle_temp_c = 1e308` used to write an `M109` with 309 digits.
#[test]
fn rotary_tube_nozzle_temp_1e308_is_refused() {
    let text = std::fs::read_to_string(repo().join("examples/rotary/tube.toml")).unwrap();
    let err = TubeParams::from_toml_str(&text.replace("nozzle_temp_c = 190.0", "nozzle_temp_c = 1e308"));
    assert_eq!(err.unwrap_err().to_string(), "[print] nozzle_temp_c = 1e308 is out of range: 0 to 500 °C");
}
