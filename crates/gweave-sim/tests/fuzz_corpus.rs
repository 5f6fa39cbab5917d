//! Replays what fuzzing kept for the machine profile and the `M503` reader
//! (`fuzz/corpus/<target>/`, `fuzz/crashes/<target>/`) through the fuzz targets' own checks,
//! included from `fuzz/src/`. docs/reliability.md, "Fuzzing".

use std::path::PathBuf;

#[path = "../../../fuzz/src/m503.rs"]
mod m503;
#[path = "../../../fuzz/src/machine.rs"]
mod machine;
#[path = "../../../fuzz/src/replay.rs"]
mod replay;

fn fuzz_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz")
}

#[test]
fn fuzz_corpus_machine_profile_is_read_or_refused_without_panic() {
    replay::replay(&fuzz_dir(), "machine_profile", machine::machine_profile);
}

#[test]
fn fuzz_corpus_m503_is_read_or_refused_without_panic_and_makes_profiles_in_range() {
    replay::replay(&fuzz_dir(), "m503", m503::m503);
}
