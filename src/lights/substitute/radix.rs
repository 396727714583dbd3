//! The paper's substitute tree: a binary radix tree (Karras 2012) over the
//! eq. 4 keys `C = M ⊕ N` (Tatzgern et al. 2020 §3.3: "we construct a
//! radix tree … using the codes"), stored in the light BVH's layout
//! ([`crate::lights::bvh`]: explicit children in pairs, a parent per
//! node), with a [`Substitute`] beside every node.
//!
//! # Keys
//!
//! `M` is the 30-bit Morton code of [`crate::lights::morton`] (x in the
//! highest bit of each triple), `N` the 9-bit [`normal_code`] with a tenth
//! bit above it for a light without a normal (a point light or an
//! emissive triangle, [`prim_normal`] = 0), so such lights form a class
//! of their own after every direction of their cell instead of sharing
//! code 0 with lights that face the first sub-triangle (the authors' demo
//! code does the same with an "omni" bit; the paper's 9 bits leave the
//! case open): 40 bits in all. The leaves hold the lights sorted by
//! (key, light id).
//!
//! # The tree
//!
//! Every internal node covers a run of sorted leaves `[first, last]` and
//! splits it where the keys first differ: at the first bit of the
//! difference between `key[first]` and `key[last]`, its left child taking
//! the keys with a 0 there. So a node is one Morton cell (an octree cell,
//! or a half or quarter of one), then within one 1024³ cell one class of
//! normals (octant, then sub-triangles), then — for equal keys only — a
//! run split by leaf index (Karras's tie-break, §4: δ(i, j) for equal keys
//! is 64 + the common prefix of the indices). This is the tree the
//! per-node construction of Karras 2012 (Fig. 4) builds in parallel on a
//! GPU, as [`super::gpu_build`] does for rendering; here it is built
//! top-down, which gives the same tree (the unit tests check the radix
//! property at every node, and that Karras's ranges are these), and this
//! build is the GPU build's oracle. N lights give N − 1
//! internal nodes and N leaves, no bogus leaves, unlike the perfect tree
//! of `sst_perfect` ([`super::build`]), whose equal-count halves straddle
//! cells and normal classes.
//!
//! The depth is at most 40 + ⌈log₂ N⌉ + 1 nodes (the split bit strictly
//! grows down a path: 40 key bits, then ⌈log₂ N⌉ index bits), at most 71
//! for 2³⁰ lights, within [`MAX_DEPTH`] and the WGSL's path arrays.
//!
//! Node bounds, intensities and cones are gathered as the BVH's; the
//! substitutes merge as the perfect tree's ([`merge`] with the children's
//! intensities), children first.

use super::{
    merge, normal_code, prim_normal, SstSampler, Substitute, SubstituteLayout, SubstituteParams,
    MAX_LIGHTS,
};
use crate::gpu::Gpu;
use crate::lights::bvh::{self, LightBvh, INTERNAL_BIT, MAX_DEPTH};
use crate::lights::light_params::{LightParams, SamplerBuffers};
use crate::lights::sampler::{CpuOptions, Layout, LightSampler, Technique};
use crate::lights::tree::cut::LightTree;
use crate::lights::tree::perfect::{gather, leaf_node};
use crate::lights::{morton, LightCone, LightPrim, TreeNode, NO_LIGHT};

/// Bits of a radix key: 30 Morton bits, the 9-bit normal code and the
/// no-normal bit.
pub const KEY_BITS: u32 = 30 + super::NORMAL_BITS + 1;

/// The 10-bit normal class of a light: [`normal_code`], or `1 << 9` for a
/// light without a normal.
pub fn normal_class(prim: &LightPrim) -> u32 {
    let n = prim_normal(prim);
    if n == [0.0; 3] {
        1 << super::NORMAL_BITS
    } else {
        normal_code(n)
    }
}

/// The lights' ids sorted by (key, id) and the keys in that order.
pub fn sorted_keys(prims: &[LightPrim]) -> (Vec<u32>, Vec<u64>) {
    let codes = morton::codes(prims);
    let mut pairs: Vec<(u64, u32)> = codes
        .iter()
        .zip(prims)
        .enumerate()
        .map(|(id, (&m, p))| {
            let key = (m as u64) << (super::NORMAL_BITS + 1) | normal_class(p) as u64;
            (key, id as u32)
        })
        .collect();
    pairs.sort_unstable();
    pairs.into_iter().map(|(k, id)| (id, k)).unzip()
}

/// Karras's δ: the length of the common prefix of sorted entries `i` and
/// `j` as 64-bit keys, and for equal keys 64 + that of their indices; −1
/// outside the array. Strictly larger for closer entries of a run.
pub fn delta(keys: &[u64], i: usize, j: isize) -> i32 {
    if j < 0 || j as usize >= keys.len() {
        return -1;
    }
    let (a, b) = (keys[i], keys[j as usize]);
    if a != b {
        (a ^ b).leading_zeros() as i32
    } else {
        64 + ((i as u64) ^ (j as u64)).leading_zeros() as i32
    }
}

/// The last leaf of the left child of the node over `[first, last]`
/// (`first < last`): the largest `s < last` with δ(first, s) > δ(first,
/// last), by binary search.
pub fn split(keys: &[u64], first: usize, last: usize) -> usize {
    let node = delta(keys, first, last as isize);
    let (mut s, mut step) = (first, last - first);
    loop {
        step = step.div_ceil(2);
        let m = s + step;
        if m < last && delta(keys, first, m as isize) > node {
            s = m;
        }
        if step <= 1 {
            return s;
        }
    }
}

