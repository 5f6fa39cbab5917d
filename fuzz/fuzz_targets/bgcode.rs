//! AFL++ entry point for the `bgcode` target; the check is `gweave_fuzz::bgcode::bgcode`.

fn main() {
    afl::fuzz!(|data: &[u8]| gweave_fuzz::bgcode::bgcode(data));
}
