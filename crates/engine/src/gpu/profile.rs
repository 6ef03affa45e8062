//! GPU time per pass, from timestamp queries written between the passes of a batch.
//!
//! One submission holds every pass of a batch, so wall-clock time cannot tell them
//! apart; the GPU's own timestamps can. When profiling is on (`Culler::set_profiling`,
//! `homcull eval --profile`) and the adapter has `TIMESTAMP_QUERY_INSIDE_ENCODERS`,
//! the batch writes a timestamp before its first pass and after each one, resolves
//! them with the visibility mask and reads them back after it. The time between two
//! consecutive stamps is charged to the pass the later one closes. On GPUs that overlap
//! consecutive passes the split is approximate; the sum is the batch's GPU time.
//! Profiling costs one query resolve and one extra readback per batch, which is why
//! it is off unless asked for.

use super::counted::Encoder;
use super::device::GpuDevice;
use crate::cull::{Pass, PassTimes};

/// The timestamps of one batch being recorded.
pub(crate) struct Stamps {
    set: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    /// The pass each stamp closes (`None`: the opening stamp).
    closes: Vec<Option<Pass>>,
    capacity: u32,
}

impl Stamps {
    /// Room for `capacity` stamps, or `None` when that exceeds a query set's limit.
    pub(crate) fn new(gpu: &GpuDevice, capacity: u32) -> Option<Self> {
        if capacity == 0 || capacity > wgpu::QUERY_SET_MAX_QUERIES {
            return None;
        }
        let set = gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("pass timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: capacity,
        });
        let resolved = gpu.buffer(&wgpu::BufferDescriptor {
            label: Some("pass timestamps resolved"),
            size: capacity as u64 * wgpu::QUERY_SIZE as u64,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Some(Stamps {
            set,
            resolved,
            closes: Vec::new(),
            capacity,
        })
    }

    /// Writes a stamp closing `pass` (`None` opens the batch).
    pub(crate) fn mark(&mut self, encoder: &mut Encoder<'_>, pass: Option<Pass>) {
        let i = self.closes.len() as u32;
        assert!(i < self.capacity, "more pass stamps than reserved");
        encoder.raw.write_timestamp(&self.set, i);
        self.closes.push(pass);
    }

    /// Resolves the stamps written so far; returns the buffer and its byte length.
    pub(crate) fn resolve(&self, encoder: &mut Encoder<'_>) -> (&wgpu::Buffer, u64) {
        let n = self.closes.len() as u32;
        encoder
            .raw
            .resolve_query_set(&self.set, 0..n, &self.resolved, 0);
        (&self.resolved, n as u64 * wgpu::QUERY_SIZE as u64)
    }

    /// Adds the read-back `ticks` (one per stamp) to `into`, `period_ns` per tick.
    /// A stamp earlier than its predecessor (a counter reset) charges nothing.
    pub(crate) fn accumulate(&self, ticks: &[u64], period_ns: f32, into: &mut PassTimes) {
        charge(&self.closes, ticks, period_ns, into);
    }
}

fn charge(closes: &[Option<Pass>], ticks: &[u64], period_ns: f32, into: &mut PassTimes) {
    for (i, pass) in closes.iter().enumerate().skip(1) {
        let (Some(pass), Some(&t1), Some(&t0)) = (pass, ticks.get(i), ticks.get(i - 1)) else {
            continue;
        };
        if t1 >= t0 {
            into.ms[*pass as usize] += (t1 - t0) as f64 * period_ns as f64 * 1e-6;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamps_charge_the_pass_they_close() {
        let closes = [
            None,
            Some(Pass::OccluderRaster),
            Some(Pass::Pyramid),
            Some(Pass::OccluderRaster),
            Some(Pass::Refine),
        ];
        // 1 ns per tick: 2 ms raster, 1 ms pyramid, 3 ms raster, a reset (nothing).
        let ticks = [0, 2_000_000, 3_000_000, 6_000_000, 5_000_000];
        let mut t = PassTimes {
            poses: 2,
            ..Default::default()
        };
        charge(&closes, &ticks, 1.0, &mut t);
        assert_eq!(t.get(Pass::OccluderRaster), 5.0);
        assert_eq!(t.get(Pass::Pyramid), 1.0);
        assert_eq!(t.get(Pass::Refine), 0.0);
        assert_eq!(
            t.per_pose().0,
            vec![("occluder_raster", 2.5), ("pyramid", 0.5)]
        );
    }
}
