//! `gweave mix --calibration-card`: a printable card of colour swatches that teaches the pigment
//! model what a hotend really makes with its filaments.
//!
//! The swatches are the pure inputs, every pair at 1:3, 1:1 and 3:1, every triple in equal
//! parts, and the third input with each of the first two at 9:1 and 1:9 (30 for 4 inputs), each
//! a solid square patch `patch_mm` wide and `layers` layers high, opaque enough to measure. They lie in a grid in reading order from the front left corner:
//! swatch 1 at the smallest X and Y, then along +X, `columns` to a row, rows along +Y. A small
//! tab left of swatch 1, in its mix, marks that corner so the card reads the right way round.
//!
//! The card is written as a plain file in which each swatch is printed by its own slicer tool
//! (`T0`, `T1`, ...), one swatch after the other (the nozzle lifts above the finished ones to
//! travel), and then rewritten by the ordinary mix pass with a tool map: the definitions, the
//! dialect, virtual tools taking turns, a purge at each change (the profile's `[purge]`, at
//! least its length before the first swatch too) and the Z cap all come from the profile, as
//! for any print.

use serde::Serialize;

use crate::colour::mixing::TINT_EXPONENT;
use crate::colour::named_mixes::MixSpec;
use crate::colour::{Mix, MixingModel};
use crate::post::mix::profile::{CardConfig, MixProfile, PurgeMode};
use crate::post::mix::report::MixReport;
use crate::post::mix::{mix_bytes, MixPassError};

/// One swatch of the card.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Swatch {
    /// 1-based, in reading order.
    pub id: u32,
    /// Normalised, input 0 first.
    pub ratios: Vec<f64>,
    /// 1-based as `id` (and as the terminal summary says it), row 1 at the front (smallest Y).
    pub row: u32,
    /// 1-based, column 1 at the left (smallest X).
    pub column: u32,
    /// Centre of the patch, mm.
    pub x_mm: f64,
    /// Centre of the patch along Y, mm.
    pub y_mm: f64,
    /// What the profile's model predicts, `#rrggbb`.
    pub predicted: String,
}

/// The card's report: the swatches, and the mix pass's own report.
#[derive(Debug, Clone, Serialize)]
pub struct CardReport {
    /// The swatches, in reading order.
    pub swatches: Vec<Swatch>,
    /// The mix pass's report on the card's G-code.
    pub mix: MixReport,
}

/// The card's mixes for `inputs` inputs: pure, pairs at 1:3, 1:1, 3:1, triples in equal parts,
/// then (with three inputs or more) input 2 with input 0 and with input 1 at 9:1 and 1:9.
///
/// Why those last four: the 3:1 pairs do not show how far 10 % of a filament tints another,
/// which the fit's tinting exponents ([`crate::colour::fit`]) measure; in the usual C, M, Y order
/// they are the greens and oranges at their ends, where 10 % moves the hue most. Measured
/// against FilamentMixer on four sets of filaments (`colour/fit_reference.rs`): with them the
/// worst blend is 5.78 ΔE00, with the same four swatches taken from other pairs (cyan with
/// magenta, then yellow; each input tinted by the next) 5.98 to 12.2, without them 13.1.
pub fn card_mixes(inputs: usize) -> Vec<Mix> {
    let unit = |i: usize| -> Vec<f64> { (0..inputs).map(|k| f64::from(u8::from(k == i))).collect() };
    let mut mixes: Vec<Vec<f64>> = (0..inputs).map(unit).collect();
    for a in 0..inputs {
        for b in a + 1..inputs {
            for (wa, wb) in [(1.0, 1.0), (3.0, 1.0), (1.0, 3.0)] {
                let mut w = vec![0.0; inputs];
                (w[a], w[b]) = (wa, wb);
                mixes.push(w);
            }
        }
    }
    for a in 0..inputs {
        for b in a + 1..inputs {
            for c in b + 1..inputs {
                let mut w = vec![0.0; inputs];
                (w[a], w[b], w[c]) = (1.0, 1.0, 1.0);
                mixes.push(w);
            }
        }
    }
    if inputs >= 3 {
        for a in [0, 1] {
            for (wa, wb) in [(9.0, 1.0), (1.0, 9.0)] {
                let mut w = vec![0.0; inputs];
                (w[a], w[2]) = (wa, wb);
                mixes.push(w);
            }
        }
    }
    mixes.iter().map(|w| Mix::new(w).expect("unit and blend weights are valid")).collect()
}

