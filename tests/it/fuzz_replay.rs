//! The fuzz corpus and every input that once crashed, hung or
//! over-allocated, replayed on stable with the fuzz targets' own code
//! (`pcsss::tools::fuzz`): `fuzz/corpus/TARGET/` (a minimised corpus) and
//! `fixtures/fuzz/TARGET/` (the inputs behind fixed bugs, named by what
//! they found). Each must finish without a panic; hangs are the fuzzer's to find
//! (`-timeout`), not a timed test's.

use std::path::Path;

use pcsss::tools::fuzz;

/// Every file of `dir` (none when it does not exist).
fn files(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.path()).collect())
        .unwrap_or_default();
    v.sort();
    v
}

/// A fuzz target's body.
type Target = fn(&[u8]);

#[test]
fn the_fuzz_corpus_and_past_crashes_replay_cleanly() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let targets: [(&str, Target); 7] = [
        ("ply", fuzz::ply),
        ("exr", fuzz::exr),
        ("obj", fuzz::obj),
        ("json", fuzz::json),
        ("manifest", fuzz::manifest),
        ("texture", fuzz::texture),
        ("usd", fuzz::usd),
    ];
    let mut total = 0;
    for (name, run) in targets {
        for dir in [
            root.join("fuzz/corpus").join(name),
            root.join("fixtures/fuzz").join(name),
        ] {
            for f in files(&dir) {
                let data = std::fs::read(&f).unwrap();
                let caught = pcsss::formats::usd::stage::panics_caught();
                let done = std::panic::catch_unwind(|| run(&data));
                assert!(done.is_ok(), "{}: panicked", f.display());
                // A panic the USD reader's guard turned into an error is
                // a bug of the reader all the same.
                assert_eq!(
                    pcsss::formats::usd::stage::panics_caught(),
                    caught,
                    "{}: the USD reader panicked",
                    f.display()
                );
                total += 1;
            }
        }
    }
    assert!(total > 0, "no corpus found");
    eprintln!("{total} fuzz inputs replayed");
}
