//! The GPU radix sort and the GPU perfect light tree against their CPU
//! references: `sort_by_key` (stable) and `lights::perfect::build`, bit for
//! bit.

mod common;

use mdas::gpu::buffer::STORAGE;
use mdas::gpu::Gpu;
use mdas::lights::radix_sort::RadixSort;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// Sorts `(keys, ids)` on the GPU by the low `key_bits` bits.
fn gpu_sort(gpu: &Gpu, sorter: &RadixSort, keys: &[u32], key_bits: u32) -> (Vec<u32>, Vec<u32>) {
    let values: Vec<u32> = (0..keys.len() as u32).collect();
    let k = gpu.buffer_from("test.sort.keys", keys, STORAGE).unwrap();
    let v = gpu
        .buffer_from("test.sort.values", &values, STORAGE)
        .unwrap();
    gpu.scoped("test sort", || {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        sorter.sort(gpu, &mut encoder, None, &k, &v, keys.len() as u32, key_bits)?;
        gpu.queue.submit([encoder.finish()]);
        Ok(())
    })
    .unwrap();
    (
        gpu.read_buffer(&k, keys.len()).unwrap(),
        gpu.read_buffer(&v, keys.len()).unwrap(),
    )
}

/// The stable CPU sort by the masked key.
fn cpu_sort(keys: &[u32], key_bits: u32) -> (Vec<u32>, Vec<u32>) {
    let mask = if key_bits >= 32 {
        u32::MAX
    } else {
        (1u32 << key_bits) - 1
    };
    let mut pairs: Vec<(u32, u32)> = keys.iter().copied().zip(0..).collect();
    pairs.sort_by_key(|&(k, _)| k & mask);
    pairs.into_iter().unzip()
}

fn check_sort(gpu: &Gpu, sorter: &RadixSort, keys: &[u32], key_bits: u32, what: &str) {
    let (gk, gv) = gpu_sort(gpu, sorter, keys, key_bits);
    let (ck, cv) = cpu_sort(keys, key_bits);
    assert!(
        gk == ck,
        "{what}: keys differ (n = {}, bits = {key_bits})",
        keys.len()
    );
    assert!(
        gv == cv,
        "{what}: values differ (n = {}, bits = {key_bits})",
        keys.len()
    );
}

#[test]
fn radix_sort_matches_stable_cpu_sort() {
    let gpu = common::gpu();
    let sorter = RadixSort::new(gpu, 1 << 20).unwrap();
    let mut rng = StdRng::seed_from_u64(6);
    for n in [0usize, 1, 2, 255, 256, 257, 2047, 2048, 2049, 5000, 100_003] {
        let random: Vec<u32> = (0..n).map(|_| rng.random::<u32>() >> 2).collect();
        check_sort(gpu, &sorter, &random, 30, "random 30-bit");
        // Few distinct keys: long runs of equal keys test stability.
        let few: Vec<u32> = (0..n).map(|_| rng.random_range(0..5u32) << 27).collect();
        check_sort(gpu, &sorter, &few, 30, "five distinct keys");
    }
    for n in [0usize, 1, 255, 256, 257, 4099] {
        let equal = vec![0x2aaa_aaaau32; n];
        check_sort(gpu, &sorter, &equal, 30, "all equal");
        let sorted: Vec<u32> = (0..n as u32).map(|i| i * 7).collect();
        check_sort(gpu, &sorter, &sorted, 30, "already sorted");
        let reversed: Vec<u32> = sorted.iter().rev().copied().collect();
        check_sort(gpu, &sorter, &reversed, 30, "reversed");
    }
    // Bits above key_bits travel along but do not order; odd pass counts
    // (a copy back) and full 32-bit keys.
    let wide: Vec<u32> = (0..3001).map(|_| rng.random::<u32>()).collect();
    for bits in [0, 1, 4, 5, 12, 30, 31, 32] {
        check_sort(gpu, &sorter, &wide, bits, "wide keys");
    }
}

#[test]
fn radix_sort_one_million() {
    let gpu = common::gpu();
    let n = 1 << 20;
    let sorter = RadixSort::new(gpu, n).unwrap();
    let mut rng = StdRng::seed_from_u64(7);
    let keys: Vec<u32> = (0..n).map(|_| rng.random::<u32>() >> 2).collect();
    check_sort(gpu, &sorter, &keys, 30, "1M random");
}

#[test]
fn radix_sort_refuses_over_capacity() {
    let gpu = common::gpu();
    let sorter = RadixSort::new(gpu, 100).unwrap();
    let k = gpu.buffer_zeroed("test.sort.k", 4 * 101, STORAGE).unwrap();
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    let err = sorter
        .sort(gpu, &mut encoder, None, &k, &k, 101, 30)
        .unwrap_err();
    assert!(err.to_string().contains("capacity"), "{err}");
    let small = gpu.buffer_zeroed("test.sort.small", 16, STORAGE).unwrap();
    let err = sorter
        .sort(gpu, &mut encoder, None, &small, &k, 100, 30)
        .unwrap_err();
    assert!(err.to_string().contains("keys buffer"), "{err}");
}
