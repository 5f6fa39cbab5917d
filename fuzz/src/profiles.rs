//! The profile targets of the engine: any text, read as a mix profile (`gweave mix --config`) or
//! a printhead profile (`gweave raster --head`). Reading it gives a profile or an error, never a
//! panic. Bytes that are not UTF-8 are left out: the CLI refuses them before any parser sees them.

use gweave::gen::printhead::PrintheadProfile;
use gweave::post::mix::profile::MixProfile;

/// Reads `bytes` as a mix profile: parsed and validated, or refused.
pub fn mix_profile(bytes: &[u8]) {
    if let Ok(text) = std::str::from_utf8(bytes) {
        let _ = MixProfile::from_toml_str(text);
    }
}

/// Reads `bytes` as a printhead profile: parsed and validated, or refused.
pub fn printhead_profile(bytes: &[u8]) {
    if let Ok(text) = std::str::from_utf8(bytes) {
        let _ = PrintheadProfile::from_toml(text);
    }
}
