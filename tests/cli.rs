//! The binary's adapter choice from the command line: a `WGPU_ADAPTER_NAME` that matches
//! no adapter is a clear error under `HOMCULL_REQUIRE_GPU=1` and a CPU fallback with a
//! warning otherwise, never a panic.

use std::process::Command;

fn cull_demo(require_gpu: bool) -> std::process::Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_homcull"));
    cmd.args([
        "cull",
        "--demo",
        "--pose",
        r#"{"position":[0,1.7,3],"look_at":[40,1.7,10],"viewport":[64,36]}"#,
    ])
    .env("WGPU_ADAPTER_NAME", "no adapter is called this")
    .env_remove("HOMCULL_REQUIRE_GPU");
    if require_gpu {
        cmd.env("HOMCULL_REQUIRE_GPU", "1");
    }
    cmd.output().expect("the binary runs")
}

#[test]
fn an_unknown_adapter_name_is_an_error_or_the_cpu_fallback() {
    let strict = cull_demo(true);
    let err = String::from_utf8_lossy(&strict.stderr);
    assert!(!strict.status.success(), "HOMCULL_REQUIRE_GPU=1 must fail");
    assert!(
        !err.contains("panicked"),
        "a panic instead of an error: {err}"
    );
    assert!(
        err.contains("WGPU_ADAPTER_NAME") && err.contains("matches none"),
        "the error names the variable: {err}"
    );

    let lenient = cull_demo(false);
    let err = String::from_utf8_lossy(&lenient.stderr);
    assert!(lenient.status.success(), "falls back to the CPU: {err}");
    assert!(err.contains("CPU reference"), "says so: {err}");
    let out: serde_json::Value = serde_json::from_slice(&lenient.stdout).expect("JSON");
    assert!(!out["visible"].as_array().expect("visible IDs").is_empty());
}
