//! The whole file: film, camera, materials, then shapes, lights and
//! light sets in order, the integrand and the MDAS table.

use super::ctx::{Ctx, Result};
use super::lights::{LightOut, Surfaces};
use super::raw::*;
use super::shapes::ShapeOutputs;
use super::values::*;
use super::*;
use crate::film::Film;
use crate::scene::shapes::{self};
use crate::scene::{Camera, Checker, Material, Mesh, Scene};
use glam::Vec3;
use std::collections::HashMap;

impl Ctx<'_> {
    pub(super) fn scene_file(&self, raw: RawScene) -> Result<SceneFile> {
        let background = match &raw.background {
            Some(b) => self.rgb(b, "background")?,
            None => Vec3::ZERO,
        };
        let film = self.film(raw.film.get_ref())?;
        let camera = self.camera(raw.camera.get_ref())?;

        let mut materials = Vec::with_capacity(raw.material.len());
        let mut by_name: HashMap<&str, u32> = HashMap::new();
        for m in &raw.material {
            let m = m.get_ref();
            let name = m.name.get_ref().as_str();
            if by_name.insert(name, materials.len() as u32).is_some() {
                return Err(
                    self.error(m.name.span(), format!("material '{name}' is defined twice"))
                );
            }
            materials.push(self.material(m)?);
        }

        let mut meshes = Vec::with_capacity(raw.shape.len());
        let mut out = ShapeOutputs {
            materials,
            inputs: Vec::new(),
            warnings: Vec::new(),
        };
        for (n, s) in raw.shape.iter().enumerate() {
            meshes.extend(self.shape(s, n, &by_name, &mut out)?);
        }
        let ShapeOutputs {
            mut materials,
            inputs,
            mut warnings,
        } = out;

        let mut lights = Vec::new();
        for (n, l) in raw.light.iter().enumerate() {
            match self.light(l)? {
                LightOut::Delta(light) => lights.push(light),
                LightOut::Area { corners, radiance } => {
                    let name = format!("light{n}");
                    let mesh = shapes::quad(corners);
                    meshes.push(Mesh {
                        name: name.clone(),
                        positions: mesh.positions,
                        indices: mesh.indices,
                        normals: Vec::new(),
                        uvs: Vec::new(),
                        material: materials.len() as u32,
                        motion: Vec::new(),
                    });
                    materials.push(Material {
                        name,
                        albedo: Vec3::ZERO,
                        emission: radiance,
                        checker: None,
                        one_sided: false,
                        uv_checker: None,
                    });
                }
            }
        }

        let mut point_light_sets = Vec::with_capacity(raw.light_set.len());
        let mut surfaces: Option<Surfaces> = None;
        let mut set_lights = 0u64;
        for set in &raw.light_set {
            let r = set.get_ref();
            let t = self.check_type("light_set", &r.kind, &r.type_keys(), &LIGHT_SET_TYPES)?;
            if LIGHT_SET_TYPES[t].0 == "surface" && surfaces.is_none() {
                surfaces = Some(Surfaces::new(&meshes, &materials));
            }
            let generated = self.light_set(r, t, surfaces.as_ref(), set_lights)?;
            set_lights += generated.lights.len() as u64;
            point_light_sets.push(generated);
        }

        let (integrand, (visibility, voxel)) = match &raw.integrand {
            None => (
                IntegrandSpec::AreaLight,
                (Visibility::Bvh, VoxelParams::default()),
            ),
            Some(i) => {
                let emissive = meshes
                    .iter()
                    .any(|m| materials[m.material as usize].emission.max_element() > 0.0);
                (
                    self.integrand(i.get_ref(), emissive)?,
                    self.visibility(i.get_ref())?,
                )
            }
        };
        let mdas = match &raw.mdas {
            Some(m) => self.mdas(m, film)?,
            None => MdasParams::for_film(film),
        };
        let mut scene = Scene {
            film,
            camera,
            background,
            materials,
            meshes,
            lights,
            point_light_sets,
        };
        warnings.extend(scene.orient_to_normals());
        Ok(SceneFile {
            scene,
            integrand,
            visibility,
            voxel,
            mdas,
            inputs,
            warnings,
        })
    }

    /// The OBJ files of the `mesh` shapes (already loaded, so they exist).
    pub(super) fn film(&self, f: &RawFilm) -> Result<Film> {
        let side = |v: &S<i64>, key: &str| {
            let x = *v.get_ref();
            if x <= 0 {
                Err(self.error(v.span(), format!("film {key} must be positive, found {x}")))
            } else if x > MAX_FILM_SIDE {
                Err(self.error(
                    v.span(),
                    format!("film {key} {x} is absurdly large (at most {MAX_FILM_SIDE})"),
                ))
            } else {
                Ok(x)
            }
        };
        let (w, h) = (side(&f.width, "width")?, side(&f.height, "height")?);
        if w * h > MAX_FILM_PIXELS {
            return Err(self.error(
                f.height.span(),
                format!(
                    "film {w}×{h} = {} pixels is absurdly large (at most 2^26 = {MAX_FILM_PIXELS})",
                    w * h
                ),
            ));
        }
        Ok(Film {
            width: w as u32,
            height: h as u32,
        })
    }

    pub(super) fn camera(&self, c: &RawCamera) -> Result<Camera> {
        let position = self.bounded3(&c.position, "camera position", super::MAX_COORDINATE)?;
        let look_at = self.bounded3(&c.look_at, "camera look_at", super::MAX_COORDINATE)?;
        let Some(forward) = (look_at - position).try_normalize() else {
            return Err(self.error(c.look_at.span(), "camera look_at must differ from position"));
        };
        let up = self.nonzero(&c.up, "camera up")?;
        if forward.cross(up).length() < 1e-4 {
            return Err(self.error(
                c.up.span(),
                "camera up must not be parallel to the view direction",
            ));
        }
        // Checked as the f32 the GPU uses: 179.99999999 is 180 in f32.
        let fov_y = c.fov_y.get_ref().0;
        if !crate::scene::fov_y_is_valid(fov_y) {
            let written = self.text.get(c.fov_y.span()).unwrap_or("").trim();
            let found = match written.parse::<f64>() {
                Ok(v) if v != fov_y as f64 => {
                    format!("{written}, which is {fov_y:?} as the f32 the GPU uses")
                }
                _ => fov_y.to_string(),
            };
            return Err(self.error(
                c.fov_y.span(),
                format!("fov_y must be in (0, 180) degrees, found {found}"),
            ));
        }
        let aperture_radius = match &c.aperture_radius {
            Some(a) => {
                self.non_negative(a, "aperture_radius")?;
                self.bounded(a, "aperture_radius", super::MAX_COORDINATE)?
            }
            None => 0.0,
        };
        let focus_distance = match &c.focus_distance {
            // Bounded like a coordinate: 10^20 rendered black (issue 54
            // item 5); lens rays aim at a point that far along the view.
            Some(d) => self
                .bounded(d, "focus_distance", super::MAX_COORDINATE)
                .and_then(|_| self.positive(d, "focus_distance"))?,
            None => (look_at - position).length(),
        };
        let time = |t: &Option<S<Num>>, key: &str, default: f32| {
            t.as_ref()
                .map_or(Ok(default), |t| self.bounded(t, key, super::MAX_TIME))
        };
        let shutter_open = time(&c.shutter_open, "shutter_open", 0.0)?;
        let shutter_close = time(&c.shutter_close, "shutter_close", 1.0)?;
        if shutter_close <= shutter_open {
            let span = c
                .shutter_close
                .as_ref()
                .or(c.shutter_open.as_ref())
                .map(|t| t.span());
            return Err(self.error(
                span.unwrap_or(0..0),
                format!("shutter_close ({shutter_close}) must be greater than shutter_open ({shutter_open})"),
            ));
        }
        Ok(Camera {
            position,
            look_at,
            up: c.up.get_ref().0,
            fov_y,
            aperture_radius,
            focus_distance,
            shutter_open,
            shutter_close,
        })
    }

    pub(super) fn material(&self, m: &RawMaterial) -> Result<Material> {
        let checker = match &m.checker {
            Some(c) => {
                let c = c.get_ref();
                Some(Checker {
                    albedo2: self.albedo(&c.albedo2, "checker albedo2")?,
                    scale: self.positive(&c.scale, "checker scale")?,
                })
            }
            None => None,
        };
        Ok(Material {
            name: m.name.get_ref().clone(),
            albedo: self.albedo(&m.albedo, "albedo")?,
            emission: match &m.emission {
                Some(e) => self.rgb(e, "emission")?,
                None => Vec3::ZERO,
            },
            checker,
            one_sided: false,
            uv_checker: None,
        })
    }
}
