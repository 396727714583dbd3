//! The CPU oracle of voxel visibility: the box, triangle and segment
//! tests, voxelization, the bit layout's indices and the occlusion query,
//! each mirroring its WGSL (named in its doc) so that tests compare the
//! two.

use super::*;

/// Whether the world segment p + t·d, t ∈ [0, t_max], meets the box
/// [lo, hi] (slabs; a zero component of d needs p inside that slab).
/// `voxel_segment_meets_box` in WGSL.
pub fn segment_meets_box(p: Vec3, d: Vec3, t_max: f32, lo: [f32; 3], hi: [f32; 3]) -> bool {
    let (mut t0, mut t1) = (0.0f32, t_max);
    for k in 0..3 {
        if d[k] == 0.0 {
            if p[k] < lo[k] || p[k] > hi[k] {
                return false;
            }
        } else {
            let ta = (lo[k] - p[k]) / d[k];
            let tb = (hi[k] - p[k]) / d[k];
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
    }
    t0 <= t1
}

/// The voxel object of global triangle `prim`.
pub fn object_of(built: &BuiltScene, prim: u32) -> usize {
    if built.instances.is_empty() {
        0
    } else {
        built.triangle_instance(prim) as usize
    }
}

// Explicit scalar arithmetic, operation for operation as in voxel.wgsl,
// so that the CPU and GPU builds agree bit for bit.
pub(super) fn dot3(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(super) fn cross3(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(super) fn sub3(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Object-space point `p` in the voxel coordinates of grid `f`.
pub fn to_voxel(o: &VoxelObject, f: &VoxelFrame, p: [f32; 3]) -> [f32; 3] {
    let rel = sub3(p, o.centre);
    let half = (o.res / 2) as f32;
    let ax = |v: [f32; 4]| dot3(rel, [v[0], v[1], v[2]]) + half;
    [ax(f.a), ax(f.b), ax(f.u)]
}

/// Object-space vector `d` in the voxel coordinates of grid `f`.
pub fn to_voxel_vector(f: &VoxelFrame, d: [f32; 3]) -> [f32; 3] {
    let ax = |v: [f32; 4]| dot3(d, [v[0], v[1], v[2]]);
    [ax(f.a), ax(f.b), ax(f.u)]
}

/// Whether the triangle (voxel coordinates, relative to the box centre)
/// meets the box [−½, ½]³: no separating axis among the 3 box normals, the
/// triangle normal and the 9 edge cross products.
pub fn triangle_meets_box(v: [[f32; 3]; 3]) -> bool {
    let e = [sub3(v[1], v[0]), sub3(v[2], v[1]), sub3(v[0], v[2])];
    let separated = |axis: [f32; 3]| {
        let p0 = dot3(axis, v[0]);
        let p1 = dot3(axis, v[1]);
        let p2 = dot3(axis, v[2]);
        let r = 0.5 * (axis[0].abs() + axis[1].abs() + axis[2].abs());
        p0.min(p1).min(p2) > r || p0.max(p1).max(p2) < -r
    };
    let units = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    if units.iter().any(|&u| separated(u)) {
        return false;
    }
    if separated(cross3(e[0], e[1])) {
        return false;
    }
    for u in units {
        for edge in e {
            if separated(cross3(u, edge)) {
                return false;
            }
        }
    }
    true
}

/// The voxels one triangle (voxel coordinates `q`) sets in a grid of `res`
/// per side, restricted to columns `cols` (per loop axis, inclusive; the
/// whole footprint when `None`), passed to `set(x, y, z)`. The loop axes
/// are the two axes other than the normal's dominant one. The build
/// kernel runs the same loop over one tile of columns per work item.
pub fn voxelize_triangle(
    q: [[f32; 3]; 3],
    res: u32,
    cols: Option<[[i32; 2]; 2]>,
    mut set: impl FnMut(u32, u32, u32),
) {
    let n = cross3(sub3(q[1], q[0]), sub3(q[2], q[0]));
    let (ax, ay, az) = (n[0].abs(), n[1].abs(), n[2].abs());
    let k = if ax >= ay && ax >= az {
        0
    } else if ay >= az {
        1
    } else {
        2
    };
    let (i, j) = match k {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let nk = n[k];
    if nk == 0.0 || !nk.is_finite() {
        return;
    }
    let last = res as i32 - 1;
    let bound = |axis: usize| {
        let lo = q[0][axis].min(q[1][axis]).min(q[2][axis]).floor();
        let hi = q[0][axis].max(q[1][axis]).max(q[2][axis]).floor();
        // Clamp in f32 first: a far-away vertex must not overflow i32.
        let lo = lo.clamp(-1.0, res as f32) as i32;
        let hi = hi.clamp(-1.0, res as f32) as i32;
        [lo.max(0), hi.min(last)]
    };
    let (bi, bj, bk) = (bound(i), bound(j), bound(k));
    let [ri, rj] = match cols {
        Some([ci, cj]) => [
            [ci[0].max(bi[0]), ci[1].min(bi[1])],
            [cj[0].max(bj[0]), cj[1].min(bj[1])],
        ],
        None => [bi, bj],
    };
    let si = n[i] / nk;
    let sj = n[j] / nk;
    for ci in ri[0]..=ri[1] {
        for cj in rj[0]..=rj[1] {
            // The plane's k over the column's square is base − si·[0, 1] − sj·[0, 1].
            let base = q[0][k] - si * (ci as f32 - q[0][i]) - sj * (cj as f32 - q[0][j]);
            let kmin = base - si.max(0.0) - sj.max(0.0);
            let kmax = base - si.min(0.0) - sj.min(0.0);
            let z0 = ((kmin - 1e-3).floor().clamp(-1.0, res as f32) as i32).max(bk[0]);
            let z1 = ((kmax + 1e-3).floor().clamp(-1.0, res as f32) as i32).min(bk[1]);
            for ck in z0..=z1 {
                let mut cell = [0i32; 3];
                cell[i] = ci;
                cell[j] = cj;
                cell[k] = ck;
                let centre = cell.map(|c| c as f32 + 0.5);
                let v = q.map(|p| sub3(p, centre));
                if triangle_meets_box(v) {
                    set(cell[0] as u32, cell[1] as u32, cell[2] as u32);
                }
            }
        }
    }
}

/// Word index of voxel (x, y, z) of direction `v` of object `o`.
pub fn word_index(o: &VoxelObject, v: u32, x: u32, y: u32, z: u32) -> u64 {
    let r = o.res as u64;
    o.base as u64 + ((v as u64 * r + y as u64) * r + x as u64) * o.words as u64 + (z / 32) as u64
}

/// The CPU oracle of the whole build: the bits of every object and
/// direction (use on small scenes; the GPU build is [`super::gpu_voxel`]).
pub fn build_cpu(built: &BuiltScene, layout: &VoxelLayout) -> Vec<u32> {
    let mut bits = vec![0u32; layout.words as usize];
    for prim in 0..built.triangle_count() {
        let o = &layout.objects[object_of(built, prim)];
        let tri = built.triangle_stored(prim).map(|p| p.to_array());
        for v in 0..layout.params.direction_count() {
            let q = tri.map(|p| to_voxel(o, layout.frame(o, v), p));
            voxelize_triangle(q, o.res, None, |x, y, z| {
                bits[word_index(o, v, x, y, z) as usize] |= 1 << (z % 32);
            });
        }
    }
    bits
}

/// The build's work list: one item per (triangle, tile of
/// [`TILE`]×[`TILE`] columns) as [prim, tile | tiles_per_side << 16]. A
/// triangle of bounding radius ρ spans at most 2ρ·s + 2 columns per axis
/// in any direction, s the object's largest scale, and at most R; tiles
/// are counted from that bound (+1 for rounding), so the items of a
/// triangle cover its footprint in every direction.
pub fn work_items(built: &BuiltScene, layout: &VoxelLayout) -> Vec<[u32; 2]> {
    let mut items = Vec::with_capacity(built.triangle_count() as usize);
    for prim in 0..built.triangle_count() {
        let object = object_of(built, prim);
        let o = &layout.objects[object];
        let [a, b, c] = built.triangle_stored(prim);
        let centroid = (a + b + c) / 3.0;
        let rho = a
            .distance(centroid)
            .max(b.distance(centroid))
            .max(c.distance(centroid));
        let span = (2.0 * rho as f64 * layout.max_scale[object] + 3.0).ceil();
        if !span.is_finite() {
            continue;
        }
        let tiles = ((span / TILE as f64).ceil() as u32).clamp(1, o.res.div_ceil(TILE));
        for t in 0..tiles * tiles {
            items.push([prim, t | (tiles << 16)]);
        }
    }
    items
}

/// The direction index (i·n + j) of the voxelization whose rows best match
/// `d` (any length > 0): d flipped to y ≥ 0, θ = acos z, φ = atan2(y, x),
/// each rounded to the nearest step, φ = 180° wrapping to 0° with θ
/// mirrored, θ = 180° to θ = 0° (module docs). `voxel_direction` in WGSL.
pub fn direction_index(n: u32, d: Vec3) -> u32 {
    let mut d = d.normalize();
    if d.y < 0.0 {
        d = -d;
    }
    let k = n as f32 / std::f32::consts::PI;
    let theta = d.z.clamp(-1.0, 1.0).acos();
    let phi = d.y.max(0.0).atan2(d.x);
    let mut i = ((theta * k + 0.5).floor() as u32).min(n);
    let mut j = ((phi * k + 0.5).floor() as u32).min(n);
    if j == n {
        j = 0;
        i = n - i;
    }
    if i == n {
        i = 0;
    }
    i * n + j
}

/// A shadow segment origin + t·dir, t ∈ [0, t_max], at scene time
/// `time`, starting on a surface of normal `n_origin` and ending on one of
/// normal `n_end` (zero vectors where it does not: a point light, a
/// direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub origin: Vec3,
    pub dir: Vec3,
    pub t_max: f32,
    pub time: f32,
    pub n_origin: Vec3,
    pub n_end: Vec3,
}

/// Whether the bits of `o` occlude the object-space segment `s` (the query
/// of the module docs; `voxel_object_hit` in WGSL).
pub fn object_hit(bits: &[u32], layout: &VoxelLayout, o: &VoxelObject, s: &Segment) -> bool {
    let (p, d, t_max) = (s.origin, s.dir, s.t_max);
    let v = direction_index(layout.params.directions, d);
    let f = layout.frame(o, v);
    let qp = to_voxel(o, f, p.to_array());
    let qd = to_voxel_vector(f, d.to_array());
    let res = o.res as f32;
    // Clip to the grid [0, R]³, slab by slab.
    let (mut t0, mut t1) = (0.0f32, t_max);
    for k in 0..3 {
        if qd[k] == 0.0 {
            if qp[k] < 0.0 || qp[k] > res {
                return false;
            }
        } else {
            let ta = (0.0 - qp[k]) / qd[k];
            let tb = (res - qp[k]) / qd[k];
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
    }
    // (Also false for NaN.)
    if t0.partial_cmp(&t1) != Some(std::cmp::Ordering::Less) {
        return false;
    }
    let at = |t: f32| [0, 1, 2].map(|k| qp[k] + qd[k] * t);
    let (x0, xm, x1) = (at(t0), at(0.5 * (t0 + t1)), at(t1));
    let (x, y) = (xm[0].floor(), xm[1].floor());
    if x < 0.0 || y < 0.0 || x >= res || y >= res {
        return false;
    }
    let extra = 1 + layout.params.skip as i32;
    // Voxels excluded at a true endpoint `near`: its own, those its
    // surface's tangent plane touches along the row, `skip` more.
    let excluded = |near: [f32; 3], is_end: bool, n: Vec3| {
        if is_end {
            endpoint_skip(o, f, [x, y], near, xm, n) + extra
        } else {
            0
        }
    };
    let (s0, s1) = (
        excluded(x0, t0 == 0.0, s.n_origin),
        excluded(x1, t1 == t_max, s.n_end),
    );
    let z0 = x0[2].floor().clamp(-1.0, res) as i32;
    let z1 = x1[2].floor().clamp(-1.0, res) as i32;
    let (lo, hi) = if x0[2] <= x1[2] {
        (z0 + s0, z1 - s1)
    } else {
        (z1 + s1, z0 - s0)
    };
    let (lo, hi) = (lo.max(0), hi.min(o.res as i32 - 1));
    if lo > hi {
        return false;
    }
    let row = word_index(o, v, x as u32, y as u32, 0) as usize;
    let (lo, hi) = (lo as u32, hi as u32);
    (lo / 32..=hi / 32).any(|w| {
        let wlo = lo.max(32 * w) - 32 * w;
        let whi = hi.min(32 * w + 31) - 32 * w;
        let mask = (u32::MAX >> (31 - (whi - wlo))) << wlo;
        bits[row + w as usize] & mask != 0
    })
}

/// The voxels after a true endpoint's own that its surface (object-space
/// normal `n`; zero: none) still touches along row `row` towards `far`:
/// the tangent plane through `near` meets the row's k-th voxel from
/// `near`'s (centre c_k) while |n_v·(c_k − near)| ≤ ½(|n_v,x| + |n_v,y| +
/// |n_v,z|), n_v the normal in voxel space (x·n/|x|² for each scaled axis
/// x); that is linear in k, and this is the last such k (0 if none).
pub fn endpoint_skip(
    o: &VoxelObject,
    f: &VoxelFrame,
    row: [f32; 2],
    near: [f32; 3],
    far: [f32; 3],
    n: Vec3,
) -> i32 {
    if n == Vec3::ZERO {
        return 0;
    }
    let n = n.to_array();
    let scaled = |x: [f32; 4]| {
        let x = [x[0], x[1], x[2]];
        dot3(x, n) / dot3(x, x)
    };
    let nv = [scaled(f.a), scaled(f.b), scaled(f.u)];
    let r = 0.5 * (nv[0].abs() + nv[1].abs() + nv[2].abs());
    let c0 = [row[0] + 0.5, row[1] + 0.5, near[2].floor() + 0.5];
    let f0 = nv[0] * (c0[0] - near[0]) + nv[1] * (c0[1] - near[1]) + nv[2] * (c0[2] - near[2]);
    let slope = if far[2] >= near[2] { nv[2] } else { -nv[2] };
    let res = o.res as f32;
    let touching = if slope != 0.0 {
        let q = (r - slope.signum() * f0) / slope.abs();
        // (NaN, from a NaN normal, counts as 0.)
        if q >= 0.0 {
            q.floor().min(res)
        } else {
            0.0
        }
    } else if f0.abs() <= r {
        res
    } else {
        0.0
    };
    touching as i32
}

/// Whether the world-space segment `s` is occluded: any object hit,
/// moving instances queried in their own frame at `s.time`
/// (`voxel_occluded` in WGSL).
pub fn occluded(built: &BuiltScene, layout: &VoxelLayout, bits: &[u32], s: &Segment) -> bool {
    layout.objects.iter().enumerate().any(|(i, o)| {
        if !segment_meets_box(s.origin, s.dir, s.t_max, o.world_min, o.world_max) {
            return false;
        }
        let moving = built
            .instances
            .get(i)
            .is_some_and(|inst| inst.key_count > 0);
        let local = if moving {
            let x = built.instance_transform_at(i as u32, s.time);
            Segment {
                origin: x.inverse_point(s.origin),
                dir: x.inverse_vector(s.dir),
                n_origin: x.inverse_vector(s.n_origin),
                n_end: x.inverse_vector(s.n_end),
                ..*s
            }
        } else {
            *s
        };
        object_hit(bits, layout, o, &local)
    })
}
