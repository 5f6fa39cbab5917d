//! AFL++ entry point for the `m503` target; the check is `gweave_fuzz::m503::m503`.

fn main() {
    afl::fuzz!(|data: &[u8]| gweave_fuzz::m503::m503(data));
}
