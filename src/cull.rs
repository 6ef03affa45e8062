//! Culling methods behind one trait, and the per-pose plan they share.
//!
//! A cull takes a batch of cameras (one pose is a batch of one) and answers each with
//! the IDs that may be visible. The CPU-side preparation is the same for every backend
//! ([`plan`]): frustum-cull the scene BVH, pick the in-frustum test boxes, select
//! occluders, build the box-based depth estimation buffer. A backend ([`Culler`])
//! then runs the image-space work: the GPU one ([`crate::gpu::GpuBackend`]) records a
//! whole batch into one submission with one readback; [`CpuBackend`] runs the CPU
//! reference of every pass.
//!
//! Methods: `frustum` (BVH only), `hom`, `hzb`, and `exact` (the ID-buffer oracle that
//! defines ground truth). `hom` with `refine` (the default) re-tests the objects that
//! pass its box test per pixel of their own triangles ([`CpuBackend::refine`]).

use std::time::Instant;

use homcull_proto::{CullOptions, CullStats, DebVariant, Method};

use crate::bvh::BoxBvh;
use crate::camera::Camera;
use crate::gpu::profile::PassTimes;
use crate::hom::deb::{DEFAULT_TILE, DepthEstimationBuffer};
use crate::hom::level_thresholds;
use crate::hom::pyramid::{self, LevelLayout};
use crate::hom::raster::{raster_depth, raster_ids, raster_triangle};
use crate::hom::test::{PyramidView, hom_occluded, hzb_occluded};
use crate::occluders::{OccluderDb, OccluderParams, OccluderSelection};
use crate::scene::Scene;

/// Why a cull failed.
#[derive(Debug, thiserror::Error)]
pub enum CullError {
    #[error("threshold must be in (0, 1], got {0}")]
    Threshold(f32),
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
}

/// A scene with the structures culling needs, built once and kept resident.
pub struct PreparedScene {
    pub scene: Scene,
    pub bvh: BoxBvh,
    pub occluders: OccluderDb,
}

impl PreparedScene {
    pub fn new(scene: Scene, occluder_params: OccluderParams) -> Self {
        let occluders = OccluderDb::build(&scene, occluder_params);
        Self::with_occluders(scene, occluders)
    }

    /// Prepares a scene whose occluder database was built before (e.g. read from a cache).
    pub fn with_occluders(scene: Scene, occluders: OccluderDb) -> Self {
        let boxes: Vec<_> = scene.objects.iter().map(|o| o.aabb).collect();
        let bvh = BoxBvh::new(&boxes);
        PreparedScene {
            scene,
            bvh,
            occluders,
        }
    }
}

/// Everything that shapes a cull besides the poses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CullSettings {
    pub options: CullOptions,
    /// Occluder triangles rendered per pose.
    pub budget_triangles: u32,
    /// Tile side of the `tiles` DEB, pixels.
    pub deb_tile: u32,
}

impl CullSettings {
    pub fn new(options: CullOptions, prepared: &PreparedScene) -> Self {
        CullSettings {
            options,
            budget_triangles: prepared.occluders.params.budget_triangles,
            deb_tile: DEFAULT_TILE,
        }
    }

    /// True when the box test's survivors are refined per pixel (`hom` with `refine`).
    pub fn refines(&self) -> bool {
        self.options.method == Method::Hom && self.options.refine
    }

    pub fn validate(&self) -> Result<(), CullError> {
        let t = self.options.threshold;
        if t > 0.0 && t <= 1.0 {
            Ok(())
        } else {
            Err(CullError::Threshold(t))
        }
    }
}

/// The CPU-side preparation of one pose.
pub struct PosePlan {
    pub cam: Camera,
    /// In-frustum object IDs, ascending.
    pub candidates: Vec<u32>,
    /// Indices into `scene.boxes` of the in-frustum test boxes of the candidates.
    pub test_boxes: Vec<u32>,
    pub occluders: OccluderSelection,
    pub deb: DepthEstimationBuffer,
}

/// Frustum culling, test-box selection, occluder selection and box DEB for one pose.
pub fn plan(prep: &PreparedScene, cam: &Camera, s: &CullSettings) -> PosePlan {
    plan_preferring(prep, cam, s, &[])
}

/// [`plan`] whose occluder selection takes the objects in `prefer` (ascending IDs)
/// first ([`OccluderDb::select_preferring`]).
pub fn plan_preferring(
    prep: &PreparedScene,
    cam: &Camera,
    s: &CullSettings,
    prefer: &[u32],
) -> PosePlan {
    let mut candidates = Vec::new();
    prep.bvh.frustum_query(cam, |i| candidates.push(i));
    candidates.sort_unstable();
    let occludes = matches!(s.options.method, Method::Hom | Method::Hzb);
    let mut test_boxes = Vec::new();
    let mut occluders = OccluderSelection::default();
    if occludes {
        for &c in &candidates {
            let (a, b) = prep.scene.box_ranges[c as usize];
            test_boxes
                .extend((a..b).filter(|&i| cam.intersects(&prep.scene.boxes[i as usize].aabb)));
        }
        occluders = prep
            .occluders
            .select_preferring(&prep.scene, cam, s.budget_triangles, prefer);
    }
    let variant = if s.options.method == Method::Hom {
        s.options.deb
    } else {
        DebVariant::Raster
    };
    let deb = DepthEstimationBuffer::build(
        variant,
        s.deb_tile,
        cam,
        occluders
            .ids
            .iter()
            .map(|&i| prep.scene.objects[i as usize].aabb),
    );
    PosePlan {
        cam: cam.clone(),
        candidates,
        test_boxes,
        occluders,
        deb,
    }
}

