//! `gweave mix` on real slicer files. Each output is parsed again with the core and checked:
//! every model move (one that moves XYZ) keeps its end point and its extrusion, in order, outside
//! the inserted purge blocks; every virtual tool is defined (M163/M164 or M567) before `T<n>`
//! selects it; the E position is the same after each purge block as before it, and the block fed
//! exactly its purge length and the retraction it refilled; the one nozzle is never retracted at
//! the first extrusion after a change of mix (the slicer unretracts only the tool it retracted); no move runs Z faster than the cap; every input line not
//! deliberately rewritten is in the output byte for byte; and the mix in force at each extrusion
//! is the one the schedule or tool map asks for.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use gweave::gcode::lexer::parse_into;
use gweave::gcode::retraction::Retraction;
use gweave::gcode::state::{E, X, Y, Z};
use gweave::post::mix::mix_bytes;
use gweave::post::mix::profile::MixProfile;
use gweave::post::mix::report::MixReport;
use gweave::post::zcap::z_feed_mm_min;
use gweave::{mix, Block, Effect, MixCommands, State};

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(rel)
}

fn examples(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/mix").join(rel)
}

/// A move as the core sees it: end point and filament.
#[derive(Debug, Clone, Copy)]
struct Mv {
    to: [f64; 3],
    e_mm: f64,
    line: usize,
}

fn moves_xyz(text: &str, skip_purges: bool) -> Vec<Mv> {
    let mut state = State::default();
    let mut block = Block::default();
    let mut out = Vec::new();
    let mut in_purge = false;
    for (i, l) in text.lines().enumerate() {
        if l.starts_with("; gweave mix: purge") {
            in_purge = true;
        }
        parse_into(l.as_bytes(), &mut block);
        if let Effect::Move(m) = state.apply(l.as_bytes(), &block) {
            let moves_xyz = (0..3).any(|a| m.from[a] != m.to[a]);
            if moves_xyz && !(skip_purges && in_purge) {
                out.push(Mv { to: [m.to[X], m.to[Y], m.to[Z]], e_mm: m.e_mm(), line: i + 1 });
            }
        }
        if l.starts_with("; gweave mix: end purge") {
            in_purge = false;
        }
    }
    out
}

/// What the output says, checked line by line.
struct Checked {
    report: MixReport,
    /// Per layer (0-based) the ratios in force at its extrusions (all distinct sets, in order).
    ratios_by_layer: BTreeMap<u32, Vec<Vec<f64>>>,
    purges: usize,
}

