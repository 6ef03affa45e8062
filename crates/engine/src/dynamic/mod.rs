//! Moving objects: placements that writers send, scene versions, and the temporal
//! bounding volumes that keep an answer right while things move.
//!
//! A scene as loaded is version 0. Each accepted update ([`Dynamics::apply`]) places
//! some objects (relative to where the file put them) and may declare how they move
//! (velocity, angular velocity, for how long); it is checked whole and applied whole,
//! and makes the next version. Updates are cheap: they are recorded here, and the
//! engine builds the moved scene ([`snapshot::advance`]) when it next culls, from
//! the objects changed since the scene it holds. A cull runs on one whole version and
//! its answer names it, so a cull never sees half an update.
//!
//! **Why the answer stays conservative.** At a version every object's geometry is
//! where its placement puts it: positions, bounds and test boxes are recomputed from
//! the loaded ones, so the conservativeness argument of the static scene holds for the
//! moved one as it is.
//!
//! **Temporal bounding volumes.** A client draws an answer a round trip after it was
//! computed; by then a moving object has moved. An object that declares a motion is
//! bounded, box by box, over the scene's horizon (or the motion's validity, if
//! shorter): each test box becomes the box of everywhere it can reach
//! ([`Placement::swept`]). If that volume is hidden, the object is hidden throughout
//! the interval. Two consequences, both on the conservative side:
//! - the per-pixel refinement tests an object's triangles where they are *now*, which
//!   says nothing of where they will be, so it leaves moving objects as the box test
//!   left them ([`PreparedScene::moving`](crate::cull::PreparedScene::moving));
//! - a moving object does not occlude: it could only be trusted to hide what it hides
//!   throughout the interval, which would need its swept *occlusion* (the intersection
//!   of what it covers along the way), and a car that leaves a doorway would otherwise
//!   hide, at the version it was sent in, what the doorway shows a moment later.
//!   Objects placed without a motion stay occluders at their placement. What the rule
//!   costs is measured by the report (section 3b: the demo city with its 1,152 cars
//!   left out of the occluders keeps ~11 % more triangles than the oracle, the larger
//!   part of what motion costs); the "throughout" variant would win back at most that.

pub mod marks;
mod placement;
pub mod snapshot;

use std::sync::Arc;

pub use placement::{
    DEFAULT_HORIZON_MS, MAX_COORDINATE, MAX_HORIZON_MS, MAX_SPEED, Placement, TransformError,
    horizon_s,
};

use homcull_proto::TransformsRequest;

use crate::cull::PreparedScene;

/// Objects one update may carry by default.
pub const DEFAULT_MAX_UPDATE_OBJECTS: usize = 65_536;

/// The placements of one scene's objects, and its version. Shared (behind a mutex)
/// between the writers that update it and the engine that culls it.
pub struct Dynamics {
    /// The scene as loaded: what every placement is relative to.
    base: Arc<PreparedScene>,
    version: u64,
    horizon_s: f32,
    /// One per object once the first update arrived (`None`: as loaded).
    placements: Vec<Option<Placement>>,
    /// Objects changed since the engine last took the changes, ascending on take.
    dirty: Vec<u32>,
    /// Bitmask of objects whose vertices interleave with another's (computed on the
    /// first update): they cannot move alone.
    shared: Option<Vec<u32>>,
}

/// An update checked whole ([`Dynamics::check`]), to be applied as `version`.
#[derive(Debug, Clone)]
pub struct Checked {
    pub version: u64,
    horizon: Option<f32>,
    placed: Vec<(u32, Option<Placement>)>,
}

/// Every placed object of a scene at one version (the rest as loaded), and the
/// horizon: what a journal's snapshot keeps.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Placed {
    pub version: u64,
    pub horizon_s: f32,
    /// Ascending by id.
    pub objects: Vec<(u32, Placement)>,
}

impl Placed {
    /// The horizon a scene starts with, seconds.
    pub fn default_horizon_s() -> f32 {
        (DEFAULT_HORIZON_MS / 1e3) as f32
    }
}

/// What changed since the engine last looked: enough to build the next scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Changes {
    pub version: u64,
    pub horizon_s: f32,
    /// Each changed object with its placement now (`None`: back as loaded), ascending.
    pub objects: Vec<(u32, Option<Placement>)>,
}

impl Dynamics {
    /// The placements of `base`, as loaded (version 0).
    pub fn new(base: Arc<PreparedScene>) -> Self {
        Dynamics {
            base,
            version: 0,
            horizon_s: Placed::default_horizon_s(),
            placements: Vec::new(),
            dirty: Vec::new(),
            shared: None,
        }
    }

    pub fn version(&self) -> u64 {
        self.version
    }

    /// How long an answer culled now stays right without a new version: unbounded
    /// (`None`) while no object declares a motion, else the horizon its test boxes are
    /// swept over, seconds.
    pub fn answers_hold_s(&self) -> Option<f32> {
        let moving = self.placements.iter().flatten().any(Placement::has_motion);
        moving.then_some(self.horizon_s)
    }

    /// Checks `req` whole (at most `max_objects` objects) and applies it: the next
    /// version, or an error and no change at all.
    pub fn apply(
        &mut self,
        req: &TransformsRequest,
        max_objects: usize,
    ) -> Result<u64, TransformError> {
        let checked = self.check(req, max_objects)?;
        Ok(self.commit(checked))
    }

