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
    c("G29", "bed levelling (firmware.mesh): probe the grid in simulated time, store a flat mesh, levelling on"),
    c("G90 G91", "absolute / relative coordinates (E too)"),
    c("G92", "set the logical position without moving"),
    c("M0 M1", "program stop: finish the moves, motors off; with m0 = \"seed\" also home and end the program"),
    c("M17 M18 M84", "motors on (accepted) / off (the axes must be homed again)"),
    c("M20 M21 M22", "SD card (firmware.sdcard, serve --sd DIR): list files (L: long names), mount, release"),
    c("M23 M24 M25 M26 M27", "SD print: select a file, start/resume, pause, set the byte position, status (S<n>: every n s)"),
    c("M28 M29 M30 M32 M33", "SD upload to a file / end it, delete a file, select and start, long name of a file"),
    c("M31", "print job time"),
    c("M42 M226", "set a pin / wait for a pin state (firmware.pin_control)"),
    c("M73 M117", "progress (accepted) and status message, sent to the host as //action:notification"),
    c("M75 M76 M77", "print job timer start / pause / stop"),
    c("M80 M81", "power on (firmware.psu_control) / off: heaters and motors off"),
    c("M82 M83", "absolute / relative extrusion"),
    c("M92", "steps per unit X Y Z E of the steppers"),
    c("M104 M109", "hotend target (T picks the hotend), M109 also waits: S while heating, R both ways"),
    c("M105", "report temperatures and heater powers: ok T:.. /.. B:.. /.. @:.. B@:.."),
    c("M106 M107", "part fan speed / off (the fan cools the hotend)"),
    c("M108 M410", "emergency parser: break a wait / quick stop (accepted: waits end by themselves)"),
    c("M110", "set the line number (serial protocol)"),
    c("M112", "emergency stop: heaters off, halted until M999"),
    c("M114", "position and motor counts after the queued moves"),
    c("M115", "firmware name, extruder count and the capabilities of the [firmware] table"),
    c("M116", "wait for every heater with a target (RepRapFirmware)"),
    c("M118", "print a message to the host (A1: // prefix, E1: echo: prefix)"),
    c("M119", "endstop states"),
    c("M140 M190", "bed target, M190 also waits: S while heating, R both ways"),
    c("M154", "report the position every S seconds (firmware.autoreport_pos)"),
    c("M155", "report temperatures every S seconds (0: off)"),
    c("M163 M164 M165 M166", "mixing: set a weight, store a virtual tool, mix at once, gradient (accepted)"),
    c("M201 M203 M204 M205", "acceleration, feed rate, print/travel acceleration, junction deviation (M205 J) or classic jerk (M205 X Y Z E) and minimum segment time (M205 B) limits"),
    c("M207 M208 M209", "firmware retraction: retract length (the planner's G10), recover, auto-retract"),
    c("M211", "software endstops on/off and their limits"),
    c("M220 M221", "feed rate / flow percentage (no S: report it)"),
    c("M300", "beep (accepted)"),
    c("M301", "set or report the hotend PID gains"),
    c("M303", "PID autotune on the thermal plant (relay method), U1 applies the gains"),
    c("M304", "set or report the bed PID gains"),
    c("M400", "wait for the queued moves to finish; its ok takes that time in wall time too (hosts time it)"),
    c("M420", "bed levelling on/off (S), mesh report (V)"),
    c("M500 M501 M502 M503", "settings: save to / load from the EEPROM file, factory defaults, report"),
    c("M524", "abort the SD print"),
    c("M563 M567", "tool definition (accepted) and mix ratios (RepRapFirmware)"),
    c("M568", "tool temperature, as G10 P S (RepRapFirmware 3.3+; on a mixing hotend, the nozzle's)"),
    c("M600", "filament change (firmware.advanced_pause): park, host prompts, wait for M108 / M876 S0, purge, resume"),
    c("M851", "probe offsets X Y Z (firmware.probe)"),
    c("M876", "answer a host prompt (firmware.prompt_support)"),
    c("M928", "log the following commands to an SD file until M29"),
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
