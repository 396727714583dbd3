// Morton (Z-order) decoding of the MDAS initial grid (paper §4.1).
//
// A code of dims·b + 2e bits addresses one cell of a grid with 2^(b+e)
// cells along each film axis (axes 0, 1) and 2^b along every other axis.
// Bits 0 .. dims·b − 1 interleave all axes (bit j of axis k sits at
// j·dims + k); the 2e bits above them interleave the film axes only and are
// the high-order bits of their cell coordinates (bit j of axis a ∈ {0, 1}
// sits at dims·b + 2j + a). src/integrator/mdas/cpu_oracle.rs is the CPU twin.

fn morton_decode(code: u32, dims: u32, b: u32, e: u32) -> array<u32, MAX_DIMS> {
    var cell: array<u32, MAX_DIMS>;
    for (var k = 0u; k < dims; k++) {
        cell[k] = 0u;
    }
    for (var j = 0u; j < b; j++) {
        for (var k = 0u; k < dims; k++) {
            cell[k] |= ((code >> (j * dims + k)) & 1u) << j;
        }
    }
    for (var j = 0u; j < e; j++) {
        for (var a = 0u; a < 2u; a++) {
            cell[a] |= ((code >> (dims * b + 2u * j + a)) & 1u) << (b + j);
        }
    }
    return cell;
}
