//! `stats` and `sim` read every file the same way (issue 27): as the firmware its flavour names
//! (`gweave::Firmware`). Over every fixture, the virtual printer ends where the modal
//! state `stats` reads with ends (X Y Z, the extrusion axis E and the rotary A), its moves have
//! fed the same filament, and it counts the same layers. A LinuxCNC file extrudes with A: read as Marlin,
//! the printer would move a rotary A and feed nothing.

#[path = "../../gweave/tests/one_nozzle/mod.rs"]
mod one_nozzle;

use std::path::{Path, PathBuf};
use std::process::Command;

use gweave::gcode::state::{A, E, X, Y, Z};
use gweave::{Ctx, Step};
use gweave::{Flow, Pass, Run, State};

fn json(args: &[&str]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_gweave")).args(args).output().unwrap();
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

/// Every G-code fixture: tests/data/<slicer>/*.gcode.
fn fixtures() -> Vec<PathBuf> {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
    let mut all: Vec<PathBuf> = std::fs::read_dir(&data)
        .unwrap()
        .flat_map(|dir| std::fs::read_dir(dir.unwrap().path()).into_iter().flatten())
        .map(|f| f.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "gcode"))
        .collect();
    all.sort();
    all
}

/// Filament the motor fed, mm, net: the moves' E and the firmware retractions (`G10`, `G11`),
/// as the printer's `filament_mm` counts it (which left the retractions out until a breaking
/// session found `pr_sphere_rrf_fwretract`'s last `G10` missing from it).
#[derive(Default)]
struct MotorFed(f64);

impl Pass for MotorFed {
    fn line(&mut self, ctx: &Ctx<'_>, _out: &mut dyn std::io::Write) -> Step {
        self.0 += ctx.effect.filament_mm();
        Ok(Flow::Continue)
    }
}

/// The modal state `stats` ends with, through the same driver (`Run`, which reads the file's
/// flavour) as `gweave stats`, and the filament its motor fed.
fn stats_state(path: &Path) -> (State, f64) {
    let mut fed = MotorFed::default();
    let state = Run::file(path).scan(&mut fed).unwrap();
    (state, fed.0)
}

/// The machine a fixture was sliced for, where the default one-hotend printer would refuse
/// its tools: a file that heats and prints only T1 and T2 (a three-hotend printer) feeds no
/// filament there, its nozzles cold.
fn machine_for(path: &Path) -> String {
    match path.file_name().and_then(|n| n.to_str()) {
        Some("pr_box_3tool_tower.gcode") => {
            let three =
                std::env::temp_dir().join(format!("gweave-three-hotends-{}.toml", std::process::id()));
            std::fs::write(&three, "[[thermal.hotends]]\n[[thermal.hotends]]\n[[thermal.hotends]]\n")
                .unwrap();
            three.to_str().unwrap().to_owned()
        }
        Some("pr_cyl_semm_tower.gcode") => "prusa-mk3-mmu".to_owned(),
        _ => "marlin-ramps".to_owned(),
    }
}

fn numbers(v: &serde_json::Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|n| n.as_f64().unwrap()).collect()
}

#[test]
fn stats_and_sim_read_every_fixture_the_same_way() {
    let fixtures = fixtures();
    assert!(fixtures.len() >= 8, "{fixtures:?}");
    let mut linuxcnc = 0;
    for path in &fixtures {
        let name = path.display();
        let p = path.to_str().unwrap();
        let stats = json(&["stats", p, "--json", "-q"]);
        let sim = json(&["sim", p, "--machine", &machine_for(path), "--json", "-q"]);
        let (state, stats_mm) = stats_state(path);
        linuxcnc += usize::from(state.options().firmware.extrusion_letter() == b'A');

        let layers = sim["layer_s"].as_array().unwrap().len();
        assert_eq!(stats["layers"].as_u64(), Some(layers as u64), "{name}: layers");

        // `M114`'s logical X Y Z E A at the end, as the state has them.
        let position = numbers(&sim["position"]);
        for (i, axis) in [X, Y, Z, E, A].into_iter().enumerate() {
            let (theirs, ours) = (position[i], state.pos[axis]);
            assert!((theirs - ours).abs() < 1e-3, "{name}: axis {i}: sim {theirs}, stats {ours}");
        }

        // The printer counts filament per extruder it has (one by default): compare totals.
        let sim_mm: f64 = numbers(&sim["filament_mm"]).iter().sum();
        assert!(stats_mm > 0.0, "{name}: no filament");
        assert!(
            (sim_mm - stats_mm).abs() < 1e-6 * stats_mm,
            "{name}: filament: sim {sim_mm}, stats {stats_mm}"
        );
    }
    assert_eq!(linuxcnc, 1, "the mach3 fixture is among them");
}