/// The card for the profile's hotend and filaments (its schedule and map are not used).
pub fn calibration_card(profile: &MixProfile) -> Result<(Vec<u8>, CardReport), MixPassError> {
    profile.validate()?;
    let card = &profile.card;
    let model = profile.hardware.mixing_model()?;
    let mut job = profile.clone();
    job.schedule.clear();
    job.gradient.clear();
    job.map.clear();
    if job.purge.mode != PurgeMode::Off {
        job.purge.initial_mm = job.purge.initial_mm.max(job.purge.length_mm);
    }
    let pitch = card.patch_mm + card.gap_mm;
    let mut swatches = Vec::new();
    for (k, mix) in card_mixes(profile.hardware.inputs.len()).into_iter().enumerate() {
        let id = k as u32 + 1;
        // Counted from 1 like the swatches: the card is read by people, not by code.
        let (row, column) = (k as u32 / card.columns + 1, k as u32 % card.columns + 1);
        let name = format!("Swatch{id}");
        job.mix.insert(name.clone(), MixSpec::Ratios(mix.clone()));
        job.add_map(&format!("T{k}={name}"))?;
        swatches.push(Swatch {
            id,
            ratios: mix.ratios().to_vec(),
            row,
            column,
            x_mm: card.x_mm + f64::from(column - 1) * pitch + card.patch_mm / 2.0,
            y_mm: card.y_mm + f64::from(row - 1) * pitch + card.patch_mm / 2.0,
            predicted: model.predict(&mix)?.to_hex(),
        });
    }
    let plain = plain_card(card, &swatches, profile.hardware.filament_diameter_mm);
    let (gcode, mix) = mix_bytes(job, plain.as_bytes())?;
    Ok((gcode, CardReport { swatches, mix }))
}

/// The profile `text` (TOML; empty for the defaults) with its `[[hardware.inputs]]` replaced by
/// `profile`'s inputs carrying the fitted colours, strengths, shapes and tinting exponents of
/// `model`. Everything else is kept as values (comments are not).
pub fn fitted_profile_toml(
    text: &str,
    profile: &MixProfile,
    model: &MixingModel,
) -> Result<String, MixPassError> {
    let config = |m: String| MixPassError::Config(m);
    let mut root: toml::Table =
        toml::from_str(text).map_err(|e| config(crate::settings::toml_message(&e)))?;
    let inputs: Vec<toml::Value> = profile
        .hardware
        .inputs
        .iter()
        .zip(model.inputs().iter().zip(model.strengths()).zip(model.shapes()).zip(model.tint_exponents()))
        .map(|(input, (((colour, strength), shape), &tint))| {
            let mut t = toml::Table::new();
            t.insert("colour".into(), colour.to_hex().into());
            t.insert("material".into(), input.material.clone().into());
            t.insert("density_g_cm3".into(), input.density_g_cm3.into());
            // Four significant digits: the fit's own precision.
            t.insert("strength".into(), format!("{strength:.3e}").parse::<f64>().unwrap_or(*strength).into());
            if shape.iter().any(|&a| a != 0.0) {
                // Four decimals: a change of 1e-4 in a bump weight moves no colour by 0.01 ΔE00.
                let rounded = shape.map(|a| (a * 1e4).round() / 1e4);
                t.insert("shape".into(), toml::Value::Array(rounded.iter().map(|&a| a.into()).collect()));
            }
            if tint != TINT_EXPONENT {
                // Four decimals: 1e-4 in the exponent moves a 10 % share's weight by 0.02 %.
                t.insert("tint_exponent".into(), ((tint * 1e4).round() / 1e4).into());
            }
            toml::Value::Table(t)
        })
        .collect();
    let hardware = root.entry("hardware").or_insert_with(|| toml::Value::Table(toml::Table::new()));
    let toml::Value::Table(hardware) = hardware else {
        return Err(config("`hardware` is not a table".into()));
    };
    hardware.insert("inputs".into(), toml::Value::Array(inputs));
    let out = toml::to_string(&root).map_err(|e| config(e.to_string()))?;
    // The result must read back as the profile it claims to be.
    MixProfile::from_toml_str(&out)?;
    Ok(out)
}