    /// Checks `req` whole (at most `max_objects` objects) without applying it: what
    /// [`Dynamics::commit`] applies as the next version, so that a writer can make the
    /// update durable in between. Only commits change what a check found, so the
    /// check holds until the next commit.
    pub fn check(
        &mut self,
        req: &TransformsRequest,
        max_objects: usize,
    ) -> Result<Checked, TransformError> {
        let objects = self.base.scene.objects.len();
        if req.objects.len() > max_objects {
            return Err(TransformError::TooMany {
                count: req.objects.len(),
                max: max_objects,
            });
        }
        let horizon = req.horizon_ms.map(horizon_s).transpose()?;
        let shared = self
            .shared
            .get_or_insert_with(|| snapshot::shared_vertices(&self.base.scene));
        let mut seen = std::collections::HashSet::with_capacity(req.objects.len());
        let mut placed = Vec::with_capacity(req.objects.len());
        for t in &req.objects {
            let Some(o) = self.base.scene.objects.get(t.id as usize) else {
                return Err(TransformError::UnknownObject {
                    id: t.id,
                    objects: objects as u32,
                });
            };
            if !seen.insert(t.id) {
                return Err(TransformError::Repeated { id: t.id });
            }
            if crate::cull::has_bit(shared, t.id) {
                return Err(TransformError::SharedVertices { id: t.id });
            }
            let p = Placement::from_update(t, o.aabb)?;
            placed.push((t.id, (!p.is_identity()).then_some(p)));
        }
        Ok(Checked {
            version: self.version + 1,
            horizon,
            placed,
        })
    }

    /// Applies a checked update: its version, now the scene's.
    ///
    /// # Panics
    /// If another update was committed since the check (a writer must check and commit
    /// under one lock of its own).
    pub fn commit(&mut self, checked: Checked) -> u64 {
        assert_eq!(
            checked.version,
            self.version + 1,
            "an update committed between another's check and commit"
        );
        self.place(checked.horizon, checked.placed);
        self.version = checked.version;
        self.version
    }

    /// Sets placements and the horizon, marking what they change.
    fn place(&mut self, horizon: Option<f32>, placed: Vec<(u32, Option<Placement>)>) {
        if self.placements.is_empty() {
            self.placements = vec![None; self.base.scene.objects.len()];
        }
        if let Some(h) = horizon.filter(|&h| h != self.horizon_s) {
            self.horizon_s = h;
            // Every moving object's bounds follow the horizon.
            let moving = self.placements.iter().enumerate();
            let moving = moving.filter(|(_, p)| p.is_some_and(|p| p.has_motion()));
            self.dirty.extend(moving.map(|(id, _)| id as u32));
        }
        for (id, p) in placed {
            self.placements[id as usize] = p;
            self.dirty.push(id);
        }
    }

    /// Every placement now, and the version and horizon they belong to.
    pub fn placed(&self) -> Placed {
        Placed {
            version: self.version,
            horizon_s: self.horizon_s,
            objects: (self.placements.iter().enumerate())
                .filter_map(|(id, p)| p.map(|p| (id as u32, p)))
                .collect(),
        }
    }

    /// Puts the scene where `placed` says (a journal's snapshot): every object it
    /// names placed so, every other as loaded, at its version. Refused whole if it
    /// names an object the scene lacks, a horizon out of range, or goes back in
    /// version.
    pub fn restore(&mut self, placed: &Placed) -> Result<(), String> {
        let objects = self.base.scene.objects.len();
        if let Some(&(id, _)) = placed
            .objects
            .iter()
            .find(|(id, _)| *id as usize >= objects)
        {
            return Err(format!("object {id} of {objects}"));
        }
        if placed.version < self.version {
            return Err(format!(
                "version {} behind the scene's {}",
                placed.version, self.version
            ));
        }
        let mut now: Vec<(u32, Option<Placement>)> = (self.placements.iter().enumerate())
            .filter(|(_, p)| p.is_some())
            .map(|(id, _)| (id as u32, None))
            .collect();
        now.extend(placed.objects.iter().map(|&(id, p)| (id, Some(p))));
        let h = placed.horizon_s;
        if !(h.is_finite() && (0.0..=(MAX_HORIZON_MS / 1e3) as f32).contains(&h)) {
            return Err(format!("horizon {h} s"));
        }
        self.place(Some(h), now);
        self.version = placed.version;
        Ok(())
    }

    /// Object `id`'s bounds at its placement now (a box around its loaded bounds
    /// moved; no motion): for what needs where an object is, not exactly (levels of
    /// detail, statistics).
    pub fn bounds(&self, id: u32) -> crate::geom::Aabb {
        let loaded = self.base.scene.objects[id as usize].aabb;
        match self.placements.get(id as usize).copied().flatten() {
            Some(p) => snapshot::transformed_box(&p.matrix, loaded),
            None => loaded,
        }
    }

    /// The changes since the last call, or `None` if the version did not move since
    /// `seen`.
    pub fn take_changes(&mut self, seen: u64) -> Option<Changes> {
        if self.version == seen {
            return None;
        }
        let mut ids = std::mem::take(&mut self.dirty);
        ids.sort_unstable();
        ids.dedup();
        Some(Changes {
            version: self.version,
            horizon_s: self.horizon_s,
            objects: ids
                .into_iter()
                .map(|id| (id, self.placements[id as usize]))
                .collect(),
        })
    }
}
