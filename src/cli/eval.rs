//! The evaluation subcommands (cargo feature `eval`): `homcull eval` (every method and
//! the exact oracle on the same poses, as a table or JSON), `loadgen`, `animate` and
//! `report`.

use anyhow::{Context, Result, bail};
use homcull_proto::{Method, Pose};

use super::eval_args::{AnimateArgs, EvalArgs, LoadgenArgs, ReportArgs};
use super::{load_scene, open_backend};
use crate::core::camera::Camera;
use crate::core::resident::{Residency, ResidentScene};
use crate::core::sampler::METHOD;
use crate::eval::{MethodSpec, evaluate, table};

pub fn run(a: EvalArgs) -> Result<()> {
    let methods = a
        .methods
        .iter()
        .map(|m| {
            MethodSpec::parse(m, a.params.options(Method::Hom, None)?).map_err(anyhow::Error::msg)
        })
        .collect::<Result<Vec<_>>>()?;
    let scene = load_scene(&a.scene)?;
    let mut resident = ResidentScene::assemble(
        scene,
        Residency::evaluation(a.params.occluder_params()),
        open_backend(&a.backend)?,
    );
    let poses: Vec<Pose> = match (&a.random, &a.poses_file) {
        (Some(n), None) => {
            let res = resident.sample_poses(*n, a.seed, a.viewport);
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
    eprintln!(
        "culling {} poses with {} methods on {} …",
        cams.len(),
        methods.len() + 1,
        resident.engine.adapter()
    );
    let pvs = resident.pvs.take();
    let report = evaluate(
        &mut resident.engine,
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

/// `homcull loadgen`.
pub fn loadgen(a: LoadgenArgs) -> Result<()> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    if a.mode == "walk" {
        let host = crate::eval::loadgen::loopback(&a.url)?;
        let path = rt.block_on(crate::eval::latency::WalkPath::of(&host, &a.scene))?;
        let cfg = crate::eval::latency::WalkConfig {
            host,
            path,
            scene: a.scene.clone(),
            seconds: a.seconds as f32,
            delay_ms: a.delay_ms,
            query: a.stream_query.clone(),
            viewport: [960, 540],
        };
        let report = rt.block_on(crate::eval::latency::walk(&cfg))?;
        println!("{}", serde_json::to_string(&report)?);
        return Ok(());
    }
    if a.mode == "walkers" {
        let cfg = crate::eval::walkers::WalkersConfig {
            host: crate::eval::loadgen::loopback(&a.url)?,
            scene: a.scene.clone(),
            clients: a.clients,
            seconds: a.seconds,
            query: a.stream_query.clone(),
            viewport: [960, 540],
        };
        let report = rt.block_on(crate::eval::walkers::run(&cfg))?;
        if a.json {
            println!("{}", serde_json::to_string(&report)?);
        } else {
            println!("{}", report.summary());
        }
        return Ok(());
    }
    let report = rt.block_on(crate::eval::loadgen::run(&a.config()))?;
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!("{}", report.summary());
    }
    Ok(())
}

/// `homcull animate`.
pub fn animate(a: AnimateArgs) -> Result<()> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    let report = rt.block_on(crate::eval::animate::run(&a.config()))?;
    println!("{}", serde_json::to_string(&report)?);
    Ok(())
}

/// `homcull report`.
pub fn report(a: ReportArgs) -> Result<()> {
    crate::eval::report::run(&a.options(), open_backend(&a.backend)?)
}
