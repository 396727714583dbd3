//! Two-level CWBVH construction on the CPU with obvhs.
//!
//! **Instances.** All static meshes (world-space vertices) are merged into
//! one bottom-level BVH (BLAS) placed with the identity; every moving mesh
//! gets its own BLAS over its object-space vertices, placed by its
//! keyframes. A top-level BVH (TLAS) is built over the instances' world
//! bounds — for moving instances the bounds swept over all time
//! ([`crate::scene::motion::swept_bounds`]).
//!
//! **Builder.** Each BVH is a compressed wide 8-ary BVH (Ylitie, Karras &
//! Laine 2017, "Efficient Incoherent Ray Traversal on GPUs Through
//! Compressed Wide BVHs"): obvhs builds a binary BVH with PLOC (Meister &
//! Bittner 2018, "Parallel Locally-Ordered Clustering for Bounding Volume
//! Hierarchy Construction"), improves it by reinsertion and collapses it to
//! 8-wide nodes with the paper's SAH-based conversion (≤ 3 triangles per
//! leaf). [`BUILD_PARAMS`] is obvhs' `fast_build` preset: PLOC search
//! radius "low", 2 % reinsertion, and *no pre-splits* — so every triangle
//! appears in exactly one leaf and leaves can index triangles directly.
//! The builder sees each primitive's box grown by a tiny amount that
//! varies from primitive to primitive (`tie_broken`): PLOC merges two
//! clusters only when each is the other's cheapest neighbour, and where
//! every neighbour costs the same (a row of equal, equally spaced
//! triangles) every cluster picks the same side, one pair merges per
//! pass, and the build takes time quadratic in the count (40k such
//! triangles: 21 s; issue 54 item 4). The grown boxes still bound their
//! primitives, so traversal is exact.
//!
//! **One flat layout.** Triangles are stored in BVH leaf order
//! (`primitive_indices`), instance after instance, so a leaf's primitive
//! index *is* the global triangle index. All node arrays are concatenated
//! into one: the TLAS first (root at node 0), then each BLAS with its
//! `child_base_idx` rebased by its node offset and its `primitive_base_idx`
//! by its triangle offset. Instances are stored in TLAS leaf order, so a
//! TLAS leaf's primitive index is the instance index. Traversal therefore
//! never adds per-instance offsets; [`GpuInstance::node_root`] says where a
//! BLAS starts and [`GpuInstance::prim_offset`] where its triangles start.
//!
//! The traversal stack must hold one entry per level of the TLAS and of a
//! BLAS plus one (see bvh.wgsl); [`BuiltScene::stack_depth`] is that bound
//! and [`BuiltScene::new`] fails if it exceeds [`super::BVH_STACK_SIZE`].
//!
//! **Shading normals and texture coordinates.** A triangle of a mesh with
//! shading normals ([`crate::scene::Mesh::normals`]) or texture
//! coordinates ([`crate::scene::Mesh::uvs`]) has a record of
//! [`RECORD_ROWS`] rows in [`BuiltScene::normals`]: its corners' normals
//! in the space of its vertices with their u in `w`, then (v0, v1, v2, 0)
//! (zero normals where the mesh has none: the geometric normal shades;
//! zero uvs where it has no coordinates); `v2.w` holds one more than the
//! record's index (0: none). On the device the records follow the
//! triangles in the same buffer (`triangle_shading_normal`, `triangle_uv`
//! in scene.wgsl).

use anyhow::{bail, Result};
use glam::{Vec2, Vec3, Vec3A};
use obvhs::{
    aabb::Aabb,
    cwbvh::{builder, node::CwBvhNode, CwBvh},
    triangle::Triangle,
    BvhBuildParams,
};
use std::time::{Duration, Instant};

use super::layout::{GpuInstance, GpuKeyframe};
use crate::scene::motion::{self, Rigid};
use crate::scene::{Keyframe, Scene};

/// Rows of a triangle's record of normals and texture coordinates (module
/// docs; `RECORD_ROWS` in scene.wgsl).
pub const RECORD_ROWS: usize = 4;

/// obvhs build parameters for every BLAS and the TLAS (see module docs).
pub const BUILD_PARAMS: BvhBuildParams = BvhBuildParams::fast_build();

