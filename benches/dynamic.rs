//! Moving objects (divan; one thread): what an update and the next scene version cost.
//! Run: `cargo bench --bench dynamic`. Scenes: the demo city and munich (from
//! `HOMCULL_SCENES`, default `../shared/scenes`).
//!
//! - `apply`: checking and recording an update of `n` objects (`Dynamics::apply`),
//!   what a writer's request costs the server before it answers.
//! - `advance`: building the next version after `n` objects that were already moving
//!   moved on (`snapshot::advance`: the scene copied, the moved objects placed from
//!   their loaded geometry, the object and occluder BVHs refitted), what the first
//!   cull after an update pays once.

use std::sync::{Arc, OnceLock};

use divan::Bencher;
use homcull::core::cull::PreparedScene;
use homcull::core::dynamic::{Dynamics, snapshot};
use homcull::core::occluders::OccluderParams;
use homcull::core::scene::{demo_city, load_path};
use homcull_proto::{ObjectTransform, TransformsRequest};

const MOVED: &[usize] = &[1, 16, 256];

fn main() {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .expect("a one-thread pool");
    divan::main();
}

fn scenes() -> &'static [(String, Arc<PreparedScene>)] {
    static SCENES: OnceLock<Vec<(String, Arc<PreparedScene>)>> = OnceLock::new();
    SCENES.get_or_init(|| {
        let dir = std::env::var("HOMCULL_SCENES").unwrap_or_else(|_| "../shared/scenes".into());
        let mut out = vec![("demo".to_string(), demo_city())];
        if let Ok(s) = load_path(&std::path::Path::new(&dir).join("munich.glb")) {
            out.push(("munich".to_string(), s));
        }
        // As the server holds them: without the files' extras.
        out.into_iter()
            .map(|(n, mut s)| {
                s.extras = None;
                s.objects.iter_mut().for_each(|o| o.extras = None);
                (
                    n,
                    Arc::new(PreparedScene::new(s, OccluderParams::default())),
                )
            })
            .collect()
    })
}

/// `n` objects spread over the scene, each moved a little and given a velocity.
fn update(prep: &PreparedScene, n: usize) -> TransformsRequest {
    let count = prep.scene.objects.len();
    TransformsRequest {
        objects: (0..n)
            .map(|k| ObjectTransform {
                id: (k * count / n) as u32,
                translation: Some([0.5, 0.0, 0.25]),
                velocity: Some([2.0, 0.0, 0.0]),
                ..Default::default()
            })
            .collect(),
        horizon_ms: None,
    }
}

fn args() -> impl Iterator<Item = (usize, usize)> {
    (0..2).flat_map(|s| MOVED.iter().map(move |&n| (s, n)))
}

#[divan::bench(args = args())]
fn apply(bencher: Bencher, (scene, n): (usize, usize)) {
    let Some((_, prep)) = scenes().get(scene) else {
        return;
    };
    let req = update(prep, n);
    let mut d = Dynamics::new(prep.clone());
    d.apply(&req, usize::MAX).unwrap(); // the first one indexes vertex ranges
    bencher.bench_local(|| d.apply(&req, usize::MAX).unwrap());
}

/// Steady traffic: the same `n` objects, already moving, move on (the set of moving
/// objects, and so the occluders, unchanged).
#[divan::bench(args = args())]
fn advance(bencher: Bencher, (scene, n): (usize, usize)) {
    let Some((_, prep)) = scenes().get(scene) else {
        return;
    };
    let mut d = Dynamics::new(prep.clone());
    d.apply(&update(prep, n), usize::MAX).unwrap();
    let first = snapshot::advance(prep, prep, &d.take_changes(0).unwrap());
    let mut next = update(prep, n);
    for t in &mut next.objects {
        t.translation = Some([0.75, 0.0, 0.5]);
    }
    d.apply(&next, usize::MAX).unwrap();
    let changes = d.take_changes(1).unwrap();
    bencher.bench_local(|| snapshot::advance(prep, &first, &changes));
}