/// `sim` and `stats` gave two filament figures for one tool (T0 1428.03 against 1448.03 mm on
/// the Cura two-tool file) with no word why: the printer counts the motor's net feed, `stats`
/// what left the nozzle. The difference is what stayed retracted at the end, which `sim` now
/// reports per tool and shows beside the figure.
#[test]
fn sim_filament_plus_what_stayed_retracted_is_stats_figure_per_tool() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/cura/cura_dual.gcode");
    let p = data.to_str().unwrap();
    let stats = json(&["stats", p, "--json", "-q"]);
    let sim = json(&["sim", p, "--machine", "dual-extruder", "--json", "-q"]);
    let fed = numbers(&sim["filament_mm"]);
    let back = numbers(&sim["retracted_at_end_mm"]);
    let out: Vec<f64> =
        stats["filament"].as_array().unwrap().iter().map(|t| t["extruded_mm"].as_f64().unwrap()).collect();
    assert_eq!((fed.len(), back.len(), out.len()), (2, 2, 2));
    for t in 0..2 {
        assert!(
            (fed[t] + back[t] - out[t]).abs() < 1e-6 * out[t],
            "T{t}: {} + {} vs {}",
            fed[t],
            back[t],
            out[t]
        );
    }
    assert!((back[0] - 20.0).abs() < 1e-9 && (back[1] - 6.5).abs() < 1e-9, "{back:?}");
}

