//! The Python module (python/): its pytest suite, run with the wheel
//! `make test` built and installed into the project's Python environment.

use crate::util::*;

#[test]
#[ignore = "interop: needs the pcsss wheel in the Python environment; `make test` builds it"]
fn the_python_module_s_tests_pass() {
    let py = python_with(&["pcsss", "pytest", "numpy"]);
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let bins = bin("ssmulti");
    let o = std::process::Command::new(py)
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(root.join("python/tests"))
        .env("PCSSS_BIN", bins.parent().unwrap())
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{out}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
}
