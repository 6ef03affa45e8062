//! Random camera poses where a person would stand.
//!
//! Culling quality depends on where the camera is: a pose inside a wall sees nothing
//! (everything looks culled), a pose high above a city sees everything. Evaluating on
//! such poses says little about the walk-through case HOM is for. This sampler puts the
//! eye at standing height above a walkable floor, in open space, looking roughly level,
//! using only ray casts against the scene's triangles, so it works on any scene: a
//! generated city, an OpenStreetMap extract, a game map (where the caller can add the
//! map's own "is this point in the playable space" test through `accept`).
//!
//! See [`METHOD`] for the procedure; the CLI prints it next to every evaluation.

use glam::{Vec2, Vec3, Vec3A, Vec3Swizzles};
use homcull_proto::Pose;
use obvhs::BvhBuildParams;
use obvhs::bvh2::Bvh2;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::bvh::build_bounded;
use crate::geom::Aabb;
use crate::scene::Scene;

/// How poses are drawn, in words, for reports.
pub const METHOD: &str = "random (x, z) in the scene bounds; a ray cast straight down from above the scene \
collects every hit; hits on triangles with |normal.y| > 0.7 are candidate floors, tried lowest first; \
the eye is 1.7 m above the floor; a floor is accepted if (a) a ray up from it is clear for 2.2 m, \
(b) 26 rays spread evenly over the sphere from the eye all hit nothing closer than 0.3 m and at most \
20 % of those that hit something hit a back face (geometric normal, counter-clockwise winding, pointing \
away from the eye: inside a closed solid nearly every hit is a back face), and (c) the caller's predicate \
(e.g. a BSP cluster check) accepts the eye; yaw uniform in [0, 360)°, pitch uniform in [-10, 10]°; \
fov_y 60°, near 0.1 m, far max(2 × scene diagonal, 100 m); at most 200 attempts per pose; seeded ChaCha8";

/// Eye height above the floor (metres).
pub const EYE_HEIGHT: f32 = 1.7;
/// Free height required above a floor point (metres): a person must fit.
pub const HEADROOM: f32 = 2.2;
/// Closest any surface may be to the eye (metres).
pub const MIN_SURFACE_DISTANCE: f32 = 0.3;
/// Largest fraction of probe hits that may be back faces before the eye counts as
/// inside geometry.
pub const MAX_BACK_FACE_FRACTION: f32 = 0.2;
/// Rays cast from a candidate eye to judge whether it is in open space.
pub const PROBE_RAYS: usize = 26;
/// A triangle is a floor candidate if its unit normal's |y| exceeds this.
pub const FLOOR_MIN_NORMAL_Y: f32 = 0.7;
/// Largest |pitch| of a sampled view (degrees).
pub const MAX_PITCH_DEG: f32 = 10.0;
/// Attempts allowed per requested pose before the sampler gives up.
pub const ATTEMPTS_PER_POSE: usize = 200;
/// Vertical field of view, near plane and least far plane of sampled poses.
pub const FOV_Y_DEG: f32 = 60.0;
/// Eyes [`PoseSampler::walk_start`] chooses from.
pub const START_CANDIDATES: usize = 32;
/// Level directions it tries at each.
pub const START_DIRECTIONS: usize = 16;
/// Eyes this close in height to the lowest count as on the same (street) level.
pub const SAME_STREET_M: f32 = 0.5;
pub const NEAR: f32 = 0.1;
pub const MIN_FAR: f32 = 100.0;

/// Rays start this far (metres) off the surface they leave, so they do not hit it.
const SURFACE_LIFT: f32 = 0.01;
/// Floors closer than this in height (metres) are one floor (coplanar duplicates).
const SAME_FLOOR: f32 = 0.01;

/// The poses found and the effort it took.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleResult {
    pub poses: Vec<Pose>,
    /// Random (x, z) positions tried, successful ones included; at most
    /// `ATTEMPTS_PER_POSE × n`. `attempts - poses.len()` were rejected.
    pub attempts: usize,
}

impl SampleResult {
    /// Attempts that produced no pose.
    pub fn rejected(&self) -> usize {
        self.attempts - self.poses.len()
    }
}

/// Samples standing-height poses in open space; holds a triangle BVH of the scene.
pub struct PoseSampler {
    /// The scene's finite, non-degenerate triangles.
    triangles: Vec<Triangle>,
    /// Unit geometric normal of each triangle (counter-clockwise winding).
    normals: Vec<Vec3>,
    /// `None` when the scene has no usable triangle.
    bvh: Option<Bvh2>,
    bounds: Aabb,
    margin: f32,
    far: f32,
    probe_directions: Vec<Vec3>,
}

