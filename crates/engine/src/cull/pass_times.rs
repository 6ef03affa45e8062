//! Time per pass of a batch: which passes a backend runs, and what each cost.
//!
//! The names are the algorithm's stages, not any backend's: the GPU backend fills
//! them from timestamp queries (`gpu::profile`), and a backend that cannot measure
//! leaves them empty. `homcull eval --profile` and the report print them.

use serde::Serialize;

/// The passes a batch is split into (in recording order within a group of slots).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pass {
    /// HOM / HZB: the selected occluders rasterized into the occlusion map and depth.
    OccluderRaster,
    /// The opacity and depth pyramids (the raster DEB is the depth pyramid).
    Pyramid,
    /// The per-box overlap and depth test.
    BoxTest,
    /// The refinement: the indirect-draw filter and the survivors' raster.
    Refine,
    /// Exact: every in-frustum object rasterized into the ID buffer.
    IdRaster,
    /// Exact: ID buffer → visibility bitmask.
    Collect,
}

impl Pass {
    pub const ALL: [Pass; 6] = [
        Pass::OccluderRaster,
        Pass::Pyramid,
        Pass::BoxTest,
        Pass::Refine,
        Pass::IdRaster,
        Pass::Collect,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Pass::OccluderRaster => "occluder_raster",
            Pass::Pyramid => "pyramid",
            Pass::BoxTest => "box_test",
            Pass::Refine => "refine",
            Pass::IdRaster => "id_raster",
            Pass::Collect => "collect",
        }
    }
}

/// GPU milliseconds per pass, summed over the profiled batches, and their poses.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PassTimes {
    pub ms: [f64; Pass::ALL.len()],
    pub poses: u64,
}

impl PassTimes {
    pub fn get(&self, pass: Pass) -> f64 {
        self.ms[pass as usize]
    }

    /// Mean milliseconds per pose of every pass that took time.
    pub fn per_pose(&self) -> PassMsPerPose {
        let n = self.poses.max(1) as f64;
        PassMsPerPose(
            Pass::ALL
                .iter()
                .filter(|&&p| self.get(p) > 0.0)
                .map(|&p| (p.name(), self.get(p) / n))
                .collect(),
        )
    }

    pub fn total_ms(&self) -> f64 {
        self.ms.iter().sum()
    }
}

/// Pass name → mean GPU ms per pose, in pass order (serialized as a JSON object).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PassMsPerPose(pub Vec<(&'static str, f64)>);

impl Serialize for PassMsPerPose {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn per_pose_is_a_json_object_of_the_passes_that_took_time() {
        let mut t = PassTimes {
            poses: 2,
            ..Default::default()
        };
        t.ms[Pass::OccluderRaster as usize] = 5.0;
        t.ms[Pass::Pyramid as usize] = 1.0;
        let json = serde_json::to_string(&t.per_pose()).unwrap();
        assert_eq!(json, r#"{"occluder_raster":2.5,"pyramid":0.5}"#);
    }
}
