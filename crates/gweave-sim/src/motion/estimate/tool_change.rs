//! What a `T<n>` waits for: whether the firmware lets the queued moves run out before it
//! changes tool. A drain ends the lookahead at a full stop, so it costs the deceleration into
//! the change and the acceleration out of it: on a two-tool print with a hundred changes, about
//! a second (`estimate` and `sim` on the same file must agree on it, to the microsecond).
//!
//! - Marlin (`Marlin/src/module/tool_change.cpp`, `tool_change()`): a machine with several
//!   extruders (`HAS_MULTI_EXTRUDER`: a hotend each, or several filaments on one nozzle) calls
//!   `planner.synchronize()` first, at every `T`, the active tool's own included, and before it
//!   refuses a tool it does not have. A mixing hotend's `T` is `mixer.T()`: it selects a stored
//!   mix for the moves to come and nothing waits. With one extruder, `T0` does nothing and any
//!   other tool is refused, without waiting.
//! - Klipper has no `T` of its own: a config's `T<n>` macro calls `ACTIVATE_EXTRUDER`
//!   (`klippy/kinematics/extruder.py`), which answers "already active" for the active extruder
//!   and otherwise calls `toolhead.flush_step_generation()`, flushing the lookahead to a stop.

use crate::motion::limits::CornerMode;
use crate::profile::MachineProfile;

/// How the machine's firmware carries out `T<n>`, as far as the motion queue goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ToolChange {
    /// Nothing waits: one extruder, or a mixing hotend's virtual tools. What a bare motion
    /// profile (no machine) assumes.
    #[default]
    Select,
    /// Marlin with several extruders: the queue drains at every `T`.
    Synchronize,
    /// Klipper's `ACTIVATE_EXTRUDER`: the queue drains when the extruder changes.
    Activate,
}

impl ToolChange {
    /// How `machine` changes tool: by its firmware (Klipper when it plans as Klipper does) and
    /// its extruders.
    pub fn of(machine: &MachineProfile) -> Self {
        let extruders = match machine.single_nozzle_tools {
            0 => machine.thermal.hotends.len(),
            n => n,
        };
        if machine.mixing_inputs > 0 || extruders < 2 {
            Self::Select
        } else if matches!(machine.motion.corners, CornerMode::Klipper(_)) {
            Self::Activate
        } else {
            Self::Synchronize
        }
    }

    /// Whether `T<to>` with tool `from` active waits for the queued moves.
    pub fn waits(self, from: u32, to: u32) -> bool {
        match self {
            Self::Select => false,
            Self::Synchronize => true,
            Self::Activate => from != to,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::limits::{KlipperLimits, MotionProfile};

    fn machine(hotends: usize, single_nozzle_tools: usize, mixing_inputs: usize) -> MachineProfile {
        let mut m = MachineProfile { single_nozzle_tools, mixing_inputs, ..MachineProfile::default() };
        let hotend = m.thermal.hotends[0];
        m.thermal.hotends = vec![hotend; hotends];
        m
    }

    #[test]
    fn each_firmware_and_extruder_count_waits_as_its_tool_change_does() {
        assert_eq!(ToolChange::of(&machine(1, 0, 0)), ToolChange::Select);
        assert_eq!(ToolChange::of(&machine(1, 0, 4)), ToolChange::Select);
        assert_eq!(ToolChange::of(&machine(2, 0, 0)), ToolChange::Synchronize);
        assert_eq!(ToolChange::of(&machine(1, 5, 0)), ToolChange::Synchronize);
        let mut klipper = machine(2, 0, 0);
        klipper.motion = MotionProfile::klipper(KlipperLimits::default());
        assert_eq!(ToolChange::of(&klipper), ToolChange::Activate);
        // Marlin waits even for the active tool; Klipper's ACTIVATE_EXTRUDER does not.
        assert!(ToolChange::Synchronize.waits(1, 1) && ToolChange::Synchronize.waits(0, 1));
        assert!(!ToolChange::Activate.waits(1, 1) && ToolChange::Activate.waits(0, 1));
        assert!(!ToolChange::Select.waits(0, 1));
    }
}
