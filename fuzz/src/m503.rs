//! The `M503` target of the virtual printer: any text, read as `gweave machine from-m503` reads a
//! board's report. Reading it gives a profile or an error, never a panic, and never an
//! allocation sized by a number in the text (`M92 T99999999999 E1` once asked for 4.8 TB). A
//! profile it gives is one the simulator takes (every value in its range) and reads back the
//! same from the TOML the command writes. Bytes that are not UTF-8 are left out: the CLI refuses
//! them before the reader sees them.

use gweave_sim::{from_m503, MachineProfile};

/// Reads `bytes` as an `M503` report; a profile made must validate and round-trip.
pub fn m503(bytes: &[u8]) {
    let Ok(text) = std::str::from_utf8(bytes) else { return };
    let Ok(made) = from_m503(text) else { return };
    made.profile.validate().expect("a profile from M503 is in range");
    let written = toml::to_string(&made.profile).expect("a profile writes as TOML");
    let again = MachineProfile::from_toml_str(&written).expect("the written profile reads back");
    assert_eq!(again, made.profile, "the profile read back differs");
}
