//! What the file must have for the rules asked for: the print-proper markers (checked before
//! anything is written) and feature comments (for the rule that keeps changes off the outer wall).
//!
//! With markers (`;begin` as the start G-code's last line, `;end` as the end G-code's first, as
//! the purge-shift seed asks) only changes between them are moved. A file that lacks one would
//! otherwise come out unchanged with every change "left alone", which looks like success; the
//! seed's script stops and tells the user to add the marker, and so does this. The check reads
//! the file once before the pass (comments only), so that a refused file writes nothing, not
//! even to standard output.

use std::io::Read;
use std::path::Path;

use std::collections::BTreeMap;

use super::config::FeatureSet;
use super::nozzles::SEMM_KEY;
use crate::error::{Error, Result};
use crate::gcode::layers::{trim, Feature, Markers, ALL_FEATURES};
use crate::gcode::lexer::parse_line_lean;
use crate::gcode::line::Block;
use crate::gcode::reader::{LineReader, Part};
use crate::post::warning::Warning;

/// Fails unless `input` has the begin marker and, after it, the end marker (a file without
/// markers asked for passes).
pub(crate) fn require_markers(input: impl Read, path: &Path, markers: &Markers) -> Result<()> {
    let (Some(begin), Some(end)) = (&markers.begin, &markers.end) else { return Ok(()) };
    let mut reader = LineReader::new(input);
    let mut block = Block::default();
    let mut begin_line = None;
    let mut end_before_begin = None;
    while let Some(line) = reader.next_line().map_err(|e| Error::io(path, e))? {
        // Markers are short comments: a line too long to read whole is not one.
        if line.part != Part::Whole || !line.bytes.iter().any(|&b| b == b';' || b == b'(') {
            continue;
        }
        parse_line_lean(&line, &mut block);
        let Some(text) = block.comment_text(line.bytes).map(trim) else { continue };
        if begin_line.is_none() && text == begin.as_slice() {
            begin_line = Some(line.number);
        } else if text == end.as_slice() {
            if begin_line.is_some() {
                return Ok(());
            }
            end_before_begin.get_or_insert(line.number);
        }
    }
    let name = |m: &[u8]| String::from_utf8_lossy(m).into_owned();
    let (marker, detail) = match begin_line {
        None => (
            name(begin),
            "is not in the file: add it as the last line of the slicer's start G-code".to_string(),
        ),
        Some(b) => {
            let only =
                end_before_begin.map_or(String::new(), |e| format!("; the one on line {e} comes before it"));
            let after = format!("`;{}` (line {b}{only})", name(begin));
            (
                name(end),
                format!(
                    "is not in the file after {after}: add it as the first line of the slicer's end G-code"
                ),
            )
        }
    };
    Err(Error::MissingMarker { path: path.to_path_buf(), marker, detail })
}

/// The slicer settings that put a wipe (prime) tower in the file, as each writes them at the
/// file's ends: the PrusaSlicer family's `; wipe_tower = 1`, OrcaSlicer's `; enable_prime_tower
/// = 1`, Cura's `prime_tower_enable = True` in its `;SETTING_3` footer.
const TOWER_SETTINGS: [(&str, &str); 3] =
    [("wipe_tower", "1"), ("enable_prime_tower", "1"), ("prime_tower_enable", "True")];

/// The settings the checks of a file's ends look up in `ends` (its ends, or all of a text): the
/// wipe tower's and the nozzles' ([`super::nozzles`]), in one search of the text.
pub(crate) fn ends_settings(ends: &[u8]) -> BTreeMap<&'static str, String> {
    let [a, b, c] = TOWER_SETTINGS.map(|(key, _)| key);
    crate::gcode::ends::settings(&crate::gcode::ends::ends_text(ends), &[a, b, c, SEMM_KEY])
}

/// Refuses a file sliced with a wipe tower. purge-shift is the tower's replacement: on a file
/// that has one, the slicer's tool changes sit at the tower, so each would be moved back into
/// the tower's own moves and ramming, and the report would count a saving against a tower that
/// is still printed. `set` is the file's settings ([`ends_settings`]).
pub(crate) fn refuse_wipe_tower(set: &BTreeMap<&str, String>, path: &Path) -> Result<()> {
    let found = TOWER_SETTINGS
        .iter()
        .find(|(key, on)| set.get(key).is_some_and(|v| v == on))
        .map(|(key, on)| format!("{key} = {on}"));
    match found {
        Some(setting) => Err(Error::Invalid(format!(
            "{}: the file was sliced with a wipe tower ({setting}): purge-shift replaces the tower, \
             and would move the tool changes into the tower's own moves; slice it again without \
             the tower (PrusaSlicer: Print Settings > Multiple Extruders > Wipe tower; Cura: Prime \
             Tower) and purge-shift that file",
            path.display()
        ))),
        None => Ok(()),
    }
}

