//! The command set of the virtual printer, one line each: the reply to `?` (the seed
//! controller's help) and the table in `docs/gcode.md` come from this list, and tests keep both
//! equal to it and check that the interpreter dispatches every command in it.

/// One entry of the command list: the codes it covers and what the virtual printer does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CommandHelp {
    /// The codes, space-separated, as written in G-code (`G0 G1`, `T<n>`, `?`).
    pub codes: &'static str,
    /// What the virtual printer does with them, one line.
    pub what: &'static str,
}

const fn c(codes: &'static str, what: &'static str) -> CommandHelp {
    CommandHelp { codes, what }
}

/// Every command the interpreter carries out, in the order of the help listing.
pub const COMMANDS: &[CommandHelp] = &[
    c("G0 G1", "linear move (G0 a travel), through the lookahead planner and the steppers"),
    c("G2 G3", "arc clockwise / counter-clockwise in XY (I J centre or R), planned as 1 mm chords"),
    c("G4", "dwell P milliseconds or S seconds, after the queued moves"),
    c("G10 G11", "firmware retract / recover (45 / 8 mm/s), Marlin's `G10 S1` too; G10 with P (tool) and S sets a tool temperature (RepRapFirmware)"),
    c("G20 G21", "inches / millimetres"),
    c("G28", "home the named axes (all without words) against the endstops, with Marlin's bump"),
    c("G90 G91", "absolute / relative coordinates (E too)"),
    c("G92", "set the logical position without moving"),
    c("M0 M1", "program stop: finish the moves, motors off"),
    c("M17 M18 M84", "motors on (accepted) / off (the axes must be homed again)"),
    c("M73 M117", "progress and LCD message, accepted"),
    c("M82 M83", "absolute / relative extrusion"),
    c("M104 M109", "hotend target (T picks the hotend), M109 also waits: S while heating, R both ways"),
    c("M105", "report temperatures and heater powers: ok T:.. /.. B:.. /.. @:.. B@:.."),
    c("M106 M107", "part fan speed / off (the fan cools the hotend)"),
    c("M110", "set the line number (serial protocol)"),
    c("M112", "emergency stop: heaters off, halted until M999"),
    c("M114", "position and motor counts after the queued moves"),
    c("M115", "firmware name, extruder count and capabilities"),
    c("M116", "wait for every heater with a target (RepRapFirmware)"),
    c("M119", "endstop states"),
    c("M140 M190", "bed target, M190 also waits: S while heating, R both ways"),
    c("M155", "report temperatures every S seconds (0: off)"),
    c("M163 M164 M165 M166", "mixing: set a weight, store a virtual tool, mix at once, gradient (accepted)"),
    c("M201 M203 M204 M205", "acceleration, feed rate, print/travel acceleration, junction deviation (M205 J) or classic jerk (M205 X Y Z E) and minimum segment time (M205 B) limits"),
    c("M220 M221", "feed rate / flow percentage (no S: report it)"),
    c("M301", "set or report the hotend PID gains"),
    c("M303", "PID autotune on the thermal plant (relay method), U1 applies the gains"),
    c("M400", "wait for the queued moves to finish"),
    c("M563 M567", "tool definition (accepted) and mix ratios (RepRapFirmware)"),
    c("M568", "tool temperature, as G10 P S (RepRapFirmware 3.3+; on a mixing hotend, the nozzle's)"),
    c("M578 M700", "inkjet fire at the carriage position (machines with a printhead)"),
    c("M999", "restart after a halt"),
    c("T<n>", "select a tool (a virtual mixing tool on a mixing hotend)"),
    c("SET_VELOCITY_LIMIT SET_KINEMATIC_POSITION", "Klipper's limits and position (Klipper mode)"),
    c("?", "this list"),
];

/// The `?` reply: a title line, then `echo:  <codes>  <what>` per command.
pub fn help_lines() -> Vec<String> {
    std::iter::once("echo:gweave-sim commands:".to_owned())
        .chain(COMMANDS.iter().map(|c| format!("echo:  {:<19}  {}", c.codes, c.what)))
        .collect()
}
