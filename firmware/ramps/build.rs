//! Reads the printer's settings (`../printer.toml`, or the file `GWEAVE_PRINTER` names, such as
//! `../printer-mixing.toml` for `make firmware`'s mixing image) at build time and writes them
//! as Rust constants into `$OUT_DIR/printer.rs`, which `src/main.rs` includes.
//!
//! The file is read by the controller core's own reader (`gweave_controller::printer_file`,
//! a build dependency): its keys, their ranges and their defaults are declared there once, for
//! this build and for the host alike. An unknown key, a wrong type or a value out of range
//! stops the build, naming the line.

use gweave_controller::printer_file;

/// The file read when `GWEAVE_PRINTER` names none, relative to `firmware/`.
const DEFAULT_PRINTER: &str = "printer.toml";

fn main() {
    if std::env::var("CARGO_CFG_TARGET_ARCH").as_deref() == Ok("avr") {
        // avr-libc's float arithmetic (libm.a: `__mulsf3`, `__addsf3`, `__divsf3`, ...,
        // hand-written AVR assembly) before Rust's `compiler_builtins`, whose portable versions
        // (weak symbols, so libm's win) multiply through 64-bit integers: about 8 times slower
        // on the 8-bit chip, and the main loop then planned a line in 17 ms (docs/firmware.md,
        // "Where the main loop's time goes").
        println!("cargo::rustc-link-lib=m");
        // avr-libc's `memcpy` and `memset` (libc.a, assembly: one byte in 8 cycles) likewise:
        // `compiler_builtins`' portable ones cost about twice that, and the main loop copies
        // some 900 bytes a streamed line (lines, blocks, segments): 11 000 cycles saved a line.
        println!("cargo::rustc-link-lib=c");
    }
    println!("cargo::rerun-if-env-changed=GWEAVE_PRINTER");
    let name = std::env::var("GWEAVE_PRINTER").unwrap_or_else(|_| DEFAULT_PRINTER.to_string());
    let path = format!("{}/../{name}", env!("CARGO_MANIFEST_DIR"));
    println!("cargo::rerun-if-changed={path}");
    let text =
        std::fs::read_to_string(&path).unwrap_or_else(|e| fail(&name, 0, &format!("cannot read it: {e}")));
    let out = std::env::var("OUT_DIR").expect("cargo sets OUT_DIR");
    // Written aside, then renamed over: a reader never sees half a file, and a target folder
    // seeded by hard links from another keeps the other's copy.
    let (tmp, dest) = (format!("{out}/printer.rs.tmp"), format!("{out}/printer.rs"));
    let file = printer_file::read(&text).unwrap_or_else(|e| fail(&name, e.line, &e.message));
    if file.has_rotary() && std::env::var_os("CARGO_FEATURE_ROTARY").is_none() {
        fail(&name, 0, "[rotary] needs the build's feature `rotary` (`--features rotary`)");
    }
    std::fs::write(&tmp, file.to_rust(&name)).expect("OUT_DIR is writable");
    std::fs::rename(&tmp, &dest).expect("OUT_DIR is writable");
}

/// Stop the build with a message naming the file and line.
fn fail(file: &str, line: usize, msg: &str) -> ! {
    eprintln!("firmware/{file}:{line}: {msg}");
    std::process::exit(1);
}