/// The scene's geometry in the flat GPU layout, kept on the CPU.
#[derive(Clone, Debug, Default)]
pub struct BuiltScene {
    /// TLAS then every BLAS, offsets rebased (see module docs).
    pub nodes: Vec<CwBvhNode>,
    /// Three per triangle: v0.xyz | bitcast material, v1.xyz | bitcast
    /// instance, v2.xyz | bitcast (shading-normal record + 1, or 0). World
    /// space for the static instance, object space for moving ones.
    pub triangles: Vec<[f32; 4]>,
    /// [`RECORD_ROWS`] rows per triangle with shading normals or texture
    /// coordinates: n0.xyz | u0, n1 | u1, n2 | u2 (unit or zero normals,
    /// in the space of the triangle's vertices), then v0, v1, v2, 0.
    pub normals: Vec<[f32; 4]>,
    /// Per global triangle: (mesh index in the scene, triangle index in
    /// that mesh).
    pub source: Vec<[u32; 2]>,
    /// In TLAS leaf order.
    pub instances: Vec<GpuInstance>,
    /// Sorted by time per instance, unit rotations.
    pub keyframes: Vec<GpuKeyframe>,
    /// Node index of the TLAS root (0).
    pub tlas_root: u32,
    /// Traversal stack entries a ray can need (TLAS depth + 1 + deepest
    /// BLAS depth).
    pub stack_depth: u32,
    /// Wall time of the obvhs builds (BLASes and TLAS), milliseconds.
    pub build_ms: f64,
    /// Time obvhs reports for its core build (no AABB setup), ms.
    pub core_build_ms: f64,
}

/// The largest coordinate an instance's (swept) bounds may reach: box
/// surface areas, the builder's cost, stay finite in f32 below it.
pub const MAX_BOUNDS: f32 = 1e18;

/// A primitive's box as the builder sees it ([`tie_broken`]).
struct BuilderBox(Aabb);

impl obvhs::Boundable for BuilderBox {
    fn aabb(&self) -> Aabb {
        self.0
    }
}

/// The boxes grown on every side by u·max(2⁻¹² × the box's largest
/// extent, 2⁻²⁰ × its largest coordinate), u ∈ [0, 1) a hash of the
/// primitive's index: enough to separate PLOC's merge costs of equal
/// neighbours (the second term beats f32 rounding of far-off boxes'
/// extents), small enough not to matter to traversal. See the module
/// docs.
fn tie_broken(boxes: impl Iterator<Item = Aabb>) -> Vec<BuilderBox> {
    boxes
        .enumerate()
        .map(|(i, b)| {
            let mut h = (i as u64).wrapping_add(0x9e37_79b9_7f4a_7c15);
            h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            let u = ((h ^ (h >> 31)) >> 40) as f32 / (1u64 << 24) as f32;
            let extent = (b.max - b.min).max_element();
            let far = b.min.abs().max(b.max.abs()).max_element();
            let grow = u * (extent * 2f32.powi(-12)).max(far * 2f32.powi(-20));
            BuilderBox(Aabb::new(b.min - grow, b.max + grow))
        })
        .collect()
}

/// Triangles of one BLAS before reordering.
struct Group {
    /// Scene mesh of each triangle and its index there.
    source: Vec<[u32; 2]>,
    tris: Vec<Triangle>,
    /// Corner shading normals and texture coordinates of each triangle,
    /// if it has either.
    normals: Vec<Option<([Vec3; 3], [Vec2; 3])>>,
    motion: Vec<Keyframe>,
}

impl BuiltScene {
    /// Builds the BVHs for `scene`. Fails on out-of-range vertex indices,
    /// non-finite vertices, piles of coincident triangles, instances that
    /// move beyond ±[`MAX_BOUNDS`] or a hierarchy too deep for the GPU
    /// stack; a panic inside the builder comes back as an error too.
    pub fn new(scene: &Scene) -> Result<BuiltScene> {
        std::panic::catch_unwind(|| BuiltScene::build(scene)).unwrap_or_else(|panic| {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            bail!("the BVH builder failed on this geometry: {what}")
        })
    }

