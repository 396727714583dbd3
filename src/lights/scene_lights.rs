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
use crate::scene::motion::{normalized_keys, transform_at};
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
    let counts = light_counts(scene);
    let mut sizes = vec![counts.points];
    sizes.extend(scene.point_light_sets.iter().map(|s| s.len()));
    sizes.extend(
        scene
            .meshes
            .iter()
            .filter(|m| is_emissive(scene, m))
            .map(|m| m.indices.len()),
    );
    let mut start = 0u32;
    let mut groups = Vec::new();
    for size in sizes {
        let end = start + size as u32;
        if end > start {
            groups.push(start..end);
        }
        start = end;
    }
    groups
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
    for light in &scene.lights {
        if let Light::Point {
            position,
            intensity,
        } = *light
        {
            out.push(LightPrim::point(position, intensity));
        }
    }
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
        let radiance = scene.materials[mesh.material as usize].emission;
        let rigid =
            (!mesh.motion.is_empty()).then(|| transform_at(&normalized_keys(&mesh.motion), time));
        out.extend(mesh.indices.iter().map(|idx| {
            let [a, b, c] = idx.map(|i| {
                let p = mesh.positions[i as usize];
                rigid.map_or(p, |r| r.apply_point(p))
            });
            LightPrim::triangle(a, b, c, radiance)
        }));
    }
    out
}
