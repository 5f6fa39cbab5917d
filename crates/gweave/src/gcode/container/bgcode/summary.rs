//! The printer and print metadata of a text G-code file written as binary G-code, as
//! PrusaSlicer 2.7+ fills them when it writes `.bgcode` itself (src/libslic3r/GCode.cpp and
//! GCode/GCodeProcessor.cpp): the printer metadata (what PrusaLink, Prusa Connect and the
//! printer's screen show before opening the G-code) copies a few of the slicer's settings and
//! the totals; the print metadata holds the footer's figures.
//!
//! Both come from the text itself: the settings from its settings block (the slicer metadata),
//! the figures from its footer comments (`; filament used [mm] = ...`), which for a transform's
//! output are gweave's own figures (`gweave_sim::with_metadata` rewrites the footer before the text
//! reaches the writer). A key the text does not have is left out, as PrusaSlicer leaves out
//! what it does not know.

use super::Metadata;

/// Settings PrusaSlicer copies into the printer metadata, in its order.
const PRINTER_SETTINGS: &[&str] = &[
    "printer_model",
    "filament_type",
    "nozzle_diameter",
    "bed_temperature",
    "brim_width",
    "fill_density",
    "layer_height",
    "temperature",
    "ironing",
    "support_material",
    "extruder_colour",
];

/// Footer figures PrusaSlicer's processor adds to the printer metadata.
const PRINTER_FIGURES: &[&str] =
    &["filament used [mm]", "filament used [g]", "estimated printing time (normal mode)"];

/// Footer figures of the print metadata, in PrusaSlicer's order.
const PRINT_FIGURES: &[&str] = &[
    "filament used [mm]",
    "filament used [cm3]",
    "filament used [g]",
    "filament cost",
    "total filament used [g]",
    "total filament cost",
    "total toolchanges",
    "estimated printing time (normal mode)",
    "estimated first layer printing time (normal mode)",
    "estimated printing time (silent mode)",
    "estimated first layer printing time (silent mode)",
];

/// The printer and print metadata of a text whose settings are `settings` and whose end
/// (before the settings block) is `tail`.
pub(crate) fn of_text(settings: &Metadata, tail: &[u8]) -> (Metadata, Metadata) {
    let footer = footer(tail);
    let figure = |key: &&str| footer.iter().rev().find(|(k, _)| k == key).cloned();
    let mut printer: Vec<(String, String)> = PRINTER_SETTINGS
        .iter()
        .filter_map(|key| settings.get(key).map(|v| (key.to_string(), v.to_owned())))
        .collect();
    printer.extend(PRINTER_FIGURES.iter().filter_map(figure));
    let print = PRINT_FIGURES.iter().filter_map(figure).collect();
    (Metadata { json: false, items: printer }, Metadata { json: false, items: print })
}

/// The `; key = value` comment lines of `tail` whose key is a footer figure.
fn footer(tail: &[u8]) -> Vec<(String, String)> {
    tail.split(|&b| b == b'\n')
        .filter_map(|line| {
            let line = line.strip_suffix(b"\r").unwrap_or(line).strip_prefix(b"; ")?;
            let (key, value) = std::str::from_utf8(line).ok()?.split_once(" = ")?;
            PRINT_FIGURES.contains(&key).then(|| (key.to_owned(), value.trim().to_owned()))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_and_footer_fill_both_blocks_in_prusaslicers_order() {
        let settings = Metadata {
            json: false,
            items: [("layer_height", "0.2"), ("printer_model", "MK4S"), ("gcode_flavor", "marlin2")]
                .map(|(k, v)| (k.to_owned(), v.to_owned()))
                .to_vec(),
        };
        let tail = b"G1 X1\n; filament used [mm] = 10.00\n; filament used [g] = 0.03\n\
            ; estimated printing time (normal mode) = 1m 2s\n; filament used [mm] = 12.50\n\
            ;TYPE:Custom\n; not a figure = 3\n";
        let (printer, print) = of_text(&settings, tail);
        let items = |m: &Metadata| m.items.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>();
        // The last figure of a key counts (a footer rewritten after the slicer's).
        assert_eq!(
            items(&printer),
            [
                "printer_model=MK4S",
                "layer_height=0.2",
                "filament used [mm]=12.50",
                "filament used [g]=0.03",
                "estimated printing time (normal mode)=1m 2s"
            ]
        );
        assert_eq!(
            items(&print),
            [
                "filament used [mm]=12.50",
                "filament used [g]=0.03",
                "estimated printing time (normal mode)=1m 2s"
            ]
        );
        assert_eq!(of_text(&Metadata::default(), b"G1 X1\n"), (Metadata::default(), Metadata::default()));
    }
}