/// The answer for one pose.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseResult {
    /// Object IDs that may be visible, ascending.
    pub visible: Vec<u32>,
    pub stats: CullStats,
}

/// A backend that runs the image-space part of culling for a batch of poses.
pub trait Culler {
    /// Adapter or implementation name, for reports.
    fn describe(&self) -> String;

    /// Visibility bitmasks (`words_per_pose(objects)` words per pose) of a batch of
    /// planned poses sharing one viewport size.
    fn visibility(
        &mut self,
        prep: &PreparedScene,
        plans: &[PosePlan],
        s: &CullSettings,
    ) -> Result<Vec<Vec<u32>>, CullError>;

    /// Starts measuring GPU time per pass (`on`) or stops; false where this backend
    /// cannot (the CPU reference, adapters without timestamp queries).
    fn set_profiling(&mut self, _on: bool) -> bool {
        false
    }

    /// GPU time per pass since profiling started or the times were last taken.
    fn take_pass_times(&mut self) -> Option<PassTimes> {
        None
    }

    /// Culls a batch of cameras with the chosen method.
    fn cull(
        &mut self,
        prep: &PreparedScene,
        cams: &[Camera],
        s: &CullSettings,
    ) -> Result<Vec<PoseResult>, CullError> {
        self.cull_preferring(prep, cams, s, &[])
    }

    /// [`Culler::cull`] where pose k's occluder selection takes the objects of
    /// `prefer[k]` first (ascending IDs, e.g. what the same client saw at its previous
    /// pose; see [`plan_preferring`]). Poses past the end of `prefer` prefer nothing.
    fn cull_preferring(
        &mut self,
        prep: &PreparedScene,
        cams: &[Camera],
        s: &CullSettings,
        prefer: &[&[u32]],
    ) -> Result<Vec<PoseResult>, CullError> {
        s.validate()?;
        let start = Instant::now();
        // Planning is independent per pose: spread it over the CPU cores.
        let plans: Vec<PosePlan> = {
            use rayon::prelude::*;
            cams.par_iter()
                .enumerate()
                .map(|(k, c)| plan_preferring(prep, c, s, prefer.get(k).copied().unwrap_or(&[])))
                .collect()
        };
        tracing::debug!(
            target: "homcull::timing",
            poses = cams.len(),
            plan_ms = start.elapsed().as_secs_f64() * 1e3,
            "planned a batch"
        );
        let mut masks = Vec::with_capacity(plans.len());
        let mut image_ms = 0.0;
        if s.options.method != Method::Frustum {
            // Batches run per viewport size; consecutive equal sizes share one batch.
            let mut i = 0;
            while i < plans.len() {
                let size = (plans[i].cam.width, plans[i].cam.height);
                let j = i + plans[i..]
                    .iter()
                    .take_while(|p| (p.cam.width, p.cam.height) == size)
                    .count();
                let t = Instant::now();
                masks.extend(self.visibility(prep, &plans[i..j], s)?);
                image_ms += t.elapsed().as_secs_f64() * 1e3;
                i = j;
            }
        }
        let n = cams.len().max(1) as f64;
        let total_ms = start.elapsed().as_secs_f64() * 1e3 / n;
        let objects = prep.scene.objects.len() as u32;
        Ok(plans
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let visible = match masks.get(k) {
                    Some(m) => p
                        .candidates
                        .iter()
                        .copied()
                        .filter(|&c| m[c as usize / 32] >> (c % 32) & 1 == 1)
                        .collect(),
                    None => p.candidates.clone(),
                };
                let stats = CullStats {
                    objects,
                    candidates: p.candidates.len() as u32,
                    culled_by_frustum: objects - p.candidates.len() as u32,
                    culled_by_occlusion: (p.candidates.len() - visible.len()) as u32,
                    occluders_used: p.occluders.ids.len() as u32,
                    occluder_triangles: p.occluders.triangles,
                    gpu_ms: image_ms / n,
                    total_ms,
                };
                PoseResult { visible, stats }
            })
            .collect())
    }
}

/// Words of a per-pose visibility bitmask.
pub fn words_per_pose(objects: usize) -> usize {
    objects.div_ceil(32).max(1)
}

fn set_bit(mask: &mut [u32], id: u32) {
    mask[id as usize / 32] |= 1 << (id % 32);
}

pub(crate) fn has_bit(mask: &[u32], id: u32) -> bool {
    mask[id as usize / 32] & (1 << (id % 32)) != 0
}