fn run(rel: &str, profile: MixProfile) -> Checked {
    let input = std::fs::read(data(rel)).unwrap();
    let cap = profile.z_cap.max_z_feed_mm_min;
    let keep = profile.tool_change.keep_slicer_retractions;
    let purge_on = profile.purge.mode != gweave::post::mix::profile::PurgeMode::Off;
    let (out, report) = mix_bytes(profile, &input).unwrap();
    let (input, out) = (String::from_utf8(input).unwrap(), String::from_utf8(out).unwrap());

    // Model moves: same end points and extrusion, in order. The Z cap adds Z-only moves (at
    // most the cap) in front of split travels; those are skipped.
    let (a, b) = (moves_xyz(&input, false), moves_xyz(&out, true));
    let same =
        |p: &Mv, q: &Mv| (0..3).all(|k| (p.to[k] - q.to[k]).abs() < 1e-9) && (p.e_mm - q.e_mm).abs() < 1e-4;
    let mut j = 0;
    for p in &a {
        while j < b.len() && !same(p, &b[j]) {
            assert!(
                j + 1 < b.len() && same(p, &b[j + 1]),
                "input line {} vs output line {}",
                p.line,
                b[j].line
            );
            j += 1;
        }
        assert!(j < b.len(), "input line {} missing from the output", p.line);
        j += 1;
    }
    assert_eq!(j, b.len(), "extra moves in the output");

    // Line by line through the output.
    let mut state = State::default();
    let mut block = Block::default();
    let mut collector = [0.0f64; 8];
    let mut tools: BTreeMap<u32, Vec<f64>> = BTreeMap::new();
    let mut active: Option<Vec<f64>> = None;
    let mut ratios_by_layer: BTreeMap<u32, Vec<Vec<f64>>> = BTreeMap::new();
    let mut purge_start: Option<([f64; 4], f64, f64, f64)> = None;
    let mut purges = 0;
    let mut nozzle = Retraction::default();
    let mut changed = false;
    for l in out.lines() {
        parse_into(l.as_bytes(), &mut block);
        let effect = *state.apply(l.as_bytes(), &block);
        let retracted_mm = nozzle.in_force_mm();
        nozzle.follow(&effect);
        let fed = state.filament_mm.iter().sum::<f64>();
        let word = |c: u8| block.get(c).unwrap();
        if block.command.is_m(163) {
            collector[word(b'S') as usize] = word(b'P');
        } else if block.command.is_m(164) {
            tools.insert(word(b'S') as u32, collector[..4].to_vec());
        } else if block.command.is_m(165) {
            active = Some(vec![word(b'A'), word(b'B'), word(b'C'), word(b'D')]);
        } else if block.command.is_m(567) {
            let e = l.split_once(" E").unwrap().1;
            let r: Vec<f64> = e.split(':').map(|v| v.parse().unwrap()).collect();
            assert!((r.iter().sum::<f64>() - 1.0).abs() < 1e-12, "RRF ratios must sum to 1: {l}");
            tools.insert(word(b'P') as u32, r);
        } else if let Some(t) = block.command.tool() {
            assert!(report.dialect.uses_tools(), "a T line with direct mixing: {l}");
            active = Some(tools.get(&t).unwrap_or_else(|| panic!("T{t} used before it was defined")).clone());
        }
        if let Effect::Move(m) = effect {
            if changed && m.is_extruding() {
                assert!(
                    retracted_mm < 1e-6,
                    "{retracted_mm} mm retracted at the first extrusion after a change: {l}"
                );
                changed = false;
            }
            let z = z_feed_mm_min(&m);
            assert!(z <= cap * (1.0 + 1e-9), "Z at {z} mm/min > {cap}: {l}");
            if m.is_extruding() && state.structure.region == gweave::gcode::layers::Region::Print {
                let r = active.clone().expect("an extrusion before any mix was selected");
                let layer = state.structure.layer.unwrap();
                let seen = ratios_by_layer.entry(layer).or_default();
                if seen.last() != Some(&r) {
                    seen.push(r);
                }
            }
        }
        if l.starts_with("; gweave mix: purge") {
            let pos = [state.pos[X], state.pos[Y], state.pos[Z], state.pos[E]];
            purge_start = Some((pos, fed, state.feed_mm_min, nozzle.in_force_mm()));
        }
        if l.starts_with("; gweave mix: end ") {
            changed = true;
        }
        if l.starts_with("; gweave mix: end purge") {
            let (pos, fed0, feed0, retracted0_mm) = purge_start.take().unwrap();
            let refilled_mm = retracted0_mm - nozzle.in_force_mm();
            let now = [state.pos[X], state.pos[Y], state.pos[Z], state.pos[E]];
            for k in 0..4 {
                assert!((pos[k] - now[k]).abs() < 1e-5, "purge moved axis {k}: {pos:?} -> {now:?}");
            }
            assert!((fed - fed0 - 25.0 - refilled_mm).abs() < 1e-6, "the purge fed {} mm", fed - fed0);
            assert_eq!(state.feed_mm_min, feed0);
            purges += 1;
        }
    }
    assert_eq!(purges as u32, report.purge.count);
    assert!(purges as u32 <= report.changes);
    if !purge_on {
        assert_eq!(purges, 0);
    }

    // Untouched lines: the input is a subsequence of the output except for rewritten lines.
    let outl: Vec<&str> = out.lines().collect();
    let mut k = 0;
    let mut rewritten = 0u64;
    // Lines the pass writes of its own; only these may stand between two input lines.
    let inserted = |o: &str| {
        ["; gweave", ";T", ";G", "M16", "M56", "T", "G92 E", "G0 ", "G1 ", "; ", "M568", ";M104", ";M109"]
            .iter()
            .any(|p| o.starts_with(p))
            || o.contains("; gweave mix: the mixing hotend, for the slicer's T")
    };
    for l in input.lines() {
        let t = l.trim_start();
        let found = if t.starts_with('T') {
            None
        } else {
            let mut found = None;
            for (d, o) in outl[k..].iter().enumerate() {
                if *o == l {
                    found = Some(d);
                    break;
                }
                if !inserted(o) {
                    break;
                }
            }
            found
        };
        match found {
            Some(d) => k += d + 1,
            None => {
                // A slicer tool's temperature: for the one nozzle, or a comment.
                let tool_heat = (t.starts_with("M104") || t.starts_with("M109")) && t.contains(" T");
                assert!(
                    t.starts_with('T') || t.starts_with("G0") || t.starts_with("G1") || tool_heat,
                    "changed: {l}"
                );
                rewritten += 1;
            }
        }
    }
    let t_lines = input.lines().filter(|l| l.starts_with('T')).count() as u64;
    let dropped = if keep { 0 } else { report.dropped_retractions };
    assert_eq!(rewritten, report.z_capped_lines + t_lines + dropped + report.tool_temperatures);
    Checked { report, ratios_by_layer, purges }
}

