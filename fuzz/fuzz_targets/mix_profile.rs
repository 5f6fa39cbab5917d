//! AFL++ entry point for the `mix_profile` target; the check is `gweave_fuzz::profiles::mix_profile`.

fn main() {
    afl::fuzz!(|data: &[u8]| gweave_fuzz::profiles::mix_profile(data));
}