impl std::fmt::Debug for PoseSampler {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PoseSampler")
            .field("triangles", &self.triangles.len())
            .field("bounds", &self.bounds)
            .field("margin", &self.margin)
            .finish_non_exhaustive()
    }
}

impl PoseSampler {
    /// Builds the triangle BVH of `scene` (once; sampling reuses it).
    pub fn new(scene: &Scene) -> Self {
        let (triangles, normals) = usable_triangles(scene);
        let bvh = (!triangles.is_empty()).then(|| {
            let boxes: Vec<_> = triangles.iter().map(obvhs::Boundable::aabb).collect();
            build_bounded(&boxes, BvhBuildParams::fastest_build())
        });
        let bounds = scene.bounds;
        let far = (2.0 * bounds.diagonal()).max(MIN_FAR);
        PoseSampler {
            triangles,
            normals,
            bvh,
            bounds,
            margin: 0.0,
            far: if far.is_finite() { far } else { MIN_FAR },
            probe_directions: sphere_directions(PROBE_RAYS),
        }
    }

    /// Keeps sampled (x, z) at least `metres` inside the scene bounds (e.g. to stay
    /// off a map's outer hull). Clamped so the region never turns inside out.
    pub fn with_margin(mut self, metres: f32) -> Self {
        self.margin = if metres.is_finite() {
            metres.max(0.0)
        } else {
            0.0
        };
        self
    }

    /// Up to `n` poses, deterministic for `seed` (given a deterministic `accept`).
    /// `accept(eye)` is an extra test a candidate eye must pass.
    pub fn sample(
        &self,
        n: usize,
        seed: u64,
        viewport: [u32; 2],
        accept: &dyn Fn(Vec3) -> bool,
    ) -> SampleResult {
        let mut result = SampleResult {
            poses: Vec::with_capacity(n),
            attempts: 0,
        };
        let Some(region) = self.sampling_region() else {
            return result;
        };
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let max_attempts = n.saturating_mul(ATTEMPTS_PER_POSE);
        while result.poses.len() < n && result.attempts < max_attempts {
            result.attempts += 1;
            let x = lerp(region.0.x, region.1.x, rng.random());
            let z = lerp(region.0.y, region.1.y, rng.random());
            if let Some(eye) = self.standing_eye_at(x, z, accept) {
                result.poses.push(self.pose_at(eye, &mut rng, viewport));
            }
        }
        result
    }

    /// Where a walker may start: among [`START_CANDIDATES`] sampled eyes (seed 1) on
    /// the lowest floor found (a street rather than a roof), the eye and level
    /// direction with the longest view that ends on geometry (down a street, not into
    /// a wall a metre away, nor out of the scene into nothing), and a point 10 m along
    /// it. `None` if the scene has no place to stand.
    pub fn walk_start(&self, accept: &dyn Fn(Vec3) -> bool) -> Option<(Vec3, Vec3)> {
        let poses = self.sample(START_CANDIDATES, 1, [960, 540], accept).poses;
        let lowest = poses.iter().map(|p| p.position[1]).min_by(f32::total_cmp)?;
        let street = poses
            .iter()
            .map(|p| Vec3::from(p.position))
            .filter(|eye| eye.y <= lowest + SAME_STREET_M);
        let mut best: Option<(f32, Vec3, Vec3)> = None;
        for eye in street {
            for k in 0..START_DIRECTIONS {
                let yaw = k as f32 * std::f32::consts::TAU / START_DIRECTIONS as f32;
                let dir = Vec3::new(yaw.sin(), 0.0, yaw.cos());
                let Some((view, _)) = self.closest_hit(eye, dir, self.far) else {
                    continue; // looks out of the scene
                };
                if best.is_none_or(|(longest, ..)| view > longest) {
                    best = Some((view, eye, dir));
                }
            }
        }
        best.map(|(_, eye, dir)| (eye, eye + dir * 10.0))
    }

    /// The (x, z) rectangle to draw from, as (min, max); `None` if the scene is empty.
    fn sampling_region(&self) -> Option<(Vec2, Vec2)> {
        let b = self.bounds;
        if self.bvh.is_none() || b.is_empty() || !b.min.is_finite() || !b.max.is_finite() {
            return None;
        }
        let half = (b.max.xz() - b.min.xz()) * 0.5;
        let margin = Vec2::splat(self.margin).min(half);
        Some((b.min.xz() + margin, b.max.xz() - margin))
    }

