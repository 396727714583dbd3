//! The Morton code of the initial grid on the CPU, twin of
//! `wgsl/shared/morton.wgsl`: film bits above the interleaved low bits of
//! every dimension (module docs of [`super`]).

/// Cell coordinates of a Morton code (twin of `wgsl/shared/morton.wgsl`).
pub fn morton_decode(code: u32, dims: u32, b: u32, e: u32) -> Vec<u32> {
    let mut cell = vec![0u32; dims as usize];
    for j in 0..b {
        for k in 0..dims {
            cell[k as usize] |= ((code >> (j * dims + k)) & 1) << j;
        }
    }
    for j in 0..e {
        for a in 0..2 {
            cell[a as usize] |= ((code >> (dims * b + 2 * j + a)) & 1) << (b + j);
        }
    }
    cell
}

/// Inverse of [`morton_decode`].
pub fn morton_encode(cell: &[u32], b: u32, e: u32) -> u32 {
    let dims = cell.len() as u32;
    let mut code = 0;
    for j in 0..b {
        for k in 0..dims {
            code |= ((cell[k as usize] >> j) & 1) << (j * dims + k);
        }
    }
    for j in 0..e {
        for a in 0..2 {
            code |= ((cell[a as usize] >> (b + j)) & 1) << (dims * b + 2 * j + a);
        }
    }
    code
}
