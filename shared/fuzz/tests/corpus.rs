//! Every file of the corpus (`corpus/decode/`: the versioned seeds and whatever libFuzzer added
//! locally) through the fuzz target's body, on any toolchain (`cargo xtask lint` runs it).

use std::path::Path;

#[test]
fn the_corpus_passes_the_fuzz_checks() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus/decode");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let path = e.unwrap().path();
        if path.is_file() {
            eprintln!("replaying {}", path.display());
            fbg_shared_fuzz::decode_input(&std::fs::read(&path).unwrap());
            n += 1;
        }
    }
    assert!(n >= 4, "the four versioned seeds are missing from {} ({n} files)", dir.display());
}
