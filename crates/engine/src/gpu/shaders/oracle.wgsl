// Exact oracle, second half: every pixel of the ID buffer marks its object visible.

struct CollectParams {
    width: u32,
    height: u32,
    words_per_pose: u32,
    first_pose: u32,
    atlas_cols: u32, // slots per atlas row
    _a: u32,
    _b: u32,
    _c: u32,
}

@group(0) @binding(0) var<uniform> cp: CollectParams;
@group(0) @binding(1) var ids: texture_2d<u32>;
@group(0) @binding(2) var<storage, read_write> mask: array<atomic<u32>>;


@compute @workgroup_size(GRID_WORKGROUP, GRID_WORKGROUP, 1)
fn collect(@builtin(global_invocation_id) g: vec3<u32>) {
    if g.x >= cp.width || g.y >= cp.height {
        return;
    }
    let at = slot_origin(g.z, cp.atlas_cols, vec2<u32>(cp.width, cp.height)) + g.xy;
    let id = textureLoad(ids, at, 0).r;
    if id == NO_OBJECT {
        return;
    }
    let w = (cp.first_pose + g.z) * cp.words_per_pose + id / 32u;
    let bit = 1u << (id % 32u);
    // Most pixels repeat a neighbour's object: skip the atomic when the bit is set.
    if (atomicLoad(&mask[w]) & bit) == 0u {
        atomicOr(&mask[w], bit);
    }
}