    /// The eye above the lowest valid floor at (x, z), if any.
    pub fn standing_eye_at(&self, x: f32, z: f32, accept: &dyn Fn(Vec3) -> bool) -> Option<Vec3> {
        self.floors_at(x, z).into_iter().find_map(|floor| {
            let eye = floor + Vec3::Y * EYE_HEIGHT;
            (self.has_headroom(floor) && self.is_in_open_space(eye) && accept(eye)).then_some(eye)
        })
    }

    /// Points on floor-like triangles straight below (x, z) from the scene top, lowest first.
    fn floors_at(&self, x: f32, z: f32) -> Vec<Vec3> {
        let top = Vec3::new(x, self.bounds.max.y + 1.0, z);
        let mut heights: Vec<f32> = self
            .all_hits(top, Vec3::NEG_Y)
            .into_iter()
            .filter(|&(_, tri)| self.normals[tri].y.abs() > FLOOR_MIN_NORMAL_Y)
            .map(|(t, _)| top.y - t)
            .collect();
        heights.sort_by(f32::total_cmp);
        heights.dedup_by(|a, b| (*a - *b).abs() < SAME_FLOOR);
        heights.into_iter().map(|y| Vec3::new(x, y, z)).collect()
    }

    /// A person fits: nothing within `HEADROOM` straight above the floor point.
    fn has_headroom(&self, floor: Vec3) -> bool {
        let from = floor + Vec3::Y * SURFACE_LIFT;
        self.closest_hit(from, Vec3::Y, HEADROOM - SURFACE_LIFT)
            .is_none()
    }

    /// The eye is in open space: no surface too close, and not (mostly) looking at the
    /// inside of closed geometry.
    fn is_in_open_space(&self, eye: Vec3) -> bool {
        let mut hits = 0usize;
        let mut back_faces = 0usize;
        for &dir in &self.probe_directions {
            let Some((t, tri)) = self.closest_hit(eye, dir, f32::INFINITY) else {
                continue;
            };
            if t < MIN_SURFACE_DISTANCE {
                return false;
            }
            hits += 1;
            if self.normals[tri].dot(dir) > 0.0 {
                back_faces += 1;
            }
        }
        back_faces as f32 <= MAX_BACK_FACE_FRACTION * hits as f32
    }

    /// A pose at `eye` with a random yaw and a near-level pitch.
    fn pose_at(&self, eye: Vec3, rng: &mut ChaCha8Rng, viewport: [u32; 2]) -> Pose {
        let yaw = lerp(0.0, std::f32::consts::TAU, rng.random());
        let pitch = lerp(-MAX_PITCH_DEG, MAX_PITCH_DEG, rng.random()).to_radians();
        let forward = Vec3::new(
            pitch.cos() * yaw.sin(),
            pitch.sin(),
            pitch.cos() * yaw.cos(),
        );
        let mut pose = Pose::looking_at(eye.to_array(), (eye + forward).to_array());
        pose.fov_y_deg = FOV_Y_DEG;
        pose.viewport = viewport;
        pose.near = NEAR;
        pose.far = self.far;
        pose
    }

    /// Distance and triangle of the nearest hit along a unit direction within `max_t`.
    fn closest_hit(&self, origin: Vec3, dir: Vec3, max_t: f32) -> Option<(f32, usize)> {
        let bvh = self.bvh.as_ref()?;
        let ray = Ray::new(origin.into(), dir.into(), 0.0, max_t);
        let mut hit = RayHit::none();
        let found = bvh.ray_traverse(ray, &mut hit, |ray, id| {
            self.triangle(bvh, id).intersect(ray)
        });
        found.then(|| {
            (
                hit.t,
                bvh.primitive_indices[hit.primitive_id as usize] as usize,
            )
        })
    }

    /// Every hit along an unbounded ray, as (distance, triangle), unordered.
    fn all_hits(&self, origin: Vec3, dir: Vec3) -> Vec<(f32, usize)> {
        let mut hits = Vec::new();
        let Some(bvh) = self.bvh.as_ref() else {
            return hits;
        };
        let ray = Ray::new_inf(origin.into(), dir.into());
        bvh.ray_traverse_anyhit(ray, |ray, id| {
            let t = self.triangle(bvh, id).intersect(ray);
            if t.is_finite() {
                hits.push((t, bvh.primitive_indices[id] as usize));
            }
        });
        hits
    }

    /// The triangle behind a BVH primitive slot.
    fn triangle(&self, bvh: &Bvh2, slot: usize) -> &Triangle {
        &self.triangles[bvh.primitive_indices[slot] as usize]
    }
}

