// Before the refinement raster: the draws of the box test's survivors, expanded on the
// GPU from (pose, object) pairs and the scene's index ranges (see `fs_refine` in
// raster.wgsl). Compacting (`compact`, where the adapter draws with an indirect count):
// each survivor is appended to its pose's region and counted, so the raster issues
// only survivors. Otherwise every candidate keeps its place with an instance count of
// 1 (survivor) or 0. A moving object (`MOVING_OBJECT` set in its pair) is never drawn:
// its test boxes bound its motion and its triangles do not, so the box test's answer
// is final and a survivor's bit is set in the refined mask here.

struct FilterParams {
    first_draw: u32,     // first draw of the group
    draw_count: u32,     // draws in the group
    words_per_pose: u32,
    compact: u32,        // 1: append survivors and count them
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
@group(0) @binding(2) var<storage, read> draw_objects: array<vec2<u32>>; // (pose, object)
@group(0) @binding(3) var<storage, read> object_ranges: array<vec2<u32>>; // (first index, count)
@group(0) @binding(4) var<storage, read> pose_first: array<u32>; // a pose's first draw
@group(0) @binding(5) var<storage, read_write> draws: array<DrawArgs>;
@group(0) @binding(6) var<storage, read_write> counts: array<atomic<u32>>;
@group(0) @binding(7) var<storage, read_write> refined: array<atomic<u32>>;

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
    let d = draw_objects[i];
    let pose = d.x;
    let id = d.y & ~MOVING_OBJECT;
    let word = pose * fp.words_per_pose + id / 32u;
    let kept = (box_mask[word] & (1u << (id % 32u))) != 0u;
    if (d.y & MOVING_OBJECT) != 0u {
        if kept {
            atomicOr(&refined[word], 1u << (id % 32u));
        }
        if fp.compact == 0u {
            draws[i] = DrawArgs(0u, 0u, 0u, 0i, id);
        }
        return;
    }
    let r = object_ranges[id];
    if fp.compact == 0u {
        draws[i] = DrawArgs(r.y, select(0u, 1u, kept), r.x, 0i, id);
        return;
    }
    if kept {
        let slot = pose_first[pose] + atomicAdd(&counts[pose], 1u);
        draws[slot] = DrawArgs(r.y, 1u, r.x, 0i, id);
    }
}