    fn build(scene: &Scene) -> Result<BuiltScene> {
        let groups = groups(scene)?;
        for g in &groups {
            let tri = |t: &Triangle| [t.v0, t.v1, t.v2].map(Vec3::from);
            if let Some(pile) = crate::scene::shapes::coincident_triangles(g.tris.iter().map(tri)) {
                let mesh = &scene.meshes[g.source[pile.first[0]][0] as usize].name;
                bail!("the geometry around mesh '{mesh}' is degenerate: {pile}");
            }
        }
        let start = Instant::now();
        let mut core = Duration::ZERO;

        let blases: Vec<CwBvh> = groups
            .iter()
            .map(|g| {
                let boxes = tie_broken(g.tris.iter().map(|t| t.aabb()));
                builder::build_cwbvh(&boxes, BUILD_PARAMS, &mut core)
            })
            .collect();
        let bounds: Vec<Aabb> = groups
            .iter()
            .zip(&blases)
            .map(|(g, b)| motion::swept_bounds(&g.motion, &b.total_aabb))
            .collect();
        for (g, b) in groups.iter().zip(&bounds) {
            let extent = b.min.abs().max(b.max.abs()).max_element();
            if !extent.is_finite() || extent > MAX_BOUNDS {
                let mesh = g
                    .source
                    .first()
                    .map_or("?", |s| &scene.meshes[s[0] as usize].name);
                bail!(
                    "mesh '{mesh}' reaches a coordinate of {extent:e} over the shutter, beyond \
                     the ±{MAX_BOUNDS:e} a BVH's box areas stay finite for"
                );
            }
        }
        let tlas = if bounds.is_empty() {
            CwBvh::default()
        } else {
            builder::build_cwbvh(&tie_broken(bounds.iter().copied()), BUILD_PARAMS, &mut core)
        };
        let build_ms = start.elapsed().as_secs_f64() * 1e3;

        let mut out = BuiltScene {
            nodes: tlas.nodes.clone(),
            build_ms,
            core_build_ms: core.as_secs_f64() * 1e3,
            ..Default::default()
        };
        let mut max_blas_depth = 0;
        // The group of the deepest BLAS, to name in a stack-depth error.
        let mut deepest_group = 0usize;
        // Instance i of the flat layout is group tlas.primitive_indices[i].
        for (instance, &g) in tlas.primitive_indices.iter().enumerate() {
            let (group, blas) = (&groups[g as usize], &blases[g as usize]);
            let node_offset = out.nodes.len() as u32;
            let prim_offset = (out.triangles.len() / 3) as u32;
            out.instances.push(GpuInstance {
                node_root: node_offset,
                prim_offset,
                key_offset: out.keyframes.len() as u32,
                key_count: group.motion.len() as u32,
            });
            out.keyframes
                .extend(group.motion.iter().map(|k| GpuKeyframe {
                    translation: k.translation.into(),
                    time: k.time,
                    rotation: k.rotation.into(),
                }));
            out.nodes.extend(blas.nodes.iter().map(|n| CwBvhNode {
                child_base_idx: n.child_base_idx + node_offset,
                primitive_base_idx: n.primitive_base_idx + prim_offset,
                ..*n
            }));
            for &p in &blas.primitive_indices {
                let [mesh, tri] = group.source[p as usize];
                let Triangle { v0, v1, v2 } = group.tris[p as usize];
                let material = scene.meshes[mesh as usize].material;
                let record = match group.normals[p as usize] {
                    Some((ns, uvs)) => {
                        for k in 0..3 {
                            out.normals.push([ns[k].x, ns[k].y, ns[k].z, uvs[k].x]);
                        }
                        out.normals.push([uvs[0].y, uvs[1].y, uvs[2].y, 0.0]);
                        u32::try_from(out.normals.len() / RECORD_ROWS)?
                    }
                    None => 0,
                };
                out.triangles
                    .push([v0.x, v0.y, v0.z, f32::from_bits(material)]);
                out.triangles
                    .push([v1.x, v1.y, v1.z, f32::from_bits(instance as u32)]);
                out.triangles
                    .push([v2.x, v2.y, v2.z, f32::from_bits(record)]);
                out.source.push([mesh, tri]);
            }
            if depth(blas) > max_blas_depth {
                max_blas_depth = depth(blas);
                deepest_group = g as usize;
            }
        }
        out.stack_depth = if out.instances.is_empty() {
            0
        } else {
            depth(&tlas) + 1 + max_blas_depth
        };
        if out.stack_depth > super::BVH_STACK_SIZE {
            // Name the meshes of the deepest BLAS (issue 54 item 8): the
            // static group can hold many, a moving mesh is its own.
            let mut names: Vec<&str> = groups
                .get(deepest_group)
                .map(|g| {
                    g.source
                        .iter()
                        .map(|s| scene.meshes[s[0] as usize].name.as_str())
                        .collect()
                })
                .unwrap_or_default();
            names.dedup();
            let shown = names
                .iter()
                .take(4)
                .map(|n| format!("'{n}'"))
                .collect::<Vec<_>>();
            let more = if names.len() > 4 { ", …" } else { "" };
            bail!(
                "the scene's BVH needs a traversal stack of {} entries but the GPU traversal has {}; \
                 the deepest part is the BVH over mesh {}{more}, whose geometry is probably \
                 degenerate (many coincident or nested triangles)",
                out.stack_depth,
                super::BVH_STACK_SIZE,
                shown.join(", ")
            );
        }
        Ok(out)
    }

