//! Fixtures sliced for a nozzle per tool, made one nozzle's for the tests of purge-shift on
//! their dialects: purge-shift refuses them as sliced (their temperatures for named tools differ,
//! or PrusaSlicer's `; single_extruder_multi_material = 0` says so). Only those lines change;
//! every other byte, and the line count, is the file's. Shared by the test crates that run
//! purge-shift on them (`#[path]`).
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// `text` as for one nozzle: every `M104 T<n>`/`M109 T<n>` line (Cura's preheat and standby of
/// a nozzle per tool) made a comment, as `gweave mix` does with the temperatures of a tool not
/// printing; a temperature written `S<c> T<n>` (PrusaSlicer's and Slic3r's, each tool's at the
/// start) set to the one `T0` was last given, so every tool still heats (the virtual dual
/// extruder refuses a cold one), to one temperature; PrusaSlicer's setting made single-extruder
/// multi-material.
pub fn one_nozzle(text: &[u8]) -> Vec<u8> {
    const SEPARATE: &[u8] = b"; single_extruder_multi_material = 0";
    let mut out = Vec::with_capacity(text.len() + 4096);
    let mut t0: Option<Vec<u8>> = None;
    for line in text.split_inclusive(|&b| b == b'\n') {
        let heats = line.starts_with(b"M104 S") || line.starts_with(b"M109 S");
        let end = line[6.min(line.len())..].iter().position(|&b| b == b' ').map_or(line.len(), |i| i + 6);
        if line.starts_with(b"M104 T") || line.starts_with(b"M109 T") {
            out.push(b';');
            out.extend_from_slice(line);
        } else if heats && line[end..].starts_with(b" T0") {
            t0 = Some(line[6..end].to_vec());
            out.extend_from_slice(line);
        } else if let Some(celsius) = t0.as_ref().filter(|_| heats && line[end..].starts_with(b" T")) {
            out.extend_from_slice(&line[..6]);
            out.extend_from_slice(celsius);
            out.extend_from_slice(&line[end..]);
        } else if let Some(rest) = line.strip_prefix(SEPARATE) {
            out.extend_from_slice(b"; single_extruder_multi_material = 1");
            out.extend_from_slice(rest);
        } else {
            out.extend_from_slice(line);
        }
    }
    out
}

/// The fixture `rel` (under tests/data) as bytes.
pub fn fixture(rel: &str) -> Vec<u8> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(rel);
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The fixture `rel` as for one nozzle, written into `dir` under its own name.
pub fn one_nozzle_in(dir: &Path, rel: &str) -> PathBuf {
    let path = dir.join(Path::new(rel).file_name().unwrap());
    std::fs::write(&path, one_nozzle(&fixture(rel))).unwrap();
    path
}
