// Occluder raster and exact-oracle ID raster: one vertex stage for both, so their
// coverage is identical (`@invariant` position, same matrix, same vertices).
// CPU twin: `hom/raster.rs`.

@group(0) @binding(0) var<uniform> pose: PoseUniform;
// Each object's placement, applied to its vertices as loaded (identity until it moves:
// `gpu/scene_buffers.rs`). The instance index is the object's ID in every draw.
@group(0) @binding(1) var<storage, read> placements: array<mat4x4<f32>>;

struct VsOut {
    @invariant @builtin(position) clip: vec4<f32>,
    // View depth: clip w of a perspective projection, interpolated perspective-correctly.
    @location(0) depth: f32,
    @location(1) @interpolate(flat) id: u32,
}

@vertex
fn vs(@location(0) p: vec3<f32>, @builtin(instance_index) id: u32) -> VsOut {
    var out: VsOut;
    out.clip = pose.view_proj * (placements[id] * vec4<f32>(p, 1.0));
    out.depth = out.clip.w;
    out.id = id;
    return out;
}

// How far the interpolated depth may stray from its surface's at the pixel centre
// (`DEPTH_SLACK_PX` pixels of its gradient, `gpu/prelude.rs`).
fn depth_slack(depth: f32) -> f32 {
    return DEPTH_SLACK_PX * (abs(dpdxFine(depth)) + abs(dpdyFine(depth)));
}

// The occlusion map: each fragment's depth pushed back by its slack (never nearer than
// its surface, so it never hides what lies just behind it).
@fragment
fn fs_depth(in: VsOut) -> @location(0) f32 {
    return in.depth + depth_slack(in.depth);
}

@fragment
fn fs_id(in: VsOut) -> @location(0) u32 {
    return in.id;
}

// Refinement of HOM's box test: the objects that passed it are drawn once more, and a
// fragment that is not behind the occluders marks its object visible. An object none
// of whose pixels does that is hidden although its box is not. Two ways to decide
// "not behind" (`crate::gpu::refine`): `fs_refine_early` (refine_early.wgsl, where the
// adapter can force early depth tests) lets the fixed-function test against the
// occluders' own depth buffer decide before the shader runs; `fs_refine` here compares
// with the pose's occlusion-map layer, with the box test's depth margin.
// CPU twin: `hom::refine::refine`.

struct RefineParams {
    pose: u32,           // the pose's index in the batch
    words_per_pose: u32,
    _a: u32,
    _b: u32,
}

// The occlusion atlas: a fragment's framebuffer position is its pixel in the pose's slot.
@group(1) @binding(0) var occlusion: texture_2d<f32>;
@group(1) @binding(1) var<storage, read> box_mask: array<u32>;
@group(1) @binding(2) var<storage, read_write> refined: array<atomic<u32>>;
@group(1) @binding(3) var<uniform> rp: RefineParams;

// Sets object `id`'s bit in the refined mask if the box test kept it.
fn mark_visible(id: u32) {
    let w = rp.pose * rp.words_per_pose + id / 32u;
    let bit = 1u << (id % 32u);
    // Only objects the box test kept (the draws of the others are filtered out where
    // indirect draws exist; this keeps the direct-draw path right too).
    if (box_mask[w] & bit) == 0u || (atomicLoad(&refined[w]) & bit) != 0u {
        return;
    }
    atomicOr(&refined[w], bit);
}

@fragment
fn fs_refine(in: VsOut) {
    // The map is pushed back by its slack; the fragment comes forward by its own.
    let nearest = in.depth - depth_slack(in.depth);
    let occ = textureLoad(occlusion, vec2<u32>(in.clip.xy), 0).r;
    if occ > 0.0 && in_front(occ, nearest) {
        return;
    }
    mark_visible(in.id);
}