    pub fn triangle_count(&self) -> u32 {
        (self.triangles.len() / 3) as u32
    }

    /// Instance of global triangle `prim`.
    pub fn triangle_instance(&self, prim: u32) -> u32 {
        self.triangles[3 * prim as usize + 1][3].to_bits()
    }

    /// Material of global triangle `prim`.
    pub fn triangle_material(&self, prim: u32) -> u32 {
        self.triangles[3 * prim as usize][3].to_bits()
    }

    /// Stored (world or object space) corner shading normals of global
    /// triangle `prim`, if it has them.
    pub fn triangle_normals(&self, prim: u32) -> Option<[Vec3; 3]> {
        let record = self.triangles[3 * prim as usize + 2][3].to_bits() as usize;
        let rows = self
            .normals
            .get(RECORD_ROWS * record.checked_sub(1)?..RECORD_ROWS * record)?;
        let ns = [0, 1, 2].map(|i| Vec3::new(rows[i][0], rows[i][1], rows[i][2]));
        ns.iter().any(|n| *n != Vec3::ZERO).then_some(ns)
    }

    /// Texture coordinates of the corners of global triangle `prim`, if its
    /// mesh has them.
    pub fn triangle_uvs(&self, prim: u32) -> Option<[Vec2; 3]> {
        let record = self.triangles[3 * prim as usize + 2][3].to_bits() as usize;
        let rows = self
            .normals
            .get(RECORD_ROWS * record.checked_sub(1)?..RECORD_ROWS * record)?;
        Some([0, 1, 2].map(|i| Vec2::new(rows[i][3], rows[3][i])))
    }

    /// Stored (world or object space) vertices of global triangle `prim`.
    pub fn triangle_stored(&self, prim: u32) -> [Vec3; 3] {
        let t = &self.triangles[3 * prim as usize..3 * prim as usize + 3];
        [0, 1, 2].map(|i| Vec3::new(t[i][0], t[i][1], t[i][2]))
    }

    /// Keyframes of instance `inst`, as scene keyframes.
    pub fn instance_keys(&self, inst: u32) -> Vec<Keyframe> {
        let i = self.instances[inst as usize];
        self.keyframes[i.key_offset as usize..(i.key_offset + i.key_count) as usize]
            .iter()
            .map(|k| Keyframe {
                time: k.time,
                translation: k.translation.into(),
                rotation: glam::Quat::from_array(k.rotation),
            })
            .collect()
    }

    /// Transform of instance `inst` at scene time `time` (identity if static).
    pub fn instance_transform_at(&self, inst: u32, time: f32) -> Rigid {
        motion::transform_at(&self.instance_keys(inst), time)
    }

    /// World-space vertices of global triangle `prim` at scene time `time`
    /// (the CPU twin of `triangle_world` in scene.wgsl).
    pub fn triangle_world(&self, prim: u32, time: f32) -> [Vec3; 3] {
        let v = self.triangle_stored(prim);
        let inst = self.triangle_instance(prim);
        if self.instances[inst as usize].key_count == 0 {
            return v;
        }
        let rigid = self.instance_transform_at(inst, time);
        v.map(|p| rigid.apply_point(p))
    }
}

impl BuiltScene {
    /// Unit shading normal of global triangle `prim` at barycentrics
    /// `bary` (the weights of v1 and v2) in world space at scene time
    /// `time`; the unit geometric normal where it has none or the
    /// interpolation vanishes (the CPU twin of `triangle_shading_normal`
    /// in scene.wgsl).
    pub fn shading_normal(&self, prim: u32, bary: [f32; 2], time: f32) -> Vec3 {
        let [a, b, c] = self.triangle_world(prim, time);
        let geometric = (b - a).cross(c - a).normalize();
        let Some(ns) = self.triangle_normals(prim) else {
            return geometric;
        };
        let mut n = ns[0] * (1.0 - bary[0] - bary[1]) + ns[1] * bary[0] + ns[2] * bary[1];
        let inst = self.triangle_instance(prim);
        if self.instances[inst as usize].key_count != 0 {
            n = self.instance_transform_at(inst, time).apply_vector(n);
        }
        if n.length_squared() > 1e-12 {
            n.normalize()
        } else {
            geometric
        }
    }
}

