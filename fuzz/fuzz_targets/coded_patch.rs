#![no_main]
//! `cargo fuzz run coded_patch`: the body is `tessera_preprocess::fuzzing::coded_patch`,
//! which the corpus regression test (`preprocess/tests/fuzz_corpus.rs`) also runs.

use libfuzzer_sys::fuzz_target;

mod asan;

fuzz_target!(|data: &[u8]| {
    tessera_preprocess::fuzzing::coded_patch(data);
});