fn profile(name: &str) -> MixProfile {
    MixProfile::from_toml_str(&std::fs::read_to_string(examples(name)).unwrap()).unwrap()
}

const ORANGE: [f64; 4] = [0.0, 0.1717, 0.8283, 0.0];
const PINK: [f64; 4] = [0.0, 0.6, 0.1, 0.3];
const BLUE: [f64; 4] = [0.5, 0.5, 0.0, 0.0];

#[test]
fn cura_torus_with_the_seeds_layer_schedule() {
    let c = run("cura/cura_torus.gcode", profile("seed_layers.toml"));
    assert_eq!(c.ratios_by_layer.len(), 28);
    for (layer, ratios) in &c.ratios_by_layer {
        let want = if (10..25).contains(layer) { PINK } else { ORANGE };
        assert_eq!(ratios, &[want.to_vec()], "layer {layer}");
    }
    // Orange -> Pink at 10, Pink -> Orange at 25; Blue (from 75) is past the 28 layers.
    assert_eq!((c.report.changes, c.purges), (2, 2));
    let names: Vec<&str> = c.report.mixes.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["Orange", "Pink", "Blue"]);
    assert_eq!(c.report.mixes[0].layers, [[0, 9], [25, 27]]);
    assert_eq!(c.report.mixes[1].layers, [[10, 24]]);
    assert!(c.report.mixes[2].layers.is_empty());
    assert_eq!(c.report.mixes[0].ratios, ORANGE);
    assert_eq!(c.report.mixes[2].ratios, BLUE);
    // Purges: 2 x 25 mm of Orange then Pink... by the new mix's ratios.
    assert!((c.report.purge.filament_mm - 50.0).abs() < 1e-9);
    let p = &c.report.purge.per_input_mm;
    assert!((p[1] - 25.0 * (0.6 + 0.1717)).abs() < 1e-9 && (p[3] - 7.5).abs() < 1e-9, "{p:?}");
    // The preview colours: layer 10 is Pink's predicted colour.
    let colours = c.report.layer_colours();
    assert_eq!(colours[10].1.to_hex(), c.report.mixes[1].predicted);
}

#[test]
fn cura_torus_with_a_gradient_over_more_steps_than_tools() {
    let c = run("cura/cura_torus.gcode", profile("gradient.toml"));
    // Cyan at layer 0 to Magenta at layer 27, one step per layer: 28 mixes on 16 tools.
    for (layer, ratios) in &c.ratios_by_layer {
        let t = f64::from(*layer) / 27.0;
        let r = &ratios[0];
        assert_eq!(ratios.len(), 1);
        assert!((r[0] - (1.0 - t)).abs() <= 5e-5 && (r[1] - t).abs() <= 5e-5, "layer {layer}: {r:?}");
    }
    assert_eq!(c.report.changes, 27);
    assert_eq!(c.purges, 0, "gradient steps are not purged");
    assert_eq!(c.report.mixes.len(), 28);
    // Steps alternate on the last two tools.
    let tools: Vec<Option<u32>> = c.report.mixes.iter().map(|m| m.tool).collect();
    assert_eq!(tools[..4], [Some(0), Some(1), Some(14), Some(15)]);
}

