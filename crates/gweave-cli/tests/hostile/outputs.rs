//! Output paths: no output may name an input, two outputs may not name one file, `--in-place`
//! keeps what the user had.

use crate::harness::*;

/// Regression: `gweave cat in -o x --report x` replaced the G-code output by the JSON report.
/// (Kept here as the suite's first case; the outputs work adds the rest.)
#[test]
fn report_naming_the_input_is_refused() {
    let (dir, input) = dir_with_fixture("cura/cura_torus.gcode", "in.gcode");
    let before = snapshot(dir.path());
    gweave(dir.path(), &["stats", "in.gcode", "--report", "in.gcode"]).run().assert_refused("in.gcode");
    assert_eq!(snapshot(dir.path()), before);
    assert_no_temp_left(dir.path());
    assert!(input.exists());
}