/// Whether the print's extrusions carry feature comments (`;TYPE:` and the like). Without them
/// every extrusion is [`Feature::Unknown`]: a rule that keeps changes off some features (by
/// default the outer wall, so that the colour seam stays inside) cannot tell those apart, and
/// the change moves through them. Slic3r's files, for one, have no such comments.
#[derive(Debug, Default)]
pub(crate) struct FeatureComments {
    extruded: bool,
    known: bool,
}

impl FeatureComments {
    /// An extruding move inside the print proper, of `feature`.
    pub(crate) fn extrusion(&mut self, feature: Feature) {
        self.extruded = true;
        self.known |= feature != Feature::Unknown;
    }

    /// The warning, when the file has extrusions, none with a feature, and the rules keep the
    /// change off some feature while letting it through unmarked extrusions.
    pub(crate) fn warning(&self, allowed: FeatureSet) -> Option<Warning> {
        if !self.extruded || self.known || !allowed.contains(Feature::Unknown) {
            return None;
        }
        let kept_off: Vec<&str> =
            ALL_FEATURES.iter().filter(|&&f| !allowed.contains(f)).map(|f| f.name()).collect();
        if kept_off.is_empty() {
            return None;
        }
        Some(Warning::NoFeatureComments { kept_off })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(text: &str) -> std::result::Result<(), String> {
        let markers = Markers { begin: Some(b"begin".to_vec()), end: Some(b"end".to_vec()) };
        require_markers(text.as_bytes(), Path::new("f.gcode"), &markers).map_err(|e| e.to_string())
    }

    #[test]
    fn both_markers_in_order_pass() {
        assert_eq!(check("G28\n; begin\nT1\n;end\nM84\n"), Ok(()));
    }

    #[test]
    fn missing_begin_is_named() {
        let e = check("G28\nT1\n;end\n").unwrap_err();
        assert_eq!(
            e,
            "f.gcode: the print-proper marker `;begin` is not in the file: add it as the last line of the slicer's start G-code"
        );
    }

    #[test]
    fn missing_end_is_named() {
        let e = check(";begin\nT1\n").unwrap_err();
        assert!(
            e.contains("`;end` is not in the file after `;begin` (line 1)") && e.contains("end G-code"),
            "{e}"
        );
    }

    #[test]
    fn end_before_begin_is_refused() {
        let e = check(";end\n;begin\nT1\n").unwrap_err();
        assert!(
            e.contains(
                "`;end` is not in the file after `;begin` (line 2; the one on line 1 comes before it)"
            ),
            "{e}"
        );
    }

    #[test]
    fn marker_text_must_be_the_whole_comment() {
        // `;beginning` and a `begin` outside a comment are not the marker.
        assert!(check(";beginning\nM117 begin\n;end\n").unwrap_err().contains("`;begin`"));
    }

    #[test]
    fn unmarked_extrusions_warn_when_a_feature_is_kept_off() {
        let default: FeatureSet = ALL_FEATURES.iter().copied().filter(|&f| f != Feature::OuterWall).collect();
        let mut seen = FeatureComments::default();
        assert_eq!(seen.warning(default), None, "no extrusion, no warning");
        seen.extrusion(Feature::Unknown);
        let w = seen.warning(default).unwrap().to_string();
        assert!(
            w.starts_with(
                "the file has no feature comments (;TYPE:), so the rule keeping changes off outer_wall"
            ),
            "{w}"
        );
        let all: FeatureSet = ALL_FEATURES.iter().copied().collect();
        assert_eq!(seen.warning(all), None, "every feature allowed: no rule to miss");
        seen.extrusion(Feature::InnerWall);
        assert_eq!(seen.warning(default), None, "the file marks its features");
    }

    #[test]
    fn no_markers_asked_for_passes() {
        let none = Markers::default();
        assert!(require_markers("T1\n".as_bytes(), Path::new("f"), &none).is_ok());
    }
}