#[test]
fn cura_dual_with_a_tool_map() {
    let mut p = profile("tool_map.toml");
    p.hardware.dialect = Some(MixCommands::RepRapFirmware);
    let c = run("cura/cura_dual.gcode", p);
    let m = &c.report.mixes;
    assert_eq!((m[0].name.as_str(), m[1].name.as_str()), ("Orange", "#2060c0"));
    // A deep blue is just outside what cyan and magenta pigments make (dE 10.0 with the
    // pigment model): the nearest mix is found and flagged.
    let de = m[1].delta_e.unwrap();
    assert!(de < 12.0 && m[1].out_of_gamut, "dE {de}");
    // 78 T lines: T0 in the start G-code, then each change.
    assert_eq!(c.report.changes, 77);
    assert_eq!(c.purges, 77);
}

#[test]
fn slic3r_cone_with_a_tool_map_and_direct_mixing() {
    let mut p = profile("tool_map.toml");
    p.hardware.dialect = Some(MixCommands::MarlinDirect);
    let c = run("slic3r/slic3r_cone_2tool.gcode", p);
    assert_eq!(c.report.changes, 108);
}

#[test]
fn prusa_bunny_relative_e_with_three_tools_and_dropped_retractions() {
    let mut p = profile("tool_map.toml");
    p.add_map("T2=Yellow").unwrap();
    p.tool_change.keep_slicer_retractions = false;
    let c = run("prusaslicer/pr_bunny_3tool_rel.gcode", p);
    assert_eq!(c.report.changes, 793);
    // Every change of tool retracted 10 mm before and unretracted 10 mm when the tool came back.
    assert!(c.report.dropped_retractions > 1000, "{}", c.report.dropped_retractions);
}

#[test]
fn prusa_torus_with_soluble_support() {
    let c = run("prusaslicer/pr_torus_pva.gcode", profile("pva_support.toml"));
    assert_eq!(c.report.changes, 2);
    let pva = c.report.mixes.iter().find(|m| m.name == "PVA").unwrap();
    assert_eq!(pva.ratios, [0.0, 0.0, 0.0, 1.0]);
    let support_layers: Vec<u32> = pva.layers.iter().flat_map(|r| r[0]..=r[1]).collect();
    for l in &support_layers {
        assert!(c.ratios_by_layer[l].contains(&vec![0.0, 0.0, 0.0, 1.0]));
    }
    assert!(!support_layers.is_empty());
    // The part: Orange with 20 % material 2 is Orange's pigments scaled by 0.8.
    let part = &c.report.mixes[0];
    assert_eq!(part.ratios, [0.0, 0.1374, 0.6626, 0.2]);
}

#[test]
fn golden_small_case() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mix");
    let profile =
        MixProfile::from_toml_str(&std::fs::read_to_string(dir.join("small.toml")).unwrap()).unwrap();
    let input = std::fs::read(dir.join("small.gcode")).unwrap();
    let (out, _) = mix_bytes(profile.clone(), &input).unwrap();
    let golden = dir.join("small.expected.gcode");
    if std::env::var_os("GWEAVE_BLESS").is_some() {
        std::fs::write(&golden, &out).unwrap();
    }
    assert_eq!(String::from_utf8(out).unwrap(), std::fs::read_to_string(&golden).unwrap());
    // The streaming file path gives the same bytes.
    let tmp = tempfile::tempdir().unwrap();
    let dest = tmp.path().join("out.gcode");
    let target = gweave::Target::File(dest.clone());
    mix(profile, gweave::Run::file(&dir.join("small.gcode")).to(&target)).unwrap();
    assert_eq!(std::fs::read(dest).unwrap(), std::fs::read(golden).unwrap());
}

