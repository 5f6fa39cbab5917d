//! AFL++ entry point for the `controller` target; the check is `gweave_fuzz::controller::controller`.

fn main() {
    afl::fuzz!(|data: &[u8]| gweave_fuzz::controller::controller(data));
}
