//! AFL++ entry point for the `printhead_profile` target; the check is `gweave_fuzz::profiles::printhead_profile`.

fn main() {
    afl::fuzz!(|data: &[u8]| gweave_fuzz::profiles::printhead_profile(data));
}