/// A profile that names no dialect follows the file: PrusaSlicer's RepRapFirmware flavour says
/// so only in its settings block at the very end, yet gets `M563`/`M567` from the first line of
/// the print; a Marlin file keeps `M163`/`M164`; a dialect in the profile wins over the file.
#[test]
fn the_files_flavour_chooses_the_dialect_a_profile_leaves_unset() {
    let job = "[[schedule]]\nlayer = 0\nmix = \"Orange\"\n[[schedule]]\nlayer = 50\nmix = \"Blue\"\n";
    let sphere = "prusaslicer/pr_sphere_rrf_fwretract.gcode";
    let c = run(sphere, MixProfile::from_toml_str(job).unwrap());
    assert_eq!(
        (c.report.dialect, c.report.flavour.as_deref()),
        (MixCommands::RepRapFirmware, Some("reprapfirmware"))
    );
    // The ratios in force were read back from the M567 lines.
    assert_eq!(
        (c.ratios_by_layer[&49].as_slice(), c.ratios_by_layer[&50].as_slice()),
        (&[ORANGE.to_vec()][..], &[BLUE.to_vec()][..])
    );
    assert_eq!(c.report.changes, 1);

    let c = run("prusaslicer/pr_torus_pva.gcode", MixProfile::from_toml_str(job).unwrap());
    assert_eq!((c.report.dialect, c.report.flavour.as_deref()), (MixCommands::Marlin, Some("marlin2")));
    let c =
        run(sphere, MixProfile::from_toml_str(&format!("[hardware]\ndialect = \"marlin\"\n{job}")).unwrap());
    assert_eq!(c.report.dialect, MixCommands::Marlin);
}

/// Regression, `mix --map` on a wipe-tower file (breaking session 21): PrusaSlicer's tower
/// primes each tool before layer 0, in the start G-code's region, where the pass ignored
/// `T<n>`; layer 0 then ran on the first primed tool's mix. A small PrusaSlicer-like file:
/// the priming selects T1 then T0, layer 0 starts on T0 and changes to T1.
#[test]
fn mix_map_follows_the_tool_changes_of_a_wipe_towers_priming() {
    let input = "; generated by PrusaSlicer 2.5.0\nM83\n;TYPE:Wipe tower\n; CP PRIMING START\nT1\nG1 X10 E1 F1800\nT0\nG1 X20 E2\n\
                 ; CP PRIMING END\n;LAYER_CHANGE\n;Z:0.2\nG1 Z0.2\nG1 X30 E4\nT1\nG1 X40 E8\n";
    let mut p = MixProfile::default();
    p.add_map("T0=Cyan").unwrap();
    p.add_map("T1=Yellow").unwrap();
    p.purge.mode = gweave::post::mix::profile::PurgeMode::Off;
    let (out, report) = mix_bytes(p, input.as_bytes()).unwrap();
    let text = String::from_utf8(out).unwrap();
    let tool_of = |name: &str| report.mixes.iter().find(|m| m.name == name).unwrap().tool.unwrap();
    let (cyan, yellow) = (format!("T{}", tool_of("Cyan")), format!("T{}", tool_of("Yellow")));
    // The virtual tool selected before each extrusion.
    let mut selected = "";
    let mut runs_on = Vec::new();
    for l in text.lines() {
        if l.starts_with('T') {
            selected = l;
        } else if l.starts_with("G1 X") {
            runs_on.push(selected);
        }
    }
    assert_eq!(runs_on, [&yellow, &cyan, &cyan, &yellow], "{text}");
    let mm: Vec<f64> = report.mixes.iter().map(|m| m.filament_mm).collect();
    assert_eq!((report.mixes[0].name.as_str(), mm.as_slice(), report.changes), ("Cyan", &[6.0, 9.0][..], 2));
}

/// Each extruding move of `text` (every region, the start G-code's too) with what selects its
/// filament: the slicer's tool (`T<n>` lines) or, in mixed output, the ratios in force (read
/// back from `M163`/`M164` and `T<n>`), and the net filament each tool moved, mm.
struct Extrusions {
    by_tool: Vec<(u32, usize)>,
    by_ratios: Vec<(Vec<f64>, usize)>,
    net_mm: BTreeMap<u32, f64>,
}

