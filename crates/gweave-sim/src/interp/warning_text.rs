//! Warnings as a person reads them (`gweave sim`'s summary): the JSON report keeps every field
//! at full precision; the text rounds to what matters on a printer (0.001 mm, 0.1 C).

use std::fmt;

use super::report::WarningKind;
use crate::inkjet::InkjetWarning;

impl fmt::Display for WarningKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            WarningKind::OutOfBounds { axis, value_mm, min_mm, max_mm } => {
                write!(f, "{axis} = {value_mm:.3} mm is outside the axis range {min_mm:.3} .. {max_mm:.3} mm")
            }
            WarningKind::BelowBed { z_mm } => write!(f, "Z = {z_mm:.3} mm is below the bed"),
            WarningKind::ColdExtrusion { hotend, temp_c, min_c } => write!(
                f,
                "cold extrusion refused: hotend {hotend} at {temp_c:.1} C, below the minimum {min_c:.1} C"
            ),
            WarningKind::LongExtrusion { fed_mm, max_mm } => write!(
                f,
                "too long extrusion refused: {} mm in one move, more than the {} mm the firmware allows \
                 (EXTRUDE_MAXLENGTH); the move ran without it",
                gweave::range::short(*fed_mm),
                gweave::range::short(*max_mm)
            ),
            WarningKind::FaultNotInjected { fault, end_s } => {
                write!(f, "fault {fault} never injected: the run ended at {} s", gweave::range::short(*end_s))
            }
            WarningKind::ArcRefused { refusal } => {
                write!(f, "arc refused, the machine did not move: {refusal}")
            }
            WarningKind::UnknownCommand { command } => {
                write!(f, "unknown command {}", command.escape_debug())
            }
            WarningKind::InvalidExtruder { tool } => write!(f, "no tool or hotend {tool}"),
            WarningKind::Refused { message } => write!(f, "refused: {}", message.escape_debug()),
            WarningKind::Thermal { message } => write!(f, "{}", message.escape_debug()),
            WarningKind::WaitTimeout { heater } => write!(f, "heater {heater} never reached its target"),
            WarningKind::Inkjet { detail } => write!(f, "inkjet: {detail}"),
            WarningKind::ClockLimit { limit_s } => write!(
                f,
                "the run reached its limit of {} days of simulated time: stopped",
                gweave::range::short(limit_s / 86_400.0)
            ),
            WarningKind::Truncated { footer } => {
                write!(f, "{}", gweave::gcode::diag::Finding::NoFooter { footer: *footer })
            }
        }
    }
}

impl fmt::Display for InkjetWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            InkjetWarning::FireWithoutM400 { head, x_mm, y_mm } => {
                write!(f, "head {head} fired at X {x_mm:.3} Y {y_mm:.3} mm with no M400 since the last move")
            }
            InkjetWarning::MissingHead { x_mm, y_mm } => {
                write!(f, "fire without P at X {x_mm:.3} Y {y_mm:.3} mm: nothing fired")
            }
            InkjetWarning::UnknownHead { head } => write!(f, "no head {head} in the profile: nothing fired"),
            InkjetWarning::OffCanvas { head, x_mm, y_mm, lost } => {
                write!(f, "head {head} at X {x_mm:.3} Y {y_mm:.3} mm: {lost} drops off the canvas")
            }
            InkjetWarning::FireDuringRecoat { x_mm, y_mm } => {
                write!(f, "fired during a recoat at X {x_mm:.3} Y {y_mm:.3} mm")
            }
            InkjetWarning::NoRecoat { z_mm } => {
                write!(f, "layer at Z {z_mm:.3} mm fired with no recoat before it")
            }
            InkjetWarning::PistonTravel { axis, moved_mm, expected_mm } => write!(
                f,
                "recoat piston {axis} moved {moved_mm:.3} mm where the layer asks {expected_mm:.3} mm"
            ),
            InkjetWarning::SpreaderShort { reach_mm, bed_mm } => write!(
                f,
                "the spreader reached {:.3} .. {:.3} mm, not across the bed {:.3} .. {:.3} mm",
                reach_mm[0], reach_mm[1], bed_mm[0], bed_mm[1]
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_warning_reads_as_a_sentence_with_rounded_figures() {
        let w =
            WarningKind::OutOfBounds { axis: 'Y', value_mm: -3.0000000000000004, min_mm: 0.0, max_mm: 200.0 };
        assert_eq!(w.to_string(), "Y = -3.000 mm is outside the axis range 0.000 .. 200.000 mm");
        let w = WarningKind::ColdExtrusion { hotend: 0, temp_c: 24.999999999999996, min_c: 170.0 };
        assert_eq!(w.to_string(), "cold extrusion refused: hotend 0 at 25.0 C, below the minimum 170.0 C");
    }
}
