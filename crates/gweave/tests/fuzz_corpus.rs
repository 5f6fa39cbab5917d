//! Replays what fuzzing kept (`fuzz/corpus/<target>/`, `fuzz/crashes/<target>/`) through the fuzz
//! targets' own checks, included from `fuzz/src/`: the G-code target (line reader, lexer and
//! machine state, and `cat`'s byte-for-byte copy), the binary G-code reader and the engine's
//! profile loaders. The machine profile's and `M503` corpora are replayed in gweave-sim's tests. docs/reliability.md, "Fuzzing".

use std::path::PathBuf;

#[path = "../../../fuzz/src/bgcode.rs"]
mod bgcode;
#[path = "../../../fuzz/src/gcode.rs"]
mod gcode;
#[path = "../../../fuzz/src/profiles.rs"]
mod profiles;
#[path = "../../../fuzz/src/replay.rs"]
mod replay;

fn fuzz_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz")
}

#[test]
fn fuzz_corpus_gcode_is_read_without_panic_and_copied_byte_for_byte() {
    replay::replay(&fuzz_dir(), "gcode", gcode::check);
}

#[test]
fn fuzz_corpus_mix_profile_is_read_or_refused_without_panic() {
    replay::replay(&fuzz_dir(), "mix_profile", profiles::mix_profile);
}

#[test]
fn fuzz_corpus_printhead_profile_is_read_or_refused_without_panic() {
    replay::replay(&fuzz_dir(), "printhead_profile", profiles::printhead_profile);
}

#[test]
fn fuzz_corpus_bgcode_is_read_or_refused_without_panic() {
    replay::replay(&fuzz_dir(), "bgcode", bgcode::bgcode);
}
