//! AFL++ entry point for the `machine_profile` target; the check is `gweave_fuzz::machine::machine_profile`.

fn main() {
    afl::fuzz!(|data: &[u8]| gweave_fuzz::machine::machine_profile(data));
}
