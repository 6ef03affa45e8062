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
    assert!(err.contains("native CPU"), "says so: {err}");
    let out: serde_json::Value = serde_json::from_slice(&lenient.stdout).expect("JSON");
    assert!(!out["visible"].as_array().expect("visible IDs").is_empty());
}

#[test]
fn eval_on_the_native_backend_names_it_and_culls_conservatively() {
    let out = Command::new(env!("CARGO_BIN_EXE_homcull"))
        .args([
            "eval",
            "--demo",
            "--random",
            "6",
            "--viewport",
            "320x180",
            "--backend",
            "cpu",
            "--threads",
            "1",
            "--methods",
            "hom-refine,hom-raster",
            "--json",
        ])
        .output()
        .expect("the binary runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("backend: cpu"), "names the backend: {err}");
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert!(
        report["adapter"].as_str().unwrap().contains("native CPU (")
            && report["adapter"].as_str().unwrap().contains("1 threads"),
        "{}",
        report["adapter"]
    );
    for m in ["hom-refine", "hom-raster"] {
        assert_eq!(report["methods"][m]["false_culls"], 0, "{m}");
    }
    assert!(
        report["methods"]["hom-refine"]["efficiency"]
            .as_f64()
            .unwrap()
            > 0.5
    );
    assert!(
        report["methods"]["hom-refine"]["ms_per_pose"]["p50"]
            .as_f64()
            .unwrap()
            > 0.0
    );
}

#[test]
fn an_unknown_backend_is_a_clear_error() {
    let out = Command::new(env!("CARGO_BIN_EXE_homcull"))
        .args(["eval", "--demo", "--random", "1", "--backend", "tpu"])
        .output()
        .expect("the binary runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("unknown backend `tpu`"), "{err}");
}