/// Issue 39 point 5: a PrusaSlicer single-extruder multi-material file (two filaments, one
/// nozzle, a wipe tower) put everything on T0 with `--machine prusa-mk3` (43 `invalid_extruder`
/// warnings) and was refused as cold extrusion with `--machine dual-extruder` (the file heats
/// one nozzle). The built-in `prusa-mk3-mmu` feeds five tools through one hotend: no tool is
/// refused, nothing is cold, and each tool's filament is `stats`' own.
#[test]
fn a_single_nozzle_machine_runs_a_semm_file_with_stats_filament_per_tool() {
    let data =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/prusaslicer/pr_cyl_semm_tower.gcode");
    let p = data.to_str().unwrap();
    let stats = json(&["stats", p, "--json", "-q"]);
    let sim = json(&["sim", p, "--machine", "prusa-mk3-mmu", "--json", "-q"]);
    let fed = numbers(&sim["filament_mm"]);
    let back = numbers(&sim["retracted_at_end_mm"]);
    let out: Vec<f64> =
        stats["filament"].as_array().unwrap().iter().map(|t| t["extruded_mm"].as_f64().unwrap()).collect();
    let mm = |v: f64| format!("{v:.2}");
    let left: Vec<String> = fed.iter().zip(&back).map(|(f, b)| mm(f + b)).collect();
    assert_eq!(left, ["4524.35", "4053.18"]);
    assert_eq!(out.iter().map(|&v| mm(v)).collect::<Vec<_>>(), left);
    // The only warnings: the file was sliced for RepRapFirmware (`gcode_flavor = reprap`), and
    // its wipe tower switches pressure advance off with RepRapFirmware's `M572`, which the
    // MK3S's firmware does not have (a file sliced for it writes `M900`).
    let counts = sim["warning_counts"].as_object().unwrap();
    assert_eq!(counts.keys().collect::<Vec<_>>(), ["unknown_command"], "{counts:?}");
    assert_eq!(sim["unknown_commands"]["M572"].as_u64(), Some(85), "{}", sim["unknown_commands"]);
    let heaters: Vec<String> =
        sim["heaters"].as_array().unwrap().iter().map(|h| h["heater"].to_string()).collect();
    assert_eq!(heaters, [r#"{"hotend":0}"#, r#""bed""#], "one hotend");
}

/// The purge-shift bug found on a screw sliced for two extruders (here as for one nozzle shared
/// by both, which purge-shift is for: the `one_nozzle` module): a moved change left the old
/// tool's 10 mm tool-change retraction to the new tool, so the virtual printer ran T0 to -68.91
/// mm and T1 to 700.25 mm (355.12 / 276.22 in the input) while `stats` said the rewritten
/// figures matched. On the screw's first 7 layers, relative and absolute E: each tool feeds what
/// it fed in the input but for the moved purge (8.24 mm from T1 to T0), ends with the
/// retraction it had, and the output's own figures are what left each nozzle.
#[test]
fn tool_change_retraction_stays_with_its_tool_in_the_virtual_printer() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["pr_screw_2t_trim.gcode", "pr_screw_2t_abs_trim.gcode"] {
        let input = one_nozzle::one_nozzle_in(dir.path(), &format!("prusaslicer/{name}"));
        let out = dir.path().join(format!("shifted_{name}"));
        let (i, o) = (input.to_str().unwrap(), out.to_str().unwrap());
        let shift = json(&["purge-shift", i, "--purge-mm", "3", "-o", o, "--json", "-q"]);
        let moved_mm = shift["moved_mm"].as_f64().unwrap();
        assert!((moved_mm - 8.24027).abs() < 1e-4, "{name}: {moved_mm}");
        let before = json(&["sim", i, "--machine", "dual-extruder", "--json", "-q"]);
        let after = json(&["sim", o, "--machine", "dual-extruder", "--json", "-q"]);
        let (fed_in, fed_out) = (numbers(&before["filament_mm"]), numbers(&after["filament_mm"]));
        let back = numbers(&after["retracted_at_end_mm"]);
        assert_eq!(numbers(&before["retracted_at_end_mm"]), back, "{name}");
        assert!((back[0] - 10.0).abs() < 1e-9 && back[1] == 0.0, "{name}: {back:?}");
        let want = [fed_in[0] + moved_mm, fed_in[1] - moved_mm];
        for t in 0..2 {
            assert!((fed_out[t] - want[t]).abs() < 1e-4, "{name} T{t}: {fed_out:?} vs {want:?}");
        }
        // 40.43 mm fed by T0 in the input (and 10 mm retracted), 45.65 by T1.
        assert!(
            (fed_out[0] - 48.668).abs() < 2e-3 && (fed_out[1] - 37.413).abs() < 2e-3,
            "{name}: {fed_out:?}"
        );
        // The same steps on every motor (E: the same filament fed), and the input's motion time
        // but for the splits' extra junctions (89.497 s -> 89.518 s): the moved retraction and
        // unretraction are taken out where the change was, not made twice.
        assert_eq!(numbers(&after["count"]), numbers(&before["count"]), "{name}");
        let motion_s = |r: &serde_json::Value| r["time"]["motion_s"].as_f64().unwrap();
        let extra_s = motion_s(&after) - motion_s(&before);
        assert!((0.0..0.05).contains(&extra_s), "{name}: {} s -> {} s", motion_s(&before), motion_s(&after));
        let stats = json(&["stats", o, "--json", "-q"]);
        assert_eq!(stats["filament_matches_slicer"], serde_json::Value::Bool(true), "{name}");
        let left: Vec<f64> = stats["filament"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| t["extruded_mm"].as_f64().unwrap())
            .collect();
        for t in 0..2 {
            assert!((left[t] - (fed_out[t] + back[t])).abs() < 1e-6, "{name} T{t}: {left:?}");
        }
    }
}
