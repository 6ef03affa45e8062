//! A culling method of the caller's own, in one file: "frustum only, objects nearer
//! than d". It is one type behind `CullMethod` and one registration line
//! (`CullSettings::with_method`); every backend runs it through the shared planning,
//! and its answers are checked against the same rule computed here by brute force.
//! A method whose passes a backend lacks is refused with `CullError::Unsupported`.

use crate::common;

use homcull::core::camera::Camera;
use homcull::core::cull::{
    CullError, CullMethod, Needs, Passes, PreparedScene, empty_mask, set_bit,
};
use homcull::core::engine::{Backend, Engine};
use homcull::core::geom::Aabb;
use homcull::core::occluders::OccluderParams;
use homcull::core::scene::demo_city;
use homcull_proto::{CullOptions, Method, Pose};

/// Frustum culling, and of what is in the frustum only the objects whose bounds come
/// within `d` metres of the eye; on the backend named `only`, or on every one.
#[derive(Debug)]
struct NearerThan {
    d: f32,
    only: Option<&'static str>,
}

/// The distance from `p` to the nearest point of `b`.
fn distance(b: &Aabb, p: glam::Vec3) -> f32 {
    p.clamp(b.min, b.max).distance(p)
}

impl CullMethod for NearerThan {
    fn name(&self) -> &'static str {
        "nearer_than"
    }

    fn needs(&self, _: &CullOptions) -> Needs {
        Needs::FRUSTUM
    }

    fn passes(&self, _: &CullOptions) -> Option<Passes> {
        None
    }

    fn runs_on(&self, backend: &str) -> bool {
        self.only.is_none_or(|b| b == backend)
    }

    fn mask_from_plan(&self, prep: &PreparedScene, cam: &Camera, candidates: &[u32]) -> Vec<u32> {
        let mut mask = empty_mask(prep.scene.objects.len());
        for &c in candidates {
            if distance(&prep.scene.objects[c as usize].aabb, cam.position) < self.d {
                set_bit(&mut mask, c);
            }
        }
        mask
    }
}

static NEARER: NearerThan = NearerThan {
    d: 40.0,
    only: None,
};
static NEARER_ON_CPU: NearerThan = NearerThan {
    d: 40.0,
    only: Some("cpu"),
};

/// Poses at street height across the demo city.
fn poses() -> Vec<Pose> {
    common::server::street_walk(6, [320, 180])
}

fn backends() -> Vec<Backend> {
    let mut b = vec![Backend::Native, Backend::Reference];
    b.extend(common::gpu().map(Backend::Gpu));
    b
}

#[test]
fn a_method_of_ones_own_culls_on_every_backend_by_its_rule() {
    let scene = demo_city();
    let frustum_options = CullOptions {
        method: Method::Frustum,
        ..CullOptions::default()
    };
    for backend in backends() {
        let name = backend.name();
        let mut engine = Engine::new(scene.clone(), OccluderParams::default(), backend);
        let frustum = engine.settings(frustum_options);
        let nearer = frustum.with_method(&NEARER);
        assert_ne!(nearer, frustum, "settings tell methods apart");
        let (mut kept, mut dropped) = (0, 0);
        for pose in poses() {
            let cam = Camera::new(&pose).unwrap();
            let all = engine.cull(std::slice::from_ref(&cam), &frustum).unwrap();
            let near = engine.cull(std::slice::from_ref(&cam), &nearer).unwrap();
            let (all, near) = (&all[0], &near[0]);
            // By brute force: the frustum's objects within d.
            let want: Vec<u32> = all
                .visible
                .iter()
                .copied()
                .filter(|&c| distance(&scene.objects[c as usize].aabb, cam.position) < NEARER.d)
                .collect();
            assert_eq!(near.visible, want, "{name}: the rule's objects, ascending");
            assert_eq!(near.candidates, all.candidates, "{name}: the same frustum");
            assert_eq!(
                near.stats.occluders_used, 0,
                "{name}: it draws no occluders"
            );
            kept += want.len();
            dropped += all.visible.len() - want.len();
        }
        assert!(
            kept > 0 && dropped > 0,
            "{name}: d cuts the walk's frustum sets ({kept} kept, {dropped} dropped)"
        );
    }
}

/// A method that runs on one backend only says so: the others refuse it, in words that
/// name it and them, before any work; that backend answers it.
#[test]
fn a_method_for_one_backend_is_refused_by_the_others() {
    let cam = Camera::new(&poses()[0]).unwrap();
    for backend in backends() {
        let name = backend.name();
        let mut engine = Engine::new(demo_city(), OccluderParams::default(), backend);
        let s = engine
            .settings(CullOptions::default())
            .with_method(&NEARER_ON_CPU);
        let answer = engine.cull(std::slice::from_ref(&cam), &s);
        if name == "cpu" {
            let r = answer.unwrap();
            assert!(!r[0].visible.is_empty(), "the native backend answers it");
            continue;
        }
        let e = answer.expect_err(name);
        assert!(
            matches!(e, CullError::Unsupported { method: "nearer_than", backend } if backend == name),
            "{name}: {e:?}"
        );
        assert_eq!(
            e.to_string(),
            format!("method `nearer_than` does not run on the {name} backend")
        );
    }
}