/// The scene's triangles that rays can meaningfully hit (finite, with area), and their
/// unit counter-clockwise normals. Out-of-range indices are skipped, not trusted.
fn usable_triangles(scene: &Scene) -> (Vec<Triangle>, Vec<Vec3>) {
    let mut triangles = Vec::with_capacity(scene.indices.len() / 3);
    let mut normals = Vec::with_capacity(scene.indices.len() / 3);
    for tri in scene.indices.chunks_exact(3) {
        let corner = |k: usize| scene.positions.get(tri[k] as usize).copied();
        let (Some(v0), Some(v1), Some(v2)) = (corner(0), corner(1), corner(2)) else {
            continue;
        };
        if !(v0.is_finite() && v1.is_finite() && v2.is_finite()) {
            continue;
        }
        let normal = (v1 - v0).cross(v2 - v0).normalize_or_zero();
        if normal == Vec3::ZERO {
            continue;
        }
        triangles.push(Triangle {
            v0: Vec3A::from(v0),
            v1: Vec3A::from(v1),
            v2: Vec3A::from(v2),
        });
        normals.push(normal);
    }
    (triangles, normals)
}

/// `n` unit directions spread evenly over the sphere (Fibonacci lattice); none is
/// axis-aligned, so probes do not run along the walls of axis-aligned scenes.
fn sphere_directions(n: usize) -> Vec<Vec3> {
    let golden_angle = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - y * y).max(0.0).sqrt();
            let phi = golden_angle * i as f32;
            Vec3::new(r * phi.cos(), y, r * phi.sin()).normalize()
        })
        .collect()
}

