//! AFL++ entry point for the `controller_reader` target; the check is
//! `gweave_fuzz::controller::controller_reader`.

fn main() {
    afl::fuzz!(|data: &[u8]| gweave_fuzz::controller::controller_reader(data));
}
