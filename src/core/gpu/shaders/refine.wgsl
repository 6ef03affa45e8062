// Before the refinement raster: turns off the indirect draws of the objects HOM's box
// test culled, so only its survivors are drawn again (see `fs_refine` in raster.wgsl).

struct FilterParams {
    first_draw: u32,     // first draw of the group
    draw_count: u32,     // draws in the group
    words_per_pose: u32,
    _pad: u32,
}

// wgpu's DrawIndexedIndirectArgs.
struct DrawArgs {
    index_count: u32,
    instance_count: u32,
    first_index: u32,
    base_vertex: i32,
    first_instance: u32,
}

@group(0) @binding(0) var<uniform> fp: FilterParams;
@group(0) @binding(1) var<storage, read> box_mask: array<u32>;
@group(0) @binding(2) var<storage, read> draw_pose: array<u32>;
@group(0) @binding(3) var<storage, read_write> draws: array<DrawArgs>;

@compute @workgroup_size(LINEAR_WORKGROUP, 1, 1)
fn filter_draws(
    @builtin(global_invocation_id) g: vec3<u32>,
    @builtin(num_workgroups) n: vec3<u32>,
) {
    // Dispatches wider than 65535 workgroups wrap into y rows.
    let k = g.x + g.y * n.x * LINEAR_WORKGROUP;
    if k >= fp.draw_count {
        return;
    }
    let i = fp.first_draw + k;
    let id = draws[i].first_instance;
    let w = draw_pose[i] * fp.words_per_pose + id / 32u;
    draws[i].instance_count = select(0u, 1u, (box_mask[w] & (1u << (id % 32u))) != 0u);
}