fn lerp(lo: f32, hi: f32, t: f32) -> f32 {
    lo + (hi - lo) * t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SceneBuilder;

    /// Roof height of the test building.
    const ROOF: f32 = 10.0;
    /// Half side of the test building's square footprint, centred on the origin.
    const HALF: f32 = 5.0;

    /// A 40 m ground quad facing up and a closed 10 × 10 × 10 m box building with
    /// outward-facing triangles.
    fn ground_and_building() -> Scene {
        let mut b = SceneBuilder::default();
        let g = 20.0;
        let ground = [
            Vec3::new(-g, 0.0, -g),
            Vec3::new(-g, 0.0, g),
            Vec3::new(g, 0.0, g),
            Vec3::new(g, 0.0, -g),
        ];
        b.push("ground".into(), &ground, &[0, 1, 2, 0, 2, 3], None);
        let corners: Vec<Vec3> = (0..8)
            .map(|i| {
                Vec3::new(
                    if i & 1 == 0 { -HALF } else { HALF },
                    if i & 2 == 0 { 0.0 } else { ROOF },
                    if i & 4 == 0 { -HALF } else { HALF },
                )
            })
            .collect();
        let quads = [
            [0, 4, 6, 2],
            [1, 3, 7, 5],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 2, 3, 1],
            [4, 5, 7, 6],
        ];
        let indices: Vec<u32> = quads
            .iter()
            .flat_map(|&[a, b, c, d]| [a, b, c, a, c, d])
            .collect();
        b.push("building".into(), &corners, &indices, None);
        b.build("test")
    }

    fn inside_footprint(p: Vec3) -> bool {
        p.x.abs() <= HALF && p.z.abs() <= HALF
    }

    fn pitch_deg(p: &Pose) -> f32 {
        let dir =
            Vec3::from(p.look_at.expect("sampled poses use look_at")) - Vec3::from(p.position);
        dir.normalize().y.asin().to_degrees()
    }

    #[test]
    fn walks_start_at_street_level_looking_level() {
        let scene = ground_and_building();
        let sampler = PoseSampler::new(&scene);
        let (eye, target) = sampler.walk_start(&|_| true).expect("the ground is open");
        assert!(
            (eye.y - EYE_HEIGHT).abs() < 1e-3,
            "eye {eye} is not on the ground"
        );
        assert!(!inside_footprint(eye));
        // The only thing a level ray can end on is the building: it looks at it.
        let hit = sampler.closest_hit(eye, (target - eye).normalize(), 100.0);
        assert!(
            hit.is_some(),
            "looks into nothing from {eye} towards {target}"
        );
        assert_eq!(target.y, eye.y);
        assert!((target.distance(eye) - 10.0).abs() < 1e-3);
        assert_eq!(
            sampler.walk_start(&|_| true),
            Some((eye, target)),
            "deterministic"
        );
        // Nowhere acceptable to stand: no start.
        assert_eq!(sampler.walk_start(&|_| false), None);
    }

    #[test]
    fn eyes_stand_on_floors_outside_solids() {
        let scene = ground_and_building();
        let sampler = PoseSampler::new(&scene);
        let result = sampler.sample(200, 7, [640, 360], &|_| true);
        assert_eq!(result.poses.len(), 200);
        let mut on_ground = 0;
        for p in &result.poses {
            let eye = Vec3::from(p.position);
            let solid = Aabb::new(Vec3::new(-HALF, 0.0, -HALF), Vec3::new(HALF, ROOF, HALF));
            assert!(!solid.contains(eye), "eye {eye} inside the building");
            // Inside the footprint the only open floor is the roof.
            let floor = if inside_footprint(eye) { ROOF } else { 0.0 };
            assert!((eye.y - floor - EYE_HEIGHT).abs() < 1e-3, "eye {eye}");
            on_ground += usize::from(floor == 0.0);
            assert!(pitch_deg(p).abs() <= MAX_PITCH_DEG + 1e-3);
            assert_eq!(p.viewport, [640, 360]);
            assert_eq!(p.fov_y_deg, FOV_Y_DEG);
            assert!(p.far >= MIN_FAR && p.near == NEAR);
            assert!(crate::camera::Camera::new(p).is_ok());
        }
        // The building covers 1/16 of the ground; most eyes are at street level.
        assert!(on_ground > 150, "{on_ground}");
    }

    #[test]
    fn accept_predicate_is_respected() {
        let scene = ground_and_building();
        let sampler = PoseSampler::new(&scene);
        let result = sampler.sample(50, 3, [64, 64], &|eye| eye.y < 5.0);
        assert_eq!(result.poses.len(), 50);
        assert!(
            result
                .poses
                .iter()
                .all(|p| (p.position[1] - EYE_HEIGHT).abs() < 1e-3)
        );
        assert!(
            result
                .poses
                .iter()
                .all(|p| !inside_footprint(Vec3::from(p.position)))
        );
    }

    #[test]
    fn deterministic_for_a_seed() {
        let scene = ground_and_building();
        let sampler = PoseSampler::new(&scene);
        let a = sampler.sample(20, 42, [64, 64], &|_| true);
        let b = sampler.sample(20, 42, [64, 64], &|_| true);
        let c = sampler.sample(20, 43, [64, 64], &|_| true);
        assert_eq!(a, b);
        assert_ne!(a.poses, c.poses);
    }

    #[test]
    fn gives_up_instead_of_looping() {
        let scene = ground_and_building();
        let sampler = PoseSampler::new(&scene);
        let result = sampler.sample(3, 1, [64, 64], &|_| false);
        assert!(result.poses.is_empty());
        assert_eq!(result.attempts, 3 * ATTEMPTS_PER_POSE);
        assert_eq!(result.rejected(), result.attempts);

        let empty = SceneBuilder::default().build("empty");
        let result = PoseSampler::new(&empty).sample(5, 1, [64, 64], &|_| true);
        assert!(result.poses.is_empty());
    }

    #[test]
    fn floor_without_headroom_is_rejected() {
        // A 1.5 m high table top over the whole ground: the ground below it lacks
        // headroom, so eyes stand on the table instead.
        let mut b = SceneBuilder::default();
        let quad = [
            Vec3::new(-2.0, 0.0, -2.0),
            Vec3::new(-2.0, 0.0, 2.0),
            Vec3::new(2.0, 0.0, 2.0),
            Vec3::new(2.0, 0.0, -2.0),
        ];
        b.push("ground".into(), &quad, &[0, 1, 2, 0, 2, 3], None);
        let low = quad.map(|v| v + Vec3::Y * 1.5);
        b.push("table".into(), &low, &[0, 1, 2, 0, 2, 3], None);
        let scene = b.build("low");
        let result = PoseSampler::new(&scene).sample(10, 5, [64, 64], &|_| true);
        assert_eq!(result.poses.len(), 10);
        assert!(
            result
                .poses
                .iter()
                .all(|p| (p.position[1] - 1.5 - EYE_HEIGHT).abs() < 1e-3)
        );
    }

    #[test]
    fn probe_directions_cover_the_sphere() {
        let dirs = sphere_directions(PROBE_RAYS);
        assert_eq!(dirs.len(), PROBE_RAYS);
        assert!(dirs.iter().all(|d| (d.length() - 1.0).abs() < 1e-5));
        assert!(dirs.iter().sum::<Vec3>().length() < 0.5);
    }
}
