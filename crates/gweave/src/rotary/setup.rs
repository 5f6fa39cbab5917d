//! Machine-setup lines of a flat file, said for the rotary machine.
//!
//! A flat start G-code sets per-axis values with `M92 Y80`, `M203 Y200`... On the rotary
//! machine the flat Y is the rotary axis (and X, Z the axial and radial ones), so those words
//! are renamed to the machine's letters. Where the rotary word is in degrees the value is
//! converted too, one turn being the circumference `C` of flat Y:
//!
//! - per-distance values (`M92` steps/mm) become per degree: `v * C / 360`;
//! - rates (`M201` mm/s², `M203` mm/s, `M205` jerk mm/s, RepRapFirmware's `M566` mm/min)
//!   become degrees: `v * 360 / C`;
//! - `M17`/`M18`/`M84` (motors on/off), `M350` (microstepping), `M906`/`M913` (motor
//!   current), `M569` (driver) name an axis without a length: renamed only.
//!
//! Only these lines are touched; the rest of the line (other words, comment) is kept as written.

use super::cylinder::{RotaryConfig, RotaryUnit};
use super::emit::number_text;
use crate::gcode::line::Block;
use crate::gcode::number::NumberFormat;

/// How a setup command's Y value converts to the rotary axis in degrees.
#[derive(Clone, Copy, PartialEq)]
enum Per {
    /// A value per mm of travel (steps/mm).
    Distance,
    /// A length per time (or per time squared).
    Rate,
    /// No length in it.
    Nothing,
}

fn kind(block: &Block) -> Option<Per> {
    let c = block.command;
    if c.is_m(92) {
        Some(Per::Distance)
    } else if [201, 203, 205, 566].iter().any(|&n| c.is_m(n)) {
        Some(Per::Rate)
    } else if [17, 18, 84, 350, 569, 906, 913].iter().any(|&n| c.is_m(n)) {
        Some(Per::Nothing)
    } else {
        None
    }
}

/// The line said for the rotary machine, or `None` when it is not a setup line with axis words
/// or nothing in it changes.
pub(crate) fn rewrite_setup(
    machine: &RotaryConfig,
    format: &NumberFormat,
    line: &[u8],
    block: &Block,
) -> Option<Vec<u8>> {
    let per = kind(block)?;
    let letter = |c: char| c.to_ascii_uppercase() as u8;
    let turn_per_mm = 360.0 / machine.circumference_mm();
    let mut out = line.to_vec();
    let mut changed = false;
    // From the last word back, so that earlier spans stay valid as the text changes length.
    for w in block.words.iter().rev() {
        let to = match w.letter {
            b'X' => letter(machine.axial_axis),
            b'Y' => letter(machine.rotary_axis),
            b'Z' => letter(machine.radial_axis),
            _ => continue,
        };
        let degrees = w.letter == b'Y' && machine.rotary_unit == RotaryUnit::Degrees;
        let converted = match (w.number(), degrees, per) {
            (Some(v), true, Per::Distance) => Some(v / turn_per_mm),
            (Some(v), true, Per::Rate) => Some(v * turn_per_mm),
            _ => None,
        };
        if to == w.letter && converted.is_none() {
            continue;
        }
        let word = match converted {
            Some(value) => format!("{}{}", char::from(to), number_text(format, b'X', value)).into_bytes(),
            None => {
                let mut word = w.span.of(line).to_vec();
                word[0] = to;
                word
            }
        };
        out.splice(w.span.start as usize..w.span.end as usize, word);
        changed = true;
    }
    changed.then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::lexer::parse_into;
    use crate::rotary::emit::rotary_number_format;

    fn said(machine: &RotaryConfig, line: &str) -> Option<String> {
        let mut block = Block::default();
        parse_into(line.as_bytes(), &mut block);
        rewrite_setup(machine, &rotary_number_format(), line.as_bytes(), &block)
            .map(|b| String::from_utf8(b).unwrap())
    }

    #[test]
    fn setup_words_name_the_rotary_axis_in_its_unit() {
        // 60 mm circumference: 1 mm of flat Y is 6 degrees.
        let m = RotaryConfig::new(60.0 / std::f64::consts::PI);
        assert_eq!(
            said(&m, "M92 X80 Y80 Z400 E93 ; steps").as_deref(),
            Some("M92 X80 A13.333 Z400 E93 ; steps")
        );
        assert_eq!(said(&m, "M203 X200 Y200 Z12").as_deref(), Some("M203 X200 A1200.000 Z12"));
        assert_eq!(said(&m, "M906 X800 Y800").as_deref(), Some("M906 X800 A800"));
        assert_eq!(said(&m, "M84 Y").as_deref(), Some("M84 A"));
        assert_eq!(said(&m, "M203 X200 Z12").as_deref(), None, "nothing about Y, same letters");
        assert_eq!(said(&m, "M104 S200").as_deref(), None);
        // A rotary axis set up as Y in mm of circumference: nothing changes.
        let y = RotaryConfig { rotary_axis: 'Y', rotary_unit: RotaryUnit::Mm, ..m.clone() };
        assert_eq!(said(&y, "M92 X80 Y80"), None);
        // Other axis letters are renamed, values kept.
        let uvw = RotaryConfig { axial_axis: 'U', radial_axis: 'W', ..m };
        assert_eq!(said(&uvw, "M201 X1000 Z100").as_deref(), Some("M201 U1000 W100"));
    }
}
