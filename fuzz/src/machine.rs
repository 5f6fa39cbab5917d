//! The machine profile target of the virtual printer: any text, read as `--machine` of `sim`,
//! `estimate` and `serve`. Reading it gives a profile or an error, never a panic. Bytes that are
//! not UTF-8 are left out: the CLI refuses them before any parser sees them.

use gweave_sim::MachineProfile;

/// Reads `bytes` as a machine profile: parsed, normalised and validated, or refused.
pub fn machine_profile(bytes: &[u8]) {
    if let Ok(text) = std::str::from_utf8(bytes) {
        let _ = MachineProfile::from_toml_str(text);
    }
}
