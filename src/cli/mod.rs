//! The command line: clap's argument structs ([`args`]) and one runner per subcommand.
//! The only layer that knows clap: it turns flags into the plain configurations the
//! library takes ([`crate::server::Config`], [`crate::eval::loadgen::LoadConfig`],
//! [`crate::eval::report::ReportOptions`]) and chooses the backend.

pub mod args;
pub mod commands;
pub mod cull;
#[cfg(feature = "eval")]
pub mod eval;
#[cfg(feature = "eval")]
pub mod eval_args;
pub mod flags_table;
pub mod healthcheck;
pub mod pvs;
pub mod serve;

use anyhow::{Context, Result};
use clap::Parser;

use crate::core::engine::Backend;
use crate::core::scene::{Scene, demo_city, load_path};
use args::{BackendArgs, HealthcheckArgs, SceneArg, ServeArgs};
use commands::{Cli, Command};
pub use flags_table::flags_table;

/// Parses the command line and runs the subcommand (`serve` when none is given).
pub fn run() -> Result<()> {
    match Cli::parse().command {
        Some(Command::Serve(a)) => serve::run(a),
        Some(Command::Healthcheck(a)) => healthcheck(a),
        Some(Command::Cull(a)) => cull::run(a),
        Some(Command::Pvs(a)) => pvs::run(a),
        #[cfg(feature = "eval")]
        Some(Command::Loadgen(a)) => eval::loadgen(a),
        #[cfg(feature = "eval")]
        Some(Command::Animate(a)) => eval::animate(a),
        #[cfg(feature = "eval")]
        Some(Command::Eval(a)) => eval::run(a),
        #[cfg(feature = "eval")]
        Some(Command::Report(a)) => eval::report(a),
        None => serve::run(ServeArgs::default()),
    }
}

/// The backend a subcommand culls with, on a rayon pool of `--threads` threads.
pub fn open_backend(a: &BackendArgs) -> Result<Backend> {
    if a.threads > 0 {
        rayon::ThreadPoolBuilder::new()
            .num_threads(a.threads)
            .build_global()
            .context("starting the CPU thread pool")?;
    }
    let backend =
        Backend::open(a.backend).with_context(|| format!("opening the `{}` backend", a.backend))?;
    eprintln!("backend: {} ({})", backend.name(), backend.describe());
    Ok(backend)
}

/// The scene `--scene FILE` or `--demo` names, with a line on what was loaded.
pub fn load_scene(arg: &SceneArg) -> Result<Scene> {
    if arg.demo {
        return Ok(demo_city());
    }
    let path = arg.scene.as_ref().context("give --scene FILE or --demo")?;
    eprintln!("loading {} …", path.display());
    let scene = load_path(path).with_context(|| format!("loading {}", path.display()))?;
    eprintln!(
        "loaded {}: {} objects, {} triangles, {} test boxes{}",
        scene.name,
        scene.objects.len(),
        scene.triangle_count(),
        scene.boxes.len(),
        if scene.warnings.is_empty() {
            String::new()
        } else {
            format!(", {} warnings", scene.warnings.len())
        }
    );
    Ok(scene)
}

fn healthcheck(a: HealthcheckArgs) -> Result<()> {
    let url = a.url.unwrap_or_else(healthcheck::default_url);
    match healthcheck::check(&url, std::time::Duration::from_secs(2)) {
        Ok(()) => Ok(()),
        Err(e) => {
            eprintln!("unhealthy: {e}");
            std::process::exit(1);
        }
    }
}
