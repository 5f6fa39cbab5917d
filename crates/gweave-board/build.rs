//! Builds the C shim over libsimavr (csrc/shim.c) and links libsimavr (Debian's
//! libsimavr-dev: headers in /usr/include/simavr).
fn main() {
    println!("cargo::rerun-if-changed=csrc/shim.c");
    cc::Build::new()
        .file("csrc/shim.c")
        .include("/usr/include/simavr")
        // The loop that runs the chip instruction by instruction: optimised even in tests.
        .opt_level(2)
        // simavr's callbacks get parameters a callback may not need.
        .flag("-Wno-unused-parameter")
        .compile("gweave_board_shim");
    println!("cargo::rustc-link-lib=dylib=simavr");
}