fn extrusions(text: &str) -> Extrusions {
    let (mut state, mut block) = (State::default(), Block::default());
    let mut collector = [0.0f64; 4];
    let mut defined: BTreeMap<u32, Vec<f64>> = BTreeMap::new();
    let (mut tool, mut ratios) = (0, Vec::new());
    let mut x = Extrusions { by_tool: Vec::new(), by_ratios: Vec::new(), net_mm: BTreeMap::new() };
    for (i, l) in text.lines().enumerate() {
        parse_into(l.as_bytes(), &mut block);
        let effect = *state.apply(l.as_bytes(), &block);
        let word = |c: u8| block.get(c).unwrap();
        if block.command.is_m(163) {
            collector[word(b'S') as usize] = word(b'P');
        } else if block.command.is_m(164) {
            defined.insert(word(b'S') as u32, collector.to_vec());
        } else if let Some(t) = block.command.tool() {
            tool = t;
            ratios = defined.get(&t).cloned().unwrap_or_default();
        }
        if let Effect::Move(m) = effect {
            *x.net_mm.entry(tool).or_default() += m.e_mm();
            if m.is_extruding() {
                x.by_tool.push((tool, i + 1));
                x.by_ratios.push((ratios.clone(), i + 1));
            }
        }
    }
    x
}

/// Regression, `mix --map` on a wipe-tower file (breaking session 21): PrusaSlicer's tower
/// primes every tool before layer 0 (`; CP PRIMING START`, still the start G-code's region) and
/// mix ignored the `T<n>` lines there. The box primes T2 then T1, so T1's priming and layer 0
/// up to the next tool change ran on T2's mix (and on PrusaSlicer's 2-tool disk, 39 extrusions
/// of layer 0), while the report and `stats` counted that filament to the wrong mix. Now every
/// extrusion runs on its slicer tool's mix, and the filament per mix and per input is the
/// input's per tool, mapped.
#[test]
fn mix_map_selects_the_mix_of_each_tool_a_wipe_tower_primes() {
    let rel = "prusaslicer/pr_box_3tool_tower.gcode";
    let toml = "[purge]\nmode = \"off\"\n[map]\nT0 = \"Magenta\"\nT1 = \"Cyan\"\nT2 = \"Yellow\"\n";
    let c = run(rel, MixProfile::from_toml_str(toml).unwrap());
    let input = std::fs::read_to_string(data(rel)).unwrap();
    let (out, report) = mix_bytes(MixProfile::from_toml_str(toml).unwrap(), input.as_bytes()).unwrap();
    assert_eq!(report.changes, c.report.changes);
    let out = String::from_utf8(out).unwrap();
    let mix_of = |tool: u32| {
        let name = ["Magenta", "Cyan", "Yellow"][tool as usize];
        report.mixes.iter().find(|m| m.name == name).unwrap()
    };
    let (a, b) = (extrusions(&input), extrusions(&out));
    assert_eq!(a.by_tool.len(), b.by_ratios.len());
    let wrong: Vec<String> = a
        .by_tool
        .iter()
        .zip(&b.by_ratios)
        .filter(|((t, _), (r, _))| *r != mix_of(*t).ratios)
        .map(|((t, i), (r, o))| format!("input line {i} (T{t}) -> output line {o} runs {r:?}"))
        .collect();
    assert!(wrong.is_empty(), "{} extrusions on the wrong mix, first {:?}", wrong.len(), wrong.first());
    // The priming's T1 was the input's second extrusion block: it runs on Cyan.
    let first_t1 = a.by_tool.iter().position(|(t, _)| *t == 1).unwrap();
    assert_eq!(b.by_ratios[first_t1].0, [1.0, 0.0, 0.0, 0.0]);
    // 43 `T<n>` lines: the first (T2, the priming's) selects the first mix, the 42 others
    // change it (41 before, the priming's T1 lost).
    assert_eq!(report.changes, 42);

    // The filament per mix and per input is the input's per tool, mapped.
    for (t, mm) in &a.net_mm {
        assert!((mix_of(*t).filament_mm - mm).abs() < 1e-6, "T{t}: {} vs {mm}", mix_of(*t).filament_mm);
    }
    for k in 0..4 {
        let want: f64 = a.net_mm.iter().map(|(t, mm)| mm * mix_of(*t).ratios[k]).sum();
        assert!((report.filament_per_input_mm[k] - want).abs() < 1e-6, "input {k}");
    }
    // `stats` of the output counts each virtual tool what the input's slicer tool extruded.
    let tmp = tempfile::tempdir().unwrap();
    let mixed = tmp.path().join("mixed.gcode");
    std::fs::write(&mixed, &out).unwrap();
    let stats = |p: &Path| {
        let mut quiet = gweave::Quiet;
        gweave::stats_file(p, None, gweave::Strictness::Strict, &mut quiet).unwrap().report
    };
    let (before, after) = (stats(&data(rel)), stats(&mixed));
    for f in &before.filament {
        let tool = mix_of(f.tool).tool.unwrap();
        let g = after.filament.iter().find(|g| g.tool == tool).map_or(0.0, |g| g.extruded_mm);
        assert!((g - f.extruded_mm).abs() < 1e-6, "T{} {} mm, mixed T{tool} {g} mm", f.tool, f.extruded_mm);
    }
}

