// Stable LSD radix sort of (u32 key, u32 value) pairs, one RADIX_BITS-bit
// digit per pass, reduce-then-scan (docs/conventions.md: no decoupled look-back, no
// spin-waits). src/gpu/radix_sort.rs documents the algorithm and owns the
// constants WG, ITEMS, TILE = WG·ITEMS, RADIX = 2^RADIX_BITS, SCAN_WG.
//
// Per pass, three entry points over the same bindings:
//   histogram    one workgroup per tile of TILE keys: digit counts of the
//                tile → hist[d · tiles + tile] (digit-major).
//   scan_digits  one workgroup per digit: exclusive prefix over the tiles of
//                hist row d, in place; the row total → hist[RADIX·tiles + d].
//   scatter      one workgroup per tile: ranks each key among the tile's keys
//                of the same digit (stable: invocation t owns the contiguous
//                keys [t·ITEMS, (t+1)·ITEMS) of the tile) and writes it to
//                Σ_{d'<d} total[d'] + hist[d · tiles + tile] + rank.
//
// Every count is an integer and every position a function of the input
// only, so the result does not depend on scheduling. Loops run at most
// max(2·ITEMS, 2·⌈tiles/SCAN_WG⌉, RADIX) times per invocation.

struct Params {
    n: u32,
    shift: u32,
    // Digit mask: (1 << min(RADIX_BITS, key_bits − shift)) − 1.
    mask: u32,
    tiles: u32,
    // Workgroups along x of the 2D dispatch (Gpu::dispatch_dims).
    groups_x: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> keys_in: array<u32>;
@group(0) @binding(2) var<storage, read> values_in: array<u32>;
@group(0) @binding(3) var<storage, read_write> keys_out: array<u32>;
@group(0) @binding(4) var<storage, read_write> values_out: array<u32>;
@group(0) @binding(5) var<storage, read_write> hist: array<u32>;

fn digit_of(key: u32) -> u32 {
    return (key >> params.shift) & params.mask;
}

fn tile_index(wid: vec3<u32>) -> u32 {
    return wid.x + wid.y * params.groups_x;
}

// ---- histogram ----

var<workgroup> tile_counts: array<atomic<u32>, RADIX>;

@compute @workgroup_size(WG)
fn histogram(@builtin(workgroup_id) wid: vec3<u32>,
             @builtin(local_invocation_index) lid: u32) {
    let tile = tile_index(wid);
    for (var d = lid; d < RADIX; d += WG) {
        atomicStore(&tile_counts[d], 0u);
    }
    workgroupBarrier();
    // Integer additions commute: the counts do not depend on their order.
    let start = tile * TILE + lid * ITEMS;
    for (var j = 0u; j < ITEMS; j++) {
        let i = start + j;
        if (i < params.n) {
            atomicAdd(&tile_counts[digit_of(keys_in[i])], 1u);
        }
    }
    workgroupBarrier();
    if (tile < params.tiles) {
        for (var d = lid; d < RADIX; d += WG) {
            hist[d * params.tiles + tile] = atomicLoad(&tile_counts[d]);
        }
    }
}

// ---- scan of each digit's row of tile counts ----

var<workgroup> scan_chunks: array<u32, SCAN_WG>;

@compute @workgroup_size(SCAN_WG)
fn scan_digits(@builtin(workgroup_id) wid: vec3<u32>,
               @builtin(local_invocation_index) lid: u32) {
    let d = wid.x;
    let tiles = params.tiles;
    let row = d * tiles;
    let chunk = (tiles + SCAN_WG - 1u) / SCAN_WG;
    let start = min(lid * chunk, tiles);
    let end = min(start + chunk, tiles);
    var sum = 0u;
    for (var i = start; i < end; i++) {
        sum += hist[row + i];
    }
    scan_chunks[lid] = sum;
    workgroupBarrier();
    if (lid == 0u) {
        var run = 0u;
        for (var c = 0u; c < SCAN_WG; c++) {
            let x = scan_chunks[c];
            scan_chunks[c] = run;
            run += x;
        }
        hist[RADIX * tiles + d] = run;
    }
    workgroupBarrier();
    var run = scan_chunks[lid];
    for (var i = start; i < end; i++) {
        let x = hist[row + i];
        hist[row + i] = run;
        run += x;
    }
}

// ---- scatter ----

// ranks[d · WG + t]: first the count of digit d among invocation t's keys,
// then, after the scan, the count of keys in the tile with a smaller digit,
// or the same digit and a smaller position; used as a running position.
var<workgroup> ranks: array<u32, RADIX * WG>;
var<workgroup> rank_chunks: array<u32, WG>;
// Destination of the tile's first key of each digit, minus ranks[d · WG].
var<workgroup> digit_base: array<u32, RADIX>;

// RADIX·WG entries over WG invocations.
const RANK_CHUNK: u32 = RADIX;

@compute @workgroup_size(WG)
fn scatter(@builtin(workgroup_id) wid: vec3<u32>,
           @builtin(local_invocation_index) lid: u32) {
    let tile = tile_index(wid);
    for (var d = 0u; d < RADIX; d++) {
        ranks[d * WG + lid] = 0u;
    }
    let start = tile * TILE + lid * ITEMS;
    for (var j = 0u; j < ITEMS; j++) {
        let i = start + j;
        if (i < params.n) {
            let d = digit_of(keys_in[i]);
            ranks[d * WG + lid] += 1u;
        }
    }
    workgroupBarrier();

    // Exclusive scan of ranks (digit-major): each invocation scans a
    // contiguous chunk of RANK_CHUNK entries, invocation 0 the chunk totals.
    let c0 = lid * RANK_CHUNK;
    var sum = 0u;
    for (var k = 0u; k < RANK_CHUNK; k++) {
        sum += ranks[c0 + k];
    }
    rank_chunks[lid] = sum;
    workgroupBarrier();
    if (lid == 0u) {
        var run = 0u;
        for (var c = 0u; c < WG; c++) {
            let x = rank_chunks[c];
            rank_chunks[c] = run;
            run += x;
        }
    }
    workgroupBarrier();
    var run = rank_chunks[lid];
    for (var k = 0u; k < RANK_CHUNK; k++) {
        let x = ranks[c0 + k];
        ranks[c0 + k] = run;
        run += x;
    }
    workgroupBarrier();

    if (lid < RADIX && tile < params.tiles) {
        let tiles = params.tiles;
        var below = 0u;
        for (var d = 0u; d < lid; d++) {
            below += hist[RADIX * tiles + d];
        }
        digit_base[lid] = below + hist[lid * tiles + tile] - ranks[lid * WG];
    }
    workgroupBarrier();

    for (var j = 0u; j < ITEMS; j++) {
        let i = start + j;
        if (i < params.n) {
            let key = keys_in[i];
            let d = digit_of(key);
            let r = ranks[d * WG + lid];
            ranks[d * WG + lid] = r + 1u;
            let dst = digit_base[d] + r;
            keys_out[dst] = key;
            values_out[dst] = values_in[i];
        }
    }
}
