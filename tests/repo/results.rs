//! The tables README.md and docs/performance.md quote are what `results/tables.py`
//! makes from the run directories under `results/`: a figure typed by hand, or a run
//! changed without its tables made again, fails here.

use std::process::Command;

#[test]
fn quoted_tables_match_their_runs() {
    let root = env!("CARGO_MANIFEST_DIR");
    let out = Command::new("python3")
        .args(["results/tables.py", "--check"])
        .current_dir(root)
        .output()
        .expect("python3 runs results/tables.py");
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