/// Regression (a new user's trial): `mix --map T0=Red --map T1=Blue` of the two-tool cone
/// reported Red 494.5 mm where `stats` says T0 506.51 mm, a difference docs/mix.md did not
/// explain. The report's figure is the net E of every move made with the mix (retractions
/// negative); `stats` counts what leaves the nozzle, where a retraction and its prime cancel
/// and a retraction nothing undoes counts nothing. They differ by exactly the retractions
/// never undone: T0's 10 mm tool-change retraction at the first change (PrusaSlicer's
/// `retract_length_toolchange`: T1, a nozzle of its own to the slicer, starts without undoing
/// it) and its 2 mm retraction at the end (`retract_length`). On the one nozzle the first
/// purge into Blue refills those 10 mm
/// (`mix_left_the_one_nozzle_retracted_at_a_first_change_to_a_new_tool`), so Blue's mix
/// counts them: 10 mm over `stats`'s T1.
#[test]
fn mix_report_t0_12_mm_under_stats_is_the_retractions_never_undone() {
    let rel = "prusaslicer/pr_cone_2tool.gcode";
    let toml = "[map]\nT0 = \"Red\"\nT1 = \"Blue\"\n";
    let input = std::fs::read(data(rel)).unwrap();
    let (out, report) = mix_bytes(MixProfile::from_toml_str(toml).unwrap(), &input).unwrap();
    let mix_mm = |name: &str| report.mixes.iter().find(|m| m.name == name).unwrap().filament_mm;
    let mut quiet = gweave::Quiet;
    let stats = gweave::stats_file(&data(rel), None, gweave::Strictness::Strict, &mut quiet).unwrap().report;
    let stats_mm = |tool: u32| stats.filament.iter().find(|f| f.tool == tool).unwrap().extruded_mm;
    // The slicer's own figures (`; filament used [mm] = 506.51, 577.33`), to its rounding.
    assert!((stats_mm(0) - 506.51).abs() < 0.005 && (stats_mm(1) - 577.33).abs() < 0.005);
    let (toolchange_mm, end_mm) = (10.0, 2.0);
    assert!((mix_mm("Red") - (stats_mm(0) - toolchange_mm - end_mm)).abs() < 1e-6, "Red {}", mix_mm("Red"));
    assert!((mix_mm("Blue") - (stats_mm(1) + toolchange_mm)).abs() < 1e-6, "Blue {}", mix_mm("Blue"));
    // Purges are counted apart: 76 changes of the default 25 mm.
    assert_eq!((report.changes, report.purge.count), (76, 76));
    assert!((report.purge.filament_mm - 1900.0).abs() < 1e-6);
    // `stats` of the output, per virtual tool (it follows each tool's retraction apart):
    // printed plus 38 purges of 25 mm; Red's tool refills its own 10 mm with its first purge,
    // and Blue's first purge pushes 10 mm more, the nozzle's refill.
    let tmp = tempfile::tempdir().unwrap();
    let mixed = tmp.path().join("mixed.gcode");
    std::fs::write(&mixed, &out).unwrap();
    let after = gweave::stats_file(&mixed, None, gweave::Strictness::Strict, &mut quiet).unwrap().report;
    let tool_of = |name: &str| report.mixes.iter().find(|m| m.name == name).unwrap().tool.unwrap();
    let after_mm = |tool: u32| after.filament.iter().find(|f| f.tool == tool).unwrap().extruded_mm;
    assert!((after_mm(tool_of("Red")) - (stats_mm(0) + 950.0 - toolchange_mm)).abs() < 1e-6);
    let blue = after_mm(tool_of("Blue"));
    assert!((blue - (stats_mm(1) + 950.0 + toolchange_mm)).abs() < 1e-6, "Blue's tool {blue}");
}

