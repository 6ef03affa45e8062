//! The pipelines and render targets shared by every scene on one device.

use std::sync::Mutex;

use super::device::GpuDevice;
use super::oracle::OraclePass;
use super::pyramid::PyramidPass;
use super::raster::RasterPass;
use super::refine::RefinePass;
use super::targets::SlotTargets;
use super::test::TestPass;

/// Pipelines and render targets shared by every scene on one device. Pipelines are
/// compiled once; the slot targets are written and consumed within one submission, so
/// one set serves every scene, and a server with many scenes holds it once.
pub struct SharedPasses {
    pub(crate) raster: RasterPass,
    pub(crate) refine: RefinePass,
    pub(crate) pyramid: PyramidPass,
    pub(crate) test: TestPass,
    pub(crate) oracle: OraclePass,
    /// Slot targets of the last viewport size, and the lock that serialises batches.
    pub(crate) targets: Mutex<Option<SlotTargets>>,
}

impl SharedPasses {
    pub(crate) fn new(ctx: &GpuDevice) -> Self {
        let raster = RasterPass::new(ctx);
        SharedPasses {
            refine: RefinePass::new(ctx, &raster),
            raster,
            pyramid: PyramidPass::new(ctx),
            test: TestPass::new(ctx),
            oracle: OraclePass::new(ctx),
            targets: Default::default(),
        }
    }
}