/// The CPU reference of every pass: the test oracle for the GPU and the fallback
/// when no adapter exists.
#[derive(Default)]
pub struct CpuBackend;

impl CpuBackend {
    fn triangles<'a>(
        scene: &'a Scene,
        ids: &'a [u32],
    ) -> impl Iterator<Item = (u32, [glam::Vec3; 3])> + 'a {
        ids.iter().flat_map(move |&id| {
            scene
                .corners_of(&scene.objects[id as usize])
                .map(move |t| (id, t))
        })
    }

    /// Level-0 occluder depth map of one pose (0 = uncovered).
    pub fn occluder_depth(scene: &Scene, p: &PosePlan) -> Vec<f32> {
        let mut depth = vec![0.0; (p.cam.width * p.cam.height) as usize];
        raster_depth(
            &p.cam,
            Self::triangles(scene, &p.occluders.ids).map(|(_, t)| t),
            &mut depth,
        );
        depth
    }

    /// Visibility bitmask of the per-object test on a given pyramid.
    pub fn test_boxes(
        scene: &Scene,
        p: &PosePlan,
        s: &CullSettings,
        layout: &LevelLayout,
        opacity: &[f32],
        depth: &[f32],
    ) -> Vec<u32> {
        let mut mask = vec![0u32; words_per_pose(scene.objects.len())];
        let view = PyramidView {
            layout,
            opacity,
            depth,
        };
        let thr = level_thresholds(s.options.threshold, layout.levels());
        for &b in &p.test_boxes {
            let tb = &scene.boxes[b as usize];
            if has_bit(&mask, tb.object) {
                continue; // another sub-bound of this object is already visible
            }
            let Some(r) = p.cam.project_box(&tb.aabb) else {
                continue;
            };
            let hidden = match s.options.method {
                Method::Hzb => hzb_occluded(&r, &view),
                _ => hom_occluded(&r, &view, &thr, s.options.deb, &p.deb),
            };
            if !hidden {
                set_bit(&mut mask, tb.object);
            }
        }
        mask
    }

    /// True if every pixel centre the object covers lies strictly behind the occluder
    /// depth map `occluders` (level 0, 0 = uncovered). No depth margin: the map holds
    /// the same rasterizer's depths of a subset of the oracle's fragments, so a pixel
    /// the oracle gives to the object is at or in front of the map there (the GPU's
    /// early depth test makes the same comparison on its own depths).
    pub fn hidden_per_pixel(scene: &Scene, cam: &Camera, occluders: &[f32], id: u32) -> bool {
        let o = &scene.objects[id as usize];
        scene.corners_of(o).all(|tri| {
            let mut hidden = true;
            raster_triangle(cam, tri, |x, y, d| {
                let occ = occluders[(y * cam.width + x) as usize];
                hidden &= occ > 0.0 && occ < d;
            });
            hidden
        })
    }

    /// The refinement of the box test (`refine`): clears the bit of every object that
    /// passed it but is hidden at each of its own pixels. GPU twin: `fs_refine` in
    /// `raster.wgsl`.
    pub fn refine(scene: &Scene, p: &PosePlan, occluders: &[f32], mask: &mut [u32]) {
        for &c in &p.candidates {
            if has_bit(mask, c) && Self::hidden_per_pixel(scene, &p.cam, occluders, c) {
                mask[c as usize / 32] &= !(1 << (c % 32));
            }
        }
    }

    /// The exact oracle on the CPU: objects owning at least one pixel of the ID buffer.
    pub fn exact(scene: &Scene, p: &PosePlan) -> Vec<u32> {
        let n = (p.cam.width * p.cam.height) as usize;
        let mut ids = vec![u32::MAX; n];
        let mut depth = vec![0.0; n];
        raster_ids(
            &p.cam,
            Self::triangles(scene, &p.candidates),
            &mut ids,
            &mut depth,
        );
        let mut mask = vec![0u32; words_per_pose(scene.objects.len())];
        for id in ids.into_iter().filter(|&id| id != u32::MAX) {
            set_bit(&mut mask, id);
        }
        mask
    }
}

impl Culler for CpuBackend {
    fn describe(&self) -> String {
        "CPU reference (no GPU)".into()
    }

    fn visibility(
        &mut self,
        prep: &PreparedScene,
        plans: &[PosePlan],
        s: &CullSettings,
    ) -> Result<Vec<Vec<u32>>, CullError> {
        let scene = &prep.scene;
        Ok(plans
            .iter()
            .map(|p| match s.options.method {
                Method::Exact => Self::exact(scene, p),
                _ => {
                    let layout = LevelLayout::new(p.cam.width, p.cam.height);
                    let occluders = Self::occluder_depth(scene, p);
                    let (opacity, depth) = pyramid::build(&layout, &occluders);
                    let mut mask = Self::test_boxes(scene, p, s, &layout, &opacity, &depth);
                    if s.refines() {
                        Self::refine(scene, p, &occluders, &mut mask);
                    }
                    mask
                }
            })
            .collect())
    }
}
