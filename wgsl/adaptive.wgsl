// Per-pixel adaptive Halton with Blender Cycles' adaptive-sampling rule:
// the declarations the evaluate kernels (adaptive_evaluate.wgsl) and the
// control kernels (adaptive_control.wgsl) share. See
// src/integrator/adaptive.rs.

struct AdaptiveParams {
    width: u32,
    height: u32,
    dims: u32,
    seed: u32,
    // Samples each wanting pixel asks for this round (before the budget).
    round_samples: u32,
    // Budget left (samples, capped at 2^32 - 1): entries past it take
    // fewer samples or none.
    remaining: u32,
    spp_max: u32,
    // Entries in adaptive_list this round.
    entries: u32,
    // Evaluate/accumulate chunk: its first slot and its number of slots.
    first_slot: u32,
    slots: u32,
    samples_per_invocation: u32,
    // Cycles' internal threshold (5 × the user's noise threshold).
    threshold: f32,
    // Workgroups of the compaction (⌈pixels / ADAPTIVE_SCAN_WG⌉).
    pixel_groups: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> adaptive_params: AdaptiveParams;
@group(0) @binding(1) var<storage, read_write> adaptive_partial: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> adaptive_list: array<vec4<u32>>;

const ADAPTIVE_WG: u32 = 64u;
const ADAPTIVE_SCAN_WG: u32 = 256u;

fn adaptive_pixels() -> u32 {
    return adaptive_params.width * adaptive_params.height;
}

// Cycles' split of the samples into two classes (Christensen et al.,
// progressive multi-jittered sequences, §10.2.1): every aligned block of
// four indices has two of each.
fn adaptive_class_a(index: u32) -> bool {
    return (countOneBits(index & 0xaaaaaaaau) & 1u) == 1u;
}