/// Splits the scene's triangles into BLAS groups: all static meshes
/// together, then one group per moving mesh. Empty groups are dropped.
fn groups(scene: &Scene) -> Result<Vec<Group>> {
    let mut fixed = Group {
        source: Vec::new(),
        tris: Vec::new(),
        normals: Vec::new(),
        motion: Vec::new(),
    };
    let mut moving = Vec::new();
    for (m, mesh) in scene.meshes.iter().enumerate() {
        if mesh.material as usize >= scene.materials.len() {
            bail!(
                "mesh '{}' uses material {} but the scene has {}",
                mesh.name,
                mesh.material,
                scene.materials.len()
            );
        }
        if let Some(p) = mesh.positions.iter().find(|p| !p.is_finite()) {
            bail!("mesh '{}' has a non-finite vertex {p}", mesh.name);
        }
        if !mesh.normals.is_empty() && mesh.normals.len() != mesh.positions.len() {
            bail!(
                "mesh '{}' has {} shading normals for {} vertices",
                mesh.name,
                mesh.normals.len(),
                mesh.positions.len()
            );
        }
        if let Some(n) = mesh.normals.iter().find(|n| !n.is_finite()) {
            bail!("mesh '{}' has a non-finite shading normal {n}", mesh.name);
        }
        if !mesh.uvs.is_empty() && mesh.uvs.len() != mesh.positions.len() {
            bail!(
                "mesh '{}' has {} texture coordinates for {} vertices",
                mesh.name,
                mesh.uvs.len(),
                mesh.positions.len()
            );
        }
        if let Some(uv) = mesh.uvs.iter().find(|uv| !uv.is_finite()) {
            bail!(
                "mesh '{}' has non-finite texture coordinates {uv}",
                mesh.name
            );
        }
        let mut group = if mesh.motion.is_empty() {
            None
        } else {
            Some(Group {
                source: Vec::new(),
                tris: Vec::new(),
                normals: Vec::new(),
                motion: motion::normalized_keys(&mesh.motion),
            })
        };
        let target = group.as_mut().unwrap_or(&mut fixed);
        for (t, idx) in mesh.indices.iter().enumerate() {
            let vertex = |i: u32| -> Result<Vec3A> {
                match mesh.positions.get(i as usize) {
                    Some(p) => Ok((*p).into()),
                    None => bail!(
                        "mesh '{}' triangle {t} uses vertex {i} but the mesh has {}",
                        mesh.name,
                        mesh.positions.len()
                    ),
                }
            };
            target.tris.push(Triangle {
                v0: vertex(idx[0])?,
                v1: vertex(idx[1])?,
                v2: vertex(idx[2])?,
            });
            target.source.push([m as u32, t as u32]);
            let ns = shading_normals(&mesh.normals, *idx);
            let uvs = (!mesh.uvs.is_empty()).then(|| idx.map(|i| mesh.uvs[i as usize]));
            target.normals.push(match (ns, uvs) {
                (None, None) => None,
                (ns, uvs) => Some((
                    ns.unwrap_or([Vec3::ZERO; 3]),
                    uvs.unwrap_or([Vec2::ZERO; 3]),
                )),
            });
        }
        if let Some(g) = group.filter(|g| !g.tris.is_empty()) {
            moving.push(g);
        }
    }
    let mut out = Vec::new();
    if !fixed.tris.is_empty() {
        out.push(fixed);
    }
    out.extend(moving);
    if out.len() > u32::MAX as usize / 2
        || out.iter().map(|g| g.tris.len()).sum::<usize>() > (u32::MAX / 4) as usize
    {
        bail!("too many triangles for 32-bit indices");
    }
    Ok(out)
}

/// The unit corner normals of the triangle with vertices `idx`, if the mesh
/// has normals and not all three are zero (a zero corner stays zero: the
/// shader falls back to the geometric normal where the interpolation
/// vanishes). The vertex indices were checked by the caller.
fn shading_normals(normals: &[Vec3], idx: [u32; 3]) -> Option<[Vec3; 3]> {
    let ns = idx.map(|i| normals.get(i as usize).map(|n| n.normalize_or_zero()));
    let ns = [ns[0]?, ns[1]?, ns[2]?];
    ns.iter().any(|n| *n != Vec3::ZERO).then_some(ns)
}

/// Levels of internal nodes on the longest root-to-leaf path.
fn depth(bvh: &CwBvh) -> u32 {
    fn go(bvh: &CwBvh, node: usize) -> u32 {
        let n = &bvh.nodes[node];
        1 + (0..8)
            .filter(|&c| !n.is_child_empty(c) && !n.is_leaf(c))
            .map(|c| go(bvh, n.child_node_index(c) as usize))
            .max()
            .unwrap_or(0)
    }
    if bvh.nodes.is_empty() {
        0
    } else {
        go(bvh, 0)
    }
}
