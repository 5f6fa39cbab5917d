//! AFL++ entry point for the `gcode` target; the check is `gweave_fuzz::gcode::check`.

fn main() {
    afl::fuzz!(|data: &[u8]| gweave_fuzz::gcode::check(data));
}
