//! Replays what fuzzing kept for the machine profile (`fuzz/corpus/machine_profile/`,
//! `fuzz/crashes/machine_profile/`) through the fuzz target's own check, included from
//! `fuzz/src/`. docs/reliability.md, "Fuzzing".

use std::path::PathBuf;

#[path = "../../../fuzz/src/machine.rs"]
mod machine;
#[path = "../../../fuzz/src/replay.rs"]
mod replay;

#[test]
fn fuzz_corpus_machine_profile_is_read_or_refused_without_panic() {
    let fuzz_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz");
    replay::replay(&fuzz_dir, "machine_profile", machine::machine_profile);
}
