//! Running OpenVDB's own reader (Debian's `python3-openvdb`, the `pyopenvdb`
//! module of the system Python) from a test; shared by firn-io's and
//! firn-run's OpenVDB tests (`#[path]`-included).

use std::path::Path;
use std::process::Command;

/// The interpreter that Debian's `python3-openvdb` installs into.
pub const PYTHON: &str = "/usr/bin/python3";

/// Whether `pyopenvdb` imports; panics where it must
/// (`FIRN_REQUIRE_OPENVDB=1`) and does not.
pub fn openvdb_available() -> bool {
    let imports = Command::new(PYTHON)
        .args(["-c", "import pyopenvdb"])
        .output()
        .is_ok_and(|output| output.status.success());
    if !imports && std::env::var("FIRN_REQUIRE_OPENVDB").as_deref() == Ok("1") {
        panic!("FIRN_REQUIRE_OPENVDB=1 but {PYTHON} cannot import pyopenvdb");
    }
    if !imports {
        eprintln!("skipped: {PYTHON} cannot import pyopenvdb (apt-get install python3-openvdb)");
    }
    imports
}

/// Runs `script` with `path` and then `args` as `sys.argv[1..]`; returns
/// its standard output, or fails the test with OpenVDB's error.
pub fn run_openvdb(script: &str, path: &Path, args: &[String]) -> String {
    let output = Command::new(PYTHON)
        .args(["-c", script])
        .arg(path)
        .args(args)
        .output()
        .expect("python runs");
    assert!(
        output.status.success(),
        "OpenVDB could not read {}:\n{}",
        path.display(),
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout).expect("utf-8")
}
