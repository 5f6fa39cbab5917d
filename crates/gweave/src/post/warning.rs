//! What the post-processing transforms warn about, typed (as the virtual printer's
//! `WarningKind`): a caller can match on the kind and read its figures, and the report still
//! says each warning in the words it always did. Through `Display` and in JSON a warning is
//! that sentence, so `--json` documents are what they were when warnings were strings.

use std::fmt;

use serde::{Serialize, Serializer};

/// One warning of a transform's report.
#[derive(Debug, Clone, PartialEq)]
pub enum Warning {
    /// `mix`: a target colour the filaments cannot print; the nearest mix is `delta_e` off.
    OutOfGamut {
        /// The mix's name.
        mix: String,
        /// The colour asked for, `#rrggbb`.
        target_hex: String,
        /// CIEDE2000 distance of the nearest printable mix.
        delta_e: f64,
    },
    /// `mix`: a palette name whose colour the filaments cannot print (see
    /// `colour::named_mixes::NAME_GAMUT_DE`).
    NameOutOfGamut {
        /// The mix's name.
        mix: String,
        /// The colour the name means, `#rrggbb`.
        meant_hex: String,
        /// What the palette's ratios print, `#rrggbb`.
        predicted_hex: String,
        /// The nearest colour the filaments print, `#rrggbb`.
        nearest_hex: String,
        /// Its ratios, as written in the summary.
        nearest_ratios: String,
        /// CIEDE2000 between the nearest and the meant colour.
        delta_e: f64,
    },
    /// `mix`: the file never moved filament nor reached its first layer, so no mix was defined.
    NoMixDefined,
    /// `mix`: a flavour named only in the middle of the file (not in the ends read before the
    /// pass), seen after the dialect was chosen, wanted another.
    DialectNotTheFlavours {
        /// The flavour the file names.
        flavour: String,
        /// The mix commands that flavour wants.
        wanted: String,
        /// The mix commands written.
        written: String,
    },
    /// `purge-shift`: no purge is configured for this change; the largest configured was used.
    NoPurgeAmount {
        /// The change's line, from 1.
        line: u64,
        /// The tool before the change.
        from_tool: u32,
        /// The tool after it.
        to_tool: u32,
        /// The purge used instead, mm of filament.
        used_mm: f64,
    },
    /// `purge-shift`: the change could not move back far enough for its whole purge.
    PurgeShort {
        /// The change's layer, from 0, when the file marks layers.
        layer: Option<u32>,
        /// The change's line, from 1.
        line: u64,
        /// The tool before the change.
        from_tool: u32,
        /// The tool after it.
        to_tool: u32,
        /// Purge missing, mm of filament.
        short_mm: f64,
        /// Purge the change moved back over, mm of filament.
        moved_mm: f64,
        /// Purge asked for, mm of filament.
        requested_mm: f64,
        /// What stopped the move back (a feature, the layer start, ...).
        stopped_by: &'static str,
        /// What became of the shortfall.
        then: Shortfall,
    },
    /// `purge-shift`: without feature comments the rule keeping changes off these features
    /// cannot apply.
    NoFeatureComments {
        /// The features the rule keeps changes off.
        kept_off: Vec<&'static str>,
    },
}

/// What became of a purge's shortfall.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shortfall {
    /// Purged by this fallback (`block`, `tower`).
    Purged(&'static str),
    /// Not purged: the fallbacks do not write inches.
    Inches,
    /// Not purged: the change opens its layer, and the purge may not reach the layer below.
    OpensItsLayer,
    /// Accepted (the `partial` fallback), stopped by a feature the rules keep the purge off.
    KeptOffAFeature,
    /// Accepted (the `partial` fallback).
    Accepted,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Warning::OutOfGamut { mix, target_hex, delta_e } => write!(
                f,
                "{mix}: {target_hex} is out of gamut for these filaments; nearest mix is off by dE2000 {delta_e:.1}"
            ),
            Warning::NameOutOfGamut { mix, meant_hex, predicted_hex, nearest_hex, nearest_ratios, delta_e } => {
                write!(
                    f,
                    "{mix}: out of these filaments' gamut: its ratios print {predicted_hex}, and the nearest to {} ({meant_hex}) they print is {nearest_hex} at {nearest_ratios}, dE2000 {delta_e:.1}",
                    mix.to_lowercase()
                )
            }
            Warning::NoMixDefined => {
                f.write_str("the file never moved filament nor reached its first layer: no mix was defined")
            }
            Warning::DialectNotTheFlavours { flavour, wanted, written } => write!(
                f,
                "the file's flavour ({flavour}) wants the {wanted} dialect, but {written} was written: the file names it only in its middle, beyond the first {} KiB and the last {} KiB read before the pass; give --dialect or set hardware.dialect",
                crate::gcode::ends::HEAD_BYTES / 1024,
                crate::gcode::ends::TAIL_BYTES / 1024
            ),
            Warning::NoPurgeAmount { line, from_tool, to_tool, used_mm } => write!(
                f,
                "line {line}: no purge amount for T{from_tool}->T{to_tool}; using the largest configured, {used_mm:.3} mm"
            ),
            Warning::PurgeShort {
                layer,
                line,
                from_tool,
                to_tool,
                short_mm,
                moved_mm,
                requested_mm,
                stopped_by,
                then,
            } => {
                let layer = layer.map_or("-".into(), |l| l.to_string());
                write!(
                    f,
                    "layer {layer}, line {line}: T{from_tool}->T{to_tool} purge short by {short_mm:.3} mm ({moved_mm:.3} of {requested_mm:.3} mm; stopped by {stopped_by}){then}"
                )
            }
            Warning::NoFeatureComments { kept_off } => write!(
                f,
                "the file has no feature comments (;TYPE:), so the rule keeping changes off {} cannot apply: \
                 changes moved through every extrusion; slice with a slicer that writes them (PrusaSlicer, Cura, ...) \
                 or pass --allow-features to say what may take the purge",
                kept_off.join(", ")
            ),
        }
    }
}

