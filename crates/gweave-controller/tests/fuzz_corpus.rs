//! Replays what fuzzing kept for the controller core (`fuzz/corpus/controller*/`,
//! `fuzz/crashes/controller*/`) through the fuzz targets' own checks, included from
//! `fuzz/src/`. docs/reliability.md, "Fuzzing".

use std::path::PathBuf;

#[path = "../../../fuzz/src/controller.rs"]
mod controller;
#[path = "../../../fuzz/src/replay.rs"]
mod replay;

fn fuzz_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz")
}

#[test]
fn fuzz_corpus_controller_reader_reads_or_refuses_every_line() {
    replay::replay(&fuzz_dir(), "controller_reader", controller::controller_reader);
}

#[test]
fn fuzz_corpus_controller_answers_any_bytes_without_panic() {
    replay::replay(&fuzz_dir(), "controller", controller::controller);
}
