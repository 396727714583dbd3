// Initial sampling (paper §4.1): one invocation per Morton cell. The cell
// becomes leaf `cell` (full box, error DIRTY) holding SAMPLES_PER_CELL
// samples at indices cell·l .. cell·l + l − 1 in slots 0 … l − 1, Latin-hypercube stratified
// inside the cell: along every axis sample j takes stratum rank_a(j) of l
// equal strata, rank_a a random permutation (ranks of hashed keys), at an
// offset inside it that is uniform per sample or, with INITIAL_KRONECKER,
// the cell's point of a Kronecker sequence. Random numbers:
// draw(leaf_key(cell, 0), …).

@compute @workgroup_size(WG)
fn initial(@builtin(global_invocation_id) gid: vec3<u32>,
           @builtin(num_workgroups) groups: vec3<u32>) {
    let cell = thread_index(gid, groups, WG);
    if (cell >= leaf_count()) {
        return;
    }
    let first = cell * SAMPLES_PER_CELL;
    let cell_key = leaf_key(cell, 0u);
    // The Kronecker shifts' key: one per render (no leaf or iteration
    // takes these indices).
    let render_key = leaf_key(0xffffffffu, 0xffffffffu);
    for (var j = 0u; j < SAMPLES_PER_CELL; j++) {
        let s = first + j;
        var words: array<u32, COORD_WORDS>;
        for (var w = 0u; w < COORD_WORDS; w++) {
            words[w] = 0u;
        }
        for (var axis = 0u; axis < DIMS; axis++) {
            let key = draw(cell_key, 2u * (axis * 16u + j));
            var rank = 0u;
            for (var i = 0u; i < SAMPLES_PER_CELL; i++) {
                let other = draw(cell_key, 2u * (axis * 16u + i));
                if (other < key || (other == key && i < j)) {
                    rank += 1u;
                }
            }
            // The offset inside the stratum (initial_offsets): uniform
            // per sample, or on the axes past the film the cell's point of
            // a Kronecker sequence, frac(cell·α_axis + s_axis) in 0.32
            // fixed point with s_axis random per render — uniform for each
            // cell (so the estimate stays unbiased) and spread evenly over
            // the cells of a pixel, which are neighbours in Morton order.
            var jitter: u32;
            if (INITIAL_KRONECKER == 1u && axis >= 2u) {
                let shift = draw(render_key, axis);
                jitter = (cell * LATTICE_STEPS[axis] + shift) >> 16u;
            } else {
                jitter = draw(cell_key, 2u * (axis * 16u + j) + 1u) >> 16u;
            }
            let q = (rank * 65536u + jitter) / SAMPLES_PER_CELL;
            words[axis / 2u] |= q << (16u * (axis % 2u));
        }
        for (var w = 0u; w < COORD_WORDS; w++) {
            samples_set(s * SAMPLE_STRIDE + w, words[w]);
        }
        values_set(3u * s, cell);
        if (j > 0u) {
            set_leaf_slot(cell, j, s);
        }
    }
    let base = leaf_base(cell);
    leaves_set(base, cell);
    leaves_set(base + 1u, make_header(first, SAMPLES_PER_CELL));
    leaves_set(base + 2u, DIRTY);
    for (var axis = 0u; axis < DIMS; axis++) {
        boxes_set(box_base(cell) + axis, make_box(0u, 65536u));
    }
}
