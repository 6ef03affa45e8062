//! Level-of-detail hints: thresholds in pixels, and the level they give a projected size.
//!
//! A client asks with `"lod": {"px": [t1, t2, …]}` in the cull options (`?lod_px=t1,t2`
//! on a stream); every visible object then also gets a level: 0 when its projected size
//! is at least `t1`, 1 when at least `t2`, …, and `n` (the number of thresholds) below
//! the last. The projected size is defined by the server (the larger side, in pixels,
//! of the object's bounding box projected and clamped to the viewport); this crate only
//! carries the thresholds and applies them. Ties go to the finer level: a size equal to
//! `t1` is level 0.

use serde::{Deserialize, Serialize};

/// Most thresholds a request may give (so levels run 0..=8 and fit a byte).
pub const MAX_LOD_THRESHOLDS: usize = 8;

/// Valid LOD thresholds: 1 to [`MAX_LOD_THRESHOLDS`] pixel sizes, finite, positive and
/// strictly decreasing. Fixed-size, so the options that carry them stay `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "LodSpec", into = "LodSpec")]
pub struct LodThresholds {
    px: [f32; MAX_LOD_THRESHOLDS],
    len: u8,
}

/// The JSON form of [`LodThresholds`]: `{"px": [t1, t2, …]}`.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LodSpec {
    /// Pixel sizes, strictly decreasing: level 0 at or above the first, level k at or
    /// above the (k+1)-th, the number of thresholds below the last.
    pub px: Vec<f32>,
}

/// Why thresholds were refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InvalidLod {
    #[error("lod.px needs 1 to {MAX_LOD_THRESHOLDS} thresholds, got {0}")]
    Count(usize),
    #[error("lod.px must be finite pixel sizes above 0, got {0}")]
    Value(f32),
    #[error("lod.px must be strictly decreasing, got {0} then {1}")]
    NotDecreasing(f32, f32),
    #[error("lod_px must be numbers separated by commas, got `{0}`")]
    Syntax(String),
}

impl LodThresholds {
    /// Checks and keeps `px`.
    pub fn new(px: &[f32]) -> Result<Self, InvalidLod> {
        if px.is_empty() || px.len() > MAX_LOD_THRESHOLDS {
            return Err(InvalidLod::Count(px.len()));
        }
        if let Some(&bad) = px.iter().find(|t| !(t.is_finite() && **t > 0.0)) {
            return Err(InvalidLod::Value(bad));
        }
        if let Some(w) = px.windows(2).find(|w| w[1] >= w[0]) {
            return Err(InvalidLod::NotDecreasing(w[0], w[1]));
        }
        let mut out = LodThresholds {
            px: [0.0; MAX_LOD_THRESHOLDS],
            len: px.len() as u8,
        };
        out.px[..px.len()].copy_from_slice(px);
        Ok(out)
    }

    /// Parses the stream's `lod_px=t1,t2,…`.
    pub fn parse_list(s: &str) -> Result<Self, InvalidLod> {
        let px = s
            .split(',')
            .map(|t| t.trim().parse::<f32>())
            .collect::<Result<Vec<_>, _>>()
            .map_err(|_| InvalidLod::Syntax(s.chars().take(64).collect()))?;
        Self::new(&px)
    }

    /// The thresholds, largest first.
    pub fn px(&self) -> &[f32] {
        &self.px[..self.len as usize]
    }

    /// The level of an object whose projected size is `size_px`: how many thresholds
    /// it is below (a size equal to a threshold is not below it).
    pub fn level(&self, size_px: f32) -> u8 {
        self.px().iter().filter(|&&t| size_px < t).count() as u8
    }
}

impl TryFrom<LodSpec> for LodThresholds {
    type Error = InvalidLod;
    fn try_from(spec: LodSpec) -> Result<Self, InvalidLod> {
        LodThresholds::new(&spec.px)
    }
}

impl From<LodThresholds> for LodSpec {
    fn from(t: LodThresholds) -> Self {
        LodSpec {
            px: t.px().to_vec(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_count_the_thresholds_a_size_is_below() {
        let t = LodThresholds::new(&[64.0, 16.0, 4.0]).unwrap();
        let levels: Vec<u8> = [100.0, 64.0, 63.9, 16.0, 5.0, 4.0, 3.9, 0.0]
            .map(|s| t.level(s))
            .to_vec();
        assert_eq!(levels, [0, 0, 1, 1, 2, 2, 3, 3]);
        assert_eq!(LodThresholds::parse_list("64, 16,4"), Ok(t));
        let json = serde_json::to_string(&t).unwrap();
        assert_eq!(json, r#"{"px":[64.0,16.0,4.0]}"#);
        assert_eq!(serde_json::from_str::<LodThresholds>(&json).unwrap(), t);
    }

    #[test]
    fn bad_thresholds_are_refused_with_a_reason() {
        for (px, why) in [
            (vec![], "1 to 8"),
            (vec![1.0; 9], "1 to 8"),
            (vec![8.0, 0.0], "above 0"),
            (vec![f32::INFINITY], "finite"),
            (vec![4.0, 16.0], "decreasing"),
            (vec![4.0, 4.0], "decreasing"),
        ] {
            let err = LodThresholds::new(&px).unwrap_err().to_string();
            assert!(err.contains(why), "{px:?}: {err}");
        }
        assert!(LodThresholds::parse_list("64,x").is_err());
        assert!(LodThresholds::parse_list("nan").is_err());
        let err = serde_json::from_str::<LodThresholds>(r#"{"px":[1, 2]}"#).unwrap_err();
        assert!(err.to_string().contains("decreasing"), "{err}");
    }
}