/// The card with one slicer tool per swatch, before the mix pass.
fn plain_card(card: &CardConfig, swatches: &[Swatch], filament_diameter_mm: f64) -> String {
    use std::fmt::Write;
    let area_mm2 = std::f64::consts::PI * filament_diameter_mm * filament_diameter_mm / 4.0;
    let e_per_mm = card.line_mm * card.layer_mm / area_mm2;
    let top_mm = f64::from(card.layers) * card.layer_mm;
    let clear_mm = top_mm + 2.0;
    let (travel, feed) = (card.travel_feed_mm_min, card.print_feed_mm_min);
    let mut g = String::new();
    let _ = writeln!(
        g,
        "; gweave mix --calibration-card: {} swatches, swatch 1 at the front left",
        swatches.len()
    );
    let _ = writeln!(
        g,
        "M140 S{}\nM104 S{}\nM190 S{}\nM109 S{}",
        card.bed_c, card.hotend_c, card.bed_c, card.hotend_c
    );
    let _ = writeln!(g, "G28\nG90\nM83\nG92 E0\n;LAYER:0");
    // A filled rectangle, lines along X at `line_mm` spacing, zigzag.
    let fill = |g: &mut String, x0: f64, y0: f64, w: f64, h: f64, z: f64| {
        let _ =
            writeln!(g, "G0 Z{clear_mm:.2} F{travel}\nG0 X{x0:.3} Y{:.3} F{travel}", y0 + card.line_mm / 2.0);
        let _ = writeln!(g, "G0 Z{z:.2} F{travel}");
        let lines = ((h / card.line_mm).floor() as u32).max(1);
        for i in 0..lines {
            let y = y0 + card.line_mm * (f64::from(i) + 0.5);
            let (from, to) = if i % 2 == 0 { (x0, x0 + w) } else { (x0 + w, x0) };
            if i > 0 {
                let _ = writeln!(g, "G1 X{from:.3} Y{y:.3} E{:.5} F{feed}", card.line_mm * e_per_mm);
            }
            let _ = writeln!(g, "G1 X{to:.3} Y{y:.3} E{:.5} F{feed}", w * e_per_mm);
        }
    };
    for s in swatches {
        let x0 = s.x_mm - card.patch_mm / 2.0;
        let y0 = s.y_mm - card.patch_mm / 2.0;
        let ratios: Vec<String> = s.ratios.iter().map(|r| format!("{r:.4}")).collect();
        let _ = writeln!(g, "; gweave card: swatch {} ratios {}\nT{}", s.id, ratios.join(":"), s.id - 1);
        for layer in 0..card.layers {
            let z = f64::from(layer + 1) * card.layer_mm;
            fill(&mut g, x0, y0, card.patch_mm, card.patch_mm, z);
            if s.id == 1 {
                // The tab that marks swatch 1's corner.
                let tab = card.patch_mm / 3.0;
                fill(&mut g, x0 - card.gap_mm / 2.0 - tab / 2.0, y0, tab / 2.0, tab, z);
            }
        }
    }
    let _ = writeln!(g, "; gweave card: end\nG0 Z{:.2} F{travel}\nM104 S0\nM140 S0\nM84", clear_mm + 10.0);
    g
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fitted_profile_keeps_the_rest_and_reads_back() {
        let text = "[purge]\nlength_mm = 30.0\n[[hardware.inputs]]\ncolour = \"#00a0e0\"\n[[hardware.inputs]]\ncolour = \"#ffffff\"\nmaterial = \"PVA\"\n";
        let profile = MixProfile::from_toml_str(text).unwrap();
        let model = MixingModel::with_strengths(
            &[crate::colour::Srgb8::new(1, 2, 3), crate::colour::Srgb8::new(250, 250, 250)],
            &[0.123456, 2.0],
        )
        .unwrap()
        .with_new_tint_exponents(&[1.234567, TINT_EXPONENT])
        .unwrap();
        let out = fitted_profile_toml(text, &profile, &model).unwrap();
        let back = MixProfile::from_toml_str(&out).unwrap();
        assert_eq!(back.purge.length_mm, 30.0);
        assert_eq!(back.hardware.inputs[0].colour.to_hex(), "#010203");
        assert_eq!(back.hardware.inputs[0].strength, Some(0.1235));
        assert_eq!(back.hardware.inputs[1].material, "PVA");
        assert_eq!(back.hardware.mixing_model().unwrap().strengths(), [0.1235, 2.0]);
        // The default exponent is not written; a fitted one is, to four decimals.
        assert_eq!(
            (back.hardware.inputs[0].tint_exponent, back.hardware.inputs[1].tint_exponent),
            (Some(1.2346), None)
        );
        assert_eq!(back.hardware.mixing_model().unwrap().tint_exponents(), [1.2346, TINT_EXPONENT]);
    }

    #[test]
    fn card_keys_have_ranges() {
        for (text, want) in [
            ("[card]\npatch_mm = 1000", "[card] patch_mm = 1000 is out of range: 3 to 100 mm"),
            ("[card]\ncolumns = 0", "[card] columns = 0 is out of range"),
            ("[[hardware.inputs]]\ncolour = \"#ffffff\"\nstrength = 0", "strength = 0 is out of range"),
            (
                "[[hardware.inputs]]\ncolour = \"#ffffff\"\ntint_exponent = 5",
                "tint_exponent = 5 is out of range: 0.8 to 3",
            ),
        ] {
            let err = MixProfile::from_toml_str(text).unwrap_err().to_string();
            assert!(err.contains(want), "{text}: {err}");
        }
    }

    #[test]
    fn four_inputs_make_30_swatches_over_the_gamut() {
        let mixes = card_mixes(4);
        assert_eq!(mixes.len(), 4 + 6 * 3 + 4 + 4);
        assert_eq!(mixes[0].ratios(), [1.0, 0.0, 0.0, 0.0]);
        assert_eq!(mixes[4].ratios(), [0.5, 0.5, 0.0, 0.0]);
        assert_eq!(mixes[5].ratios(), [0.75, 0.25, 0.0, 0.0]);
        let last_triple = mixes[25].ratios();
        assert!((last_triple[1] - 1.0 / 3.0).abs() < 1e-12 && last_triple[0] == 0.0, "{last_triple:?}");
        // The tints: yellow with cyan, then with magenta, at 9:1 and 1:9.
        let tints: Vec<Vec<f64>> =
            mixes[26..].iter().map(|m| m.ratios().iter().map(|r| (r * 10.0).round()).collect()).collect();
        assert_eq!(
            tints,
            [[9.0, 0.0, 1.0, 0.0], [1.0, 0.0, 9.0, 0.0], [0.0, 9.0, 1.0, 0.0], [0.0, 1.0, 9.0, 0.0]]
        );
        assert!((mixes[26].ratios()[0] - 0.9).abs() < 1e-12, "{:?}", mixes[26].ratios());
        assert_eq!(card_mixes(3).len(), 3 + 3 * 3 + 1 + 4);
        assert_eq!(card_mixes(2).len(), 2 + 3);
    }

    #[test]
    fn the_card_defines_and_selects_every_swatch() {
        let (gcode, report) = calibration_card(&MixProfile::default()).unwrap();
        let text = String::from_utf8(gcode).unwrap();
        assert_eq!(report.swatches.len(), 30);
        // Swatch 7 starts the second row: rows and columns count from 1, as ids do.
        assert_eq!((report.swatches[6].id, report.swatches[6].row, report.swatches[6].column), (7, 2, 1));
        assert_eq!((report.swatches[0].row, report.swatches[0].column), (1, 1));
        assert_eq!(report.mix.mixes.len(), 30);
        // 29 changes, each purged, and the purge before swatch 1.
        assert_eq!((report.mix.changes, report.mix.purge.count), (29, 30));
        assert!(text.contains("; gweave card: swatch 26 ratios 0.0000:0.3333:0.3333:0.3333\n"), "{text}");
        assert!(text.contains("; gweave card: swatch 30 ratios 0.0000:0.1000:0.9000:0.0000\n"), "{text}");
        // Swatch 30 closes the fifth row: row 5, column 6.
        assert_eq!((report.swatches[29].id, report.swatches[29].row, report.swatches[29].column), (30, 5, 6));
        assert!(!text.lines().any(|l| l.starts_with("T29")), "slicer tools become comments");
    }
}
