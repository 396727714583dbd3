//! The many-light list of one frame: every light of a [`Scene`] as a
//! [`LightPrim`] at frame time t.
//!
//! # Order (light id = index, stable)
//!
//! 1. `[[light]] type = "point"` lights, in file order
//!    (`Scene::lights`' `Light::Point` entries, in their order);
//! 2. the lights of every `[[light_set]]` (`Scene::point_light_sets`), set
//!    by set in file order, each set's lights in generation order, at their
//!    position at time t ([`PointLightSet::position`]);
//! 3. every triangle of every emissive mesh (material emission > 0 in some
//!    channel), meshes in `Scene::meshes` order (the `[[shape]]`s, then the
//!    `[[light]] type = "quad"` meshes), triangles in index order, placed
//!    at time t by the mesh's keyframes exactly as the BVH and the GPU place
//!    them ([`crate::scene::motion::transform_at`] on
//!    [`crate::scene::motion::normalized_keys`]); radiance = the
//!    material's emission. Zero-area triangles of an emissive mesh are kept
//!    (zero intensity) so the ids do not depend on the geometry.
//!
//! Directional lights are not part of the many-light set: they are at
//! infinity, have no position for a tree to bound, and the integrand adds
//! them separately if it supports them. [`light_counts`] gives the size of
//! each group without building the list.
//!
//! [`PointLightSet::position`]: crate::scene::PointLightSet::position

use super::LightPrim;
use crate::scene::motion::{normalized_keys, transform_at, Rigid};
use crate::scene::{Light, Mesh, Scene};

/// The number of lights in each group of [`light_prims`]' order.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LightCounts {
    /// `[[light]] type = "point"` lights: ids `0..points`.
    pub points: usize,
    /// `[[light_set]]` lights: ids `points..points + set_points`.
    pub set_points: usize,
    /// Emissive triangles: the last `triangles` ids.
    pub triangles: usize,
}

impl LightCounts {
    pub fn total(&self) -> usize {
        self.points + self.set_points + self.triangles
    }

    /// Id of the first emissive triangle.
    pub fn first_triangle(&self) -> usize {
        self.points + self.set_points
    }
}

/// Whether `mesh` emits (its material has emission > 0 in some channel).
pub fn is_emissive(scene: &Scene, mesh: &Mesh) -> bool {
    scene
        .materials
        .get(mesh.material as usize)
        .is_some_and(|m| m.emission.max_element() > 0.0)
}

pub fn light_counts(scene: &Scene) -> LightCounts {
    LightCounts {
        points: scene
            .lights
            .iter()
            .filter(|l| matches!(l, Light::Point { .. }))
            .count(),
        set_points: scene.point_light_sets.iter().map(|s| s.len()).sum(),
        triangles: scene
            .meshes
            .iter()
            .filter(|m| is_emissive(scene, m))
            .map(|m| m.indices.len())
            .sum(),
    }
}

/// The groups of [`light_prims`]' ids that the two-level tree (`tree2`,
/// [`super::two_level`]) builds one bottom-level tree each over, in id
/// order: the `[[light]]` points together, each `[[light_set]]`, each
/// emissive mesh. Empty groups are left out.
pub fn light_groups(scene: &Scene) -> Vec<std::ops::Range<u32>> {
    group_ranges(scene).into_iter().flatten().collect()
}

/// The id range of every group of [`light_groups`] in order, `None` for
/// an empty one.
fn group_ranges(scene: &Scene) -> Vec<Option<std::ops::Range<u32>>> {
    let mut sizes = vec![light_counts(scene).points];
    sizes.extend(scene.point_light_sets.iter().map(|s| s.len()));
    sizes.extend(
        scene
            .meshes
            .iter()
            .filter(|m| is_emissive(scene, m))
            .map(|m| m.indices.len()),
    );
    let mut start = 0u32;
    sizes
        .into_iter()
        .map(|size| {
            let range = start..start + size as u32;
            start = range.end;
            (!range.is_empty()).then_some(range)
        })
        .collect()
}

/// [`light_groups`] with the lights of each group in object space where
/// their arrangement never changes — the points; a light set that does
/// not orbit; an emissive mesh's triangles before its rigid motion (every
/// frame moves them all by one transform) — and `None` for a set that
/// orbits (each light on its own circle).
fn group_lights(scene: &Scene) -> Vec<(std::ops::Range<u32>, Option<Vec<LightPrim>>)> {
    let mut lists: Vec<Option<Vec<LightPrim>>> = vec![Some(light_prims_points(scene))];
    lists.extend(scene.point_light_sets.iter().map(|set| {
        (set.orbit_radius == 0.0).then(|| {
            set.lights
                .iter()
                .map(|l| LightPrim::point(l.base, l.intensity))
                .collect()
        })
    }));
    lists.extend(
        scene
            .meshes
            .iter()
            .filter(|m| is_emissive(scene, m))
            .map(|mesh| Some(mesh_triangles(scene, mesh, None))),
    );
    group_ranges(scene)
        .into_iter()
        .zip(lists)
        .filter_map(|(range, lights)| Some((range?, lights)))
        .collect()
}

/// The two-level tree's bottom levels of `scene` for a sequence of frames
/// ([`super::two_level::BottomLevels`]): every group of [`light_groups`],
/// sorted once in object space unless it is a light set that orbits.
pub fn bottom_levels(scene: &Scene) -> super::two_level::BottomLevels {
    let (groups, lights): (Vec<_>, Vec<_>) = group_lights(scene).into_iter().unzip();
    let object: Vec<Option<&[LightPrim]>> = lights.iter().map(|l| l.as_deref()).collect();
    super::two_level::BottomLevels::new(groups, &object)
}

/// Total number of lights of [`light_prims`] (at any time).
pub fn light_count(scene: &Scene) -> usize {
    light_counts(scene).total()
}

/// Every light of `scene` at scene time `time`, in the order of the module
/// docs. Panics if an emissive mesh indexes a vertex it does not have (a
/// loaded scene never does).
pub fn light_prims(scene: &Scene, time: f32) -> Vec<LightPrim> {
    let mut out = Vec::with_capacity(light_count(scene));
    out.extend(light_prims_points(scene));
    for set in &scene.point_light_sets {
        out.extend(
            set.lights
                .iter()
                .map(|l| LightPrim::point(set.position(l, time), l.intensity)),
        );
    }
    for mesh in &scene.meshes {
        if !is_emissive(scene, mesh) {
            continue;
        }
        let rigid =
            (!mesh.motion.is_empty()).then(|| transform_at(&normalized_keys(&mesh.motion), time));
        out.extend(mesh_triangles(scene, mesh, rigid));
    }
    out
}

/// The `[[light]] type = "point"` lights, in file order.
fn light_prims_points(scene: &Scene) -> Vec<LightPrim> {
    scene
        .lights
        .iter()
        .filter_map(|light| match *light {
            Light::Point {
                position,
                intensity,
            } => Some(LightPrim::point(position, intensity)),
            _ => None,
        })
        .collect()
}

/// The triangles of emissive `mesh`, its vertices moved by `rigid` (none:
/// in object space).
fn mesh_triangles(scene: &Scene, mesh: &Mesh, rigid: Option<Rigid>) -> Vec<LightPrim> {
    let radiance = scene.materials[mesh.material as usize].emission;
    mesh.indices
        .iter()
        .map(|idx| {
            let [a, b, c] = idx.map(|i| {
                let p = mesh.positions[i as usize];
                rigid.map_or(p, |r| r.apply_point(p))
            });
            LightPrim::triangle(a, b, c, radiance)
        })
        .collect()
}
