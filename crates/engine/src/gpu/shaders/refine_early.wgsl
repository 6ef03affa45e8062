
// Appended to raster.wgsl where the adapter has SHADER_EARLY_DEPTH_TEST. The pipeline
// tests each fragment against the pose's occluder depth buffer (reversed Z,
// GreaterEqual, no writes) before the shader runs, so the shader runs only for
// fragments at or in front of every occluder. The occluder raster and the oracle
// compute the same depth with the same invariant vertex stage, so a pixel the oracle
// gives to an object passes this test: the refinement stays conservative.
@fragment @early_depth_test(force)
fn fs_refine_early(in: VsOut) {
    mark_visible(in.id);
}