/// The filament the one nozzle holds back at the first extrusion after line `after` of
/// `text` (1-based): the retraction in force, mm.
fn retracted_at_first_extrusion_after(text: &str, after: usize) -> f64 {
    let (mut state, mut block, mut nozzle) = (State::default(), Block::default(), Retraction::default());
    for (i, l) in text.lines().enumerate() {
        parse_into(l.as_bytes(), &mut block);
        let effect = *state.apply(l.as_bytes(), &block);
        if i + 1 > after && matches!(effect, Effect::Move(m) if m.is_extruding()) {
            return nozzle.in_force_mm();
        }
        nozzle.follow(&effect);
    }
    panic!("no extrusion after line {after}")
}

/// Regression (found on PrusaSlicer's two-tool cone): with the default
/// `keep_slicer_retractions`, T0 retracts `retract_length_toolchange` (10 mm) before the first
/// `T1`, and T1, never retracted to the slicer, never undoes it. The purge block restored the
/// retraction it found, so Blue's first 25 moves (128 mm of solid infill) only refilled the
/// nozzle. Now the block primes those 10 mm with its purge (E35, then E31 not E21), and without
/// a purge a refill of its own does.
#[test]
fn mix_left_the_one_nozzle_retracted_at_a_first_change_to_a_new_tool() {
    let rel = "prusaslicer/pr_cone_2tool.gcode";
    let input = std::fs::read_to_string(data(rel)).unwrap();
    let first_t1 = input.lines().position(|l| l == "T1").unwrap() + 1;
    assert!((retracted_at_first_extrusion_after(&input, first_t1) - 10.0).abs() < 1e-9);
    let mixed = |toml: &str| {
        let (out, _) = mix_bytes(MixProfile::from_toml_str(toml).unwrap(), input.as_bytes()).unwrap();
        String::from_utf8(out).unwrap()
    };
    let block_of = |text: &str, from: &str, to: &str| -> Vec<String> {
        let lines: Vec<&str> = text.lines().collect();
        let a = lines.iter().position(|l| l.starts_with(from)).unwrap();
        let b = a + lines[a..].iter().position(|l| l.starts_with(to)).unwrap();
        lines[a..=b].iter().filter(|l| l.contains('E')).map(|l| l.to_string()).collect()
    };
    let map = "[map]\nT0 = \"Red\"\nT1 = \"Blue\"\n";
    let out = mixed(map);
    let purge = block_of(&out, "; gweave mix: purge Red -> Blue", "; gweave mix: end purge");
    // -4 (its own), +4 +10 +25 (prime, refill, purge), -4 (its own only), +4: net 35.
    assert_eq!(purge, ["G92 E0", "G1 E-4 F2400", "G1 E35 F200", "G1 E31 F2400", "G1 E35 F2400", "G92 E2"]);
    let end = out.lines().position(|l| l == "; gweave mix: end purge").unwrap() + 1;
    assert!(retracted_at_first_extrusion_after(&out, end) < 1e-9);
    // Without a purge the change still refills the 10 mm, at the retraction feed.
    let out = mixed(&format!("{map}[purge]\nmode = \"off\"\n"));
    let refill = block_of(&out, "; gweave mix: refill 10 mm", "; gweave mix: end refill");
    assert_eq!(refill, ["G92 E0", "G1 E10 F2400", "G92 E2"]);
    let end = out.lines().position(|l| l == "; gweave mix: end refill").unwrap() + 1;
    assert!(retracted_at_first_extrusion_after(&out, end) < 1e-9);
    assert_eq!(out.matches("; gweave mix: refill").count(), 1);
}
