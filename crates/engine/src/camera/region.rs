//! The region of eyes and view directions a pose may ask its answer to hold for
//! (`"region"` on the wire), validated field by field. `core::region` culls for it.

use glam::Vec3;
use homcull_proto::Pose;

use super::PoseError;

/// Largest radius of a region's ball of eyes, metres.
pub const MAX_RADIUS_M: f32 = 5.0;
/// Largest turn of the view direction, degrees.
pub const MAX_TURN_DEG: f32 = 45.0;
/// Largest diagonal of a box region, metres.
pub const MAX_BOX_DIAGONAL_M: f32 = 10.0;

/// A validated region of eyes and view directions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Region {
    /// Centre of the ball of eyes.
    pub centre: Vec3,
    /// Radius of the ball of eyes, metres.
    pub radius: f32,
    /// Half extents of the box of eyes (a box region), inside the ball; a ball's
    /// radius on every axis otherwise. A map bounds an eye's offset on each of its
    /// axes by the lesser of the two.
    pub half_extent: Vec3,
    /// Largest angle between a view direction and the pose's, radians.
    pub turn: f32,
    /// Every view direction.
    pub all_directions: bool,
}

impl Region {
    /// The region of a wire pose, checked field by field (`None`: no region).
    pub fn of(pose: &Pose) -> Result<Option<Region>, PoseError> {
        let Some(r) = pose.region else {
            return Ok(None);
        };
        let bad = |field: &'static str, why: String| PoseError::Region { field, why };
        let position = Vec3::from(pose.position);
        let (centre, radius, half_extent) = match (r.radius_m, r.bounds) {
            (Some(_), Some(_)) => {
                return Err(bad("region", "give radius_m or box, not both".into()));
            }
            (None, None) => return Err(bad("region", "give radius_m or box".into())),
            (Some(m), None) => {
                if !(m.is_finite() && m > 0.0 && m <= MAX_RADIUS_M) {
                    return Err(bad(
                        "region.radius_m",
                        format!("must be in (0, {MAX_RADIUS_M}] metres, got {m}"),
                    ));
                }
                (position, m, Vec3::splat(m))
            }
            (None, Some([lo, hi])) => {
                let (lo, hi) = (Vec3::from(lo), Vec3::from(hi));
                if !(lo.is_finite() && hi.is_finite()) || lo.cmpgt(hi).any() {
                    return Err(bad(
                        "region.box",
                        "must be finite [[x0, y0, z0], [x1, y1, z1]] with min ≤ max".into(),
                    ));
                }
                let diagonal = (hi - lo).length();
                if diagonal > MAX_BOX_DIAGONAL_M {
                    return Err(bad(
                        "region.box",
                        format!(
                            "its diagonal must be at most {MAX_BOX_DIAGONAL_M} m, got {diagonal}"
                        ),
                    ));
                }
                if position.cmplt(lo).any() || position.cmpgt(hi).any() {
                    return Err(bad("region.box", "must hold the pose's position".into()));
                }
                // The ball around the centre that holds the box (never empty: a point
                // box is a ball of a millimetre).
                let radius = (diagonal * 0.5).max(1e-3);
                (
                    (lo + hi) * 0.5,
                    radius,
                    ((hi - lo) * 0.5).max(Vec3::splat(1e-3)),
                )
            }
        };
        let turn = match (r.turn_deg, r.all_directions) {
            (Some(_), true) => {
                return Err(bad(
                    "region.turn_deg",
                    "give turn_deg or all_directions, not both".into(),
                ));
            }
            (Some(t), false) if !(t.is_finite() && (0.0..=MAX_TURN_DEG).contains(&t)) => {
                return Err(bad(
                    "region.turn_deg",
                    format!("must be in [0, {MAX_TURN_DEG}] degrees, got {t}"),
                ));
            }
            (t, _) => t.unwrap_or(0.0).to_radians(),
        };
        Ok(Some(Region {
            centre,
            radius,
            half_extent,
            turn,
            all_directions: r.all_directions,
        }))
    }
}
