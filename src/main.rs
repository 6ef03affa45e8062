//! The `homcull` binary: parse the command line, init tracing, run a subcommand.

use std::sync::Arc;

use anyhow::{Context, Result, bail};
use clap::Parser;
use homcull::camera::Camera;
use homcull::config::{Cli, Command, CullArgs, EvalArgs, HealthcheckArgs, SceneArg, ServeArgs};
use homcull::engine::Engine;
use homcull::eval::{MethodSpec, evaluate, table};
use homcull::occluders::OccluderParams;
use homcull::pvs::Pvs;
use homcull::sampler::{METHOD, PoseSampler};
use homcull::scene::{Scene, demo_city, load_path};
use homcull_proto::{CullOptions, CullResponse, Pose};

fn main() -> Result<()> {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "homcull=info,wgpu=error".into()),
        )
        .with_writer(std::io::stderr)
        // Colours only on a terminal: container logs stay plain text.
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    let cli = Cli::parse();
    match cli.command {
        Some(Command::Serve(a)) => serve(a),
        Some(Command::Healthcheck(a)) => healthcheck(a),
        Some(Command::Loadgen(a)) => homcull::loadgen::main(a),
        Some(Command::Cull(a)) => cull(a),
        Some(Command::Eval(a)) => eval(a),
        Some(Command::Report(a)) => homcull::report::main(a),
        None => serve(ServeArgs::default()),
    }
}

fn serve(a: ServeArgs) -> Result<()> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    rt.block_on(async move {
        let gpu = homcull::gpu::open_gpu()?.map(Arc::new);
        let listener = tokio::net::TcpListener::bind(a.addr)
            .await
            .with_context(|| format!("listening on {}", a.addr))?;
        let addr = listener.local_addr()?;
        let data_dir = a.data_dir.display().to_string();
        let (state, shutdown) = homcull::server::start(a, gpu)
            .with_context(|| format!("starting the server (data dir {data_dir})"))?;
        eprintln!(
            "homcull listening on http://{addr}/ (viewer at /, API docs at /docs) on {}; data in {data_dir}",
            state.adapter
        );
        homcull::server::run(listener, state, shutdown, homcull::server::shutdown_signal()).await?;
        eprintln!("homcull stopped");
        Ok(())
    })
}

fn healthcheck(a: HealthcheckArgs) -> Result<()> {
    let url = a
        .url
        .unwrap_or_else(homcull::server::healthcheck::default_url);
    match homcull::server::healthcheck::check(&url, std::time::Duration::from_secs(2)) {
        Ok(()) => Ok(()),
        Err(e) => {
            eprintln!("unhealthy: {e}");
            std::process::exit(1);
        }
    }
}

fn load_scene(arg: &SceneArg) -> Result<Scene> {
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

fn engine(scene: Scene, budget: u32) -> Result<Engine> {
    let gpu = homcull::gpu::open_gpu()?.map(Arc::new);
    let params = OccluderParams {
        budget_triangles: budget,
        ..Default::default()
    };
    let engine = Engine::new(scene, params, gpu);
    if engine.cpu_fallback {
        eprintln!("warning: no GPU adapter; using the CPU reference implementation (slow)");
    }
    Ok(engine)
}

fn cull(a: CullArgs) -> Result<()> {
    let pose: Pose = serde_json::from_str(&a.pose).context("parsing --pose")?;
    let cam = Camera::new(&pose)?;
    let mut engine = engine(load_scene(&a.scene)?, a.params.budget)?;
    let settings = engine.settings(CullOptions {
        method: a.method,
        threshold: a.params.threshold,
        deb: a.params.deb,
        refine: !a.params.no_refine,
    });
    let r = engine
        .cull(std::slice::from_ref(&cam), &settings)?
        .remove(0);
    let out = CullResponse {
        visible: r.visible,
        stats: r.stats,
    };
    println!("{}", serde_json::to_string(&out)?);
    Ok(())
}

fn eval(a: EvalArgs) -> Result<()> {
    let scene = load_scene(&a.scene)?;
    let pvs = match Pvs::from_scene(&scene) {
        Some(Ok(p)) => Some(p),
        Some(Err(e)) => {
            eprintln!("warning: the scene's PVS data is unusable: {e}");
            None
        }
        None => None,
    };
    let poses: Vec<Pose> = match (&a.random, &a.poses_file) {
        (Some(n), None) => {
            let sampler = PoseSampler::new(&scene);
            let accept = |p: glam::Vec3| pvs.as_ref().is_none_or(|v| v.cluster_at(p) >= 0);
            let res = sampler.sample(*n, a.seed, a.viewport, &accept);
            eprintln!(
                "sampled {} poses in {} attempts: {METHOD}",
                res.poses.len(),
                res.attempts
            );
            if res.poses.len() < *n {
                eprintln!("warning: only {} of {n} poses found", res.poses.len());
            }
            res.poses
        }
        (None, Some(path)) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading {}", path.display()))?;
            serde_json::from_str(&text)
                .with_context(|| format!("parsing {} as a JSON array of poses", path.display()))?
        }
        _ => bail!("give --random N or --poses-file FILE"),
    };
    let cams = poses
        .iter()
        .enumerate()
        .map(|(i, p)| Camera::new(p).with_context(|| format!("pose {i}")))
        .collect::<Result<Vec<_>>>()?;
    let methods = a
        .methods
        .iter()
        .map(|m| {
            MethodSpec::parse(m, a.params.threshold, a.params.deb, !a.params.no_refine)
                .map_err(anyhow::Error::msg)
        })
        .collect::<Result<Vec<_>>>()?;
    let mut engine = engine(scene, a.params.budget)?;
    eprintln!(
        "culling {} poses with {} methods on {} …",
        cams.len(),
        methods.len() + 1,
        engine.adapter()
    );
    let report = evaluate(
        &mut engine,
        &cams,
        &methods,
        a.batch,
        pvs.as_ref(),
        a.profile,
    )?;
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        print!("{}", table(&report));
    }
    Ok(())
}