/// The radix tree over the lights with a substitute per node.
#[derive(Clone, Debug, PartialEq)]
pub struct RadixTree {
    /// The nodes in the BVH layout (`2N − 1`, node 0 the root).
    pub bvh: LightBvh,
    /// One per node, indexed like `bvh.nodes`.
    pub substitutes: Vec<Substitute>,
    /// Light ids in leaf order (sorted by key, then id).
    pub sorted: Vec<u32>,
}

/// Builds the radix substitute tree; `None` for zero lights.
///
/// # Panics
///
/// Over [`MAX_LIGHTS`] lights.
pub fn build(prims: &[LightPrim]) -> Option<RadixTree> {
    let n = prims.len();
    if n == 0 {
        return None;
    }
    assert!(n <= MAX_LIGHTS as usize, "at most 2^30 lights");
    let (sorted, keys) = sorted_keys(prims);
    let mut nodes = vec![TreeNode::EMPTY; 2 * n - 1];
    let mut parent = vec![NO_LIGHT; 2 * n - 1];
    let mut leaf_of_light = vec![0u32; n];
    let mut next = 1usize;
    let mut max_depth = 1;
    // (node, first, last, depth): the sorted leaves [first, last].
    let mut stack = vec![(0usize, 0usize, n - 1, 1u32)];
    while let Some((node, first, last, depth)) = stack.pop() {
        max_depth = max_depth.max(depth);
        if first == last {
            let id = sorted[first];
            nodes[node].id = id;
            leaf_of_light[id as usize] = node as u32;
            continue;
        }
        let s = split(&keys, first, last);
        let left = next;
        next += 2;
        nodes[node].id = INTERNAL_BIT | left as u32;
        parent[left] = node as u32;
        parent[left + 1] = node as u32;
        stack.push((left + 1, s + 1, last, depth + 1));
        stack.push((left, first, s, depth + 1));
    }
    debug_assert_eq!(next, 2 * n - 1);
    assert!(max_depth <= MAX_DEPTH, "radix tree depth {max_depth}");
    // Children always follow their parent: gather in reverse index order.
    let mut cones = vec![LightCone::EMPTY; nodes.len()];
    let mut substitutes = vec![Substitute::default(); nodes.len()];
    for i in (0..nodes.len()).rev() {
        let id = nodes[i].id;
        if id & INTERNAL_BIT != 0 {
            let l = (id & !INTERNAL_BIT) as usize;
            let (a, b) = (nodes[l], nodes[l + 1]);
            nodes[i] = TreeNode {
                id,
                ..gather(&a, &b)
            };
            cones[i] = cones[l].union(&cones[l + 1]);
            substitutes[i] = merge(
                &substitutes[l],
                a.intensity,
                &substitutes[l + 1],
                b.intensity,
            );
        } else {
            let prim = &prims[id as usize];
            nodes[i] = leaf_node(prim, id);
            cones[i] = LightCone::of_prim(prim);
            substitutes[i] = Substitute::of_prim(prim);
        }
    }
    Some(RadixTree {
        bvh: LightBvh {
            nodes,
            parent,
            leaf_of_light,
            depth: max_depth,
            cones,
        },
        substitutes,
        sorted,
    })
}

impl LightTree for RadixTree {
    fn nodes(&self) -> &[TreeNode] {
        &self.bvh.nodes
    }
    fn cones(&self) -> &[LightCone] {
        &self.bvh.cones
    }
    fn children(&self, node: usize) -> Option<(usize, usize)> {
        self.bvh.children(node)
    }
    fn parent(&self, node: usize) -> Option<usize> {
        LightTree::parent(&self.bvh, node)
    }
    fn leaf_of_light(&self, light: u32) -> Option<usize> {
        LightTree::leaf_of_light(&self.bvh, light)
    }
    fn light_count(&self) -> u32 {
        LightTree::light_count(&self.bvh)
    }
    fn leaf_light(&self, node: usize) -> u32 {
        self.bvh.leaf_light(node)
    }
}

impl SubstituteLayout for RadixTree {
    fn substitutes(&self) -> &[Substitute] {
        &self.substitutes
    }
}

/// The radix substitute tree as a [`Technique`] (`sst`, `sst_nosub`):
/// sampled on the GPU by the BVH-layout descent, which stops at suitable
/// substitutes when the kind says so. Its upload builds the tree here on
/// the CPU (tests, tools); the many-light integrand builds it on the GPU
/// every frame instead ([`super::gpu_build::GpuRadixTree`], the same
/// buffers bit for bit).
pub struct RadixSubstituteTree;

/// The technique of the registry's `sst` and `sst_nosub` lines.
pub static RADIX_SUBSTITUTE_TREE: RadixSubstituteTree = RadixSubstituteTree;

impl Technique for RadixSubstituteTree {
    fn name(&self) -> &'static str {
        "radix substitute tree"
    }

    fn layout(&self) -> Layout {
        Layout::Bvh
    }

    fn substitutes(&self) -> bool {
        true
    }

    fn sampler(
        &self,
        prims: &[LightPrim],
        o: &CpuOptions<'_>,
    ) -> Box<dyn LightSampler + Send + Sync> {
        Box::new(SstSampler {
            tree: build(prims).expect("at least one light"),
            params: o.substitutes.then(SubstituteParams::default),
        })
    }

    fn upload(
        &self,
        gpu: &Gpu,
        prims: &[LightPrim],
        cones: bool,
        params: &mut LightParams,
        out: &mut SamplerBuffers,
    ) -> anyhow::Result<()> {
        let t = build(prims).expect("at least one light");
        bvh::gpu::upload(gpu, &t.bvh, cones, params, out)?;
        out.substitutes = Some(SamplerBuffers::upload(gpu, "substitutes", &t.substitutes)?);
        Ok(())
    }
}