/// What became of a shortfall, as the end of a warning's sentence (nothing when accepted).
impl fmt::Display for Shortfall {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Shortfall::Purged(fallback) => write!(f, "; the rest purged by the {fallback} fallback"),
            Shortfall::Inches => f.write_str("; no fallback purge: the file is in inches"),
            Shortfall::OpensItsLayer => {
                f.write_str("; it opens its layer: --cross-layers lets the purge reach the layer below")
            }
            Shortfall::KeptOffAFeature => f.write_str(
                "; --allow-features lets more features take the purge (default: all but the outer wall)",
            ),
            Shortfall::Accepted => Ok(()),
        }
    }
}

/// Warnings as a person reads them: one line per kind. A file with 95 short purges gets one
/// line with their count, range and total, and where the first is, not 95 lines (each change
/// is still in the report's `changes` and `--json`). Kinds are shown in the order they first
/// appear; a kind seen once keeps its own sentence.
pub fn grouped(warnings: &[Warning]) -> Vec<String> {
    // (the first warning of the kind, how many, smallest and largest shortfall, total)
    let mut groups: Vec<(&Warning, u64, f64, f64, f64)> = Vec::new();
    for w in warnings {
        let short_mm = match w {
            Warning::PurgeShort { short_mm, .. } => *short_mm,
            _ => 0.0,
        };
        match groups.iter_mut().find(|g| same_kind(g.0, w)) {
            Some(g) => {
                g.1 += 1;
                (g.2, g.3, g.4) = (g.2.min(short_mm), g.3.max(short_mm), g.4 + short_mm);
            }
            None => groups.push((w, 1, short_mm, short_mm, short_mm)),
        }
    }
    groups
        .into_iter()
        .map(|(first, count, min_mm, max_mm, total_mm)| match first {
            _ if count == 1 => first.to_string(),
            Warning::PurgeShort { layer, line, stopped_by, then, .. } => {
                let layer = layer.map_or("-".into(), |l| l.to_string());
                format!(
                    "{count} changes purge short by {min_mm:.3} .. {max_mm:.3} mm ({total_mm:.3} mm in all; \
                     stopped by {stopped_by}), the first at layer {layer}, line {line}{then}; --json lists each"
                )
            }
            Warning::NoPurgeAmount { line, used_mm, .. } => format!(
                "{count} changes have no purge amount for their tool pair, the first at line {line}; \
                 using the largest configured, {used_mm:.3} mm"
            ),
            other => format!("{other} (and {} more like it)", count - 1),
        })
        .collect()
}

/// Whether two warnings are shown as one line: short purges stopped by the same thing and
/// ending the same way, changes without a purge amount; every other warning is its own.
fn same_kind(a: &Warning, b: &Warning) -> bool {
    match (a, b) {
        (
            Warning::PurgeShort { stopped_by: s1, then: t1, .. },
            Warning::PurgeShort { stopped_by: s2, then: t2, .. },
        ) => s1 == s2 && t1 == t2,
        (Warning::NoPurgeAmount { .. }, Warning::NoPurgeAmount { .. }) => true,
        _ => a == b,
    }
}

/// A warning is its sentence in JSON.
impl Serialize for Warning {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn short(line: u64, short_mm: f64, stopped_by: &'static str) -> Warning {
        Warning::PurgeShort {
            layer: Some(3),
            line,
            from_tool: 0,
            to_tool: 1,
            short_mm,
            moved_mm: 2.5 - short_mm,
            requested_mm: 2.5,
            stopped_by,
            then: Shortfall::Accepted,
        }
    }

    #[test]
    fn ninety_five_shortfalls_are_one_warning_line() {
        let mut warnings: Vec<Warning> =
            (0..95).map(|i| short(100 + i, 0.5 + i as f64 / 100.0, "the outer wall")).collect();
        warnings.insert(10, short(7, 1.0, "a layer change"));
        let lines = grouped(&warnings);
        assert_eq!(
            lines,
            [
                "95 changes purge short by 0.500 .. 1.440 mm (92.150 mm in all; stopped by the outer wall), \
                 the first at layer 3, line 100; --json lists each"
                    .to_owned(),
                "layer 3, line 7: T0->T1 purge short by 1.000 mm (1.500 of 2.500 mm; stopped by a layer change)"
                    .to_owned(),
            ]
        );
    }

    #[test]
    fn a_warning_is_its_sentence_in_text_and_json() {
        let w = Warning::PurgeShort {
            layer: None,
            line: 12,
            from_tool: 0,
            to_tool: 1,
            short_mm: 0.5,
            moved_mm: 1.5,
            requested_mm: 2.0,
            stopped_by: "a layer change",
            then: Shortfall::OpensItsLayer,
        };
        let text = "layer -, line 12: T0->T1 purge short by 0.500 mm (1.500 of 2.000 mm; stopped by a layer change); \
                    it opens its layer: --cross-layers lets the purge reach the layer below";
        assert_eq!(w.to_string(), text);
        assert_eq!(serde_json::to_string(&w).unwrap(), serde_json::to_string(text).unwrap());
    }
}
