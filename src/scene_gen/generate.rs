//! The generator's core: its state, the order of a scene's parts, the
//! palette and materials, the objects and where they stand, and the camera.

use super::*;

impl Gen {
    pub(super) fn new(kind: GenIntegrand, seed: u64, opts: GenOptions) -> Gen {
        Gen {
            kind,
            seed,
            opts,
            rng: Rng::new(kind, seed),
            u: 1.0,
            region: 1.0,
            ground_y: 0.0,
            ground_top: 0.0,
            materials: Vec::new(),
            palette: Vec::new(),
            shapes: Vec::new(),
            objects: Vec::new(),
            lights: String::new(),
            light_sets: String::new(),
            integrand: String::new(),
            background: V3::ZERO,
            camera: None,
            room: None,
            aperture: None,
            shutter: None,
            notes: Vec::new(),
            emissive_surfaces: false,
        }
    }
    pub(super) fn aspect(&self) -> f64 {
        f64::from(self.opts.width.max(1)) / f64::from(self.opts.height.max(1))
    }
    pub(super) fn cam(&self) -> &Camera {
        self.camera.as_ref().expect("camera placed")
    }
    pub(super) fn generate(mut self) -> String {
        self.u = self.rng.log_range(0.5, 20.0);
        let room = self.kind == GenIntegrand::Path && self.rng.chance(0.35);
        self.make_palette();
        let ground_material = self.ground_material();
        let count = self.rng.log_int(2, 40);
        // The ground's shape is chosen before the objects so that they stand
        // on its highest level.
        let heightfield_ground = !room && self.rng.chance(0.35);
        let ground_amplitude = if heightfield_ground {
            self.u * self.rng.range(0.02, 0.12)
        } else {
            0.0
        };
        self.ground_top = self.ground_y + ground_amplitude;
        self.make_objects(count);
        self.make_background();
        if room {
            self.make_room();
        } else {
            self.place_camera();
            self.make_ground(&ground_material, heightfield_ground, ground_amplitude);
        }
        match self.kind {
            GenIntegrand::AreaLight => self.area_light_lights(),
            GenIntegrand::DepthOfField => {
                self.thin_lens();
                self.delta_lights();
                if self.rng.chance(0.35) {
                    self.bokeh_spheres();
                }
            }
            GenIntegrand::MotionBlur => {
                self.motion();
                self.delta_lights();
            }
            GenIntegrand::Path => self.path_lights(room),
            GenIntegrand::AmbientOcclusion => self.occlusion(),
            GenIntegrand::ManyLight => self.many_lights(),
        }
        self.write()
    }
    // --- materials --------------------------------------------------------

    pub(super) fn make_palette(&mut self) {
        let plain = self.rng.int(2, 5);
        let checkered = self.rng.int(1, 3);
        for i in 0..plain {
            let a = albedo(&mut self.rng);
            self.add_material(format!("plain{i}"), a, None, None);
        }
        for i in 0..checkered {
            let a = albedo(&mut self.rng);
            let b = albedo(&mut self.rng);
            let scale = self.u * self.rng.log_range(0.05, 0.6);
            self.add_material(format!("checker{i}"), a, None, Some((b, scale)));
        }
    }
    pub(super) fn add_material(
        &mut self,
        name: String,
        albedo: V3,
        emission: Option<V3>,
        checker: Option<(V3, f64)>,
    ) {
        if emission.is_none() {
            self.palette.push(name.clone());
        }
        self.materials.push(Material {
            name,
            albedo,
            emission,
            checker,
        });
    }
    /// A new emissive material of radiance `radiance`; its name.
    pub(super) fn emitter(&mut self, radiance: V3) -> String {
        let name = format!(
            "emit{}",
            self.materials
                .iter()
                .filter(|m| m.emission.is_some())
                .count()
        );
        let albedo = V3::splat(self.rng.range(0.0, 0.5));
        self.materials.push(Material {
            name: name.clone(),
            albedo,
            emission: Some(radiance),
            checker: None,
        });
        self.emissive_surfaces = true;
        name
    }
    /// The ground's material; a checkered ground also sets `ground_y` to
    /// the middle of a checker cell, so the plane is not on a cell
    /// boundary (where rounding would flip cells pixel by pixel).
    pub(super) fn ground_material(&mut self) -> String {
        let a = albedo(&mut self.rng);
        if self.rng.chance(0.6) {
            let mut b = albedo(&mut self.rng);
            if (a - b).length() < 0.2 {
                b = V3::splat(if a.max_element() > 0.45 { 0.08 } else { 0.75 });
            }
            let scale = self.u * self.rng.log_range(0.3, 2.0);
            self.ground_y = scale * self.rng.range(0.3, 0.7);
            self.add_material("ground".into(), a, None, Some((b, scale)));
        } else {
            self.add_material("ground".into(), a, None, None);
        }
        // Objects do not use the ground's material.
        self.palette.retain(|n| n != "ground");
        "ground".into()
    }
    // --- objects ----------------------------------------------------------

    pub(super) fn make_objects(&mut self, count: u32) {
        let thin_wanted = if self.rng.chance(0.75) {
            self.rng.int(1, 4).min(count)
        } else {
            0
        };
        // Sizes first: log-uniform over 20×, usually with both ends present;
        // the region they stand in grows with their total footprint.
        let mut sizes: Vec<f64> = (0..count)
            .map(|_| self.u * self.rng.log_range(0.1, 2.0))
            .collect();
        if count >= 3 && self.rng.chance(0.7) {
            let small = self.rng.int(0, count - 1) as usize;
            let large = (small + 1 + self.rng.int(0, count - 2) as usize) % count as usize;
            sizes[small] = self.u * self.rng.range(0.1, 0.15);
            sizes[large] = self.u * self.rng.range(1.5, 2.0);
        }
        let footprint: f64 = sizes.iter().map(|s| s * s).sum::<f64>().sqrt();
        let largest = sizes.iter().copied().fold(0.0, f64::max);
        self.region = (footprint * self.rng.range(0.7, 1.3)).max(0.8 * largest);
        let mut thin_made = 0;
        for (i, size) in sizes.into_iter().enumerate() {
            let thin = i < thin_wanted as usize;
            let footprint = 0.5 * size;
            let (x, z) = self.free_spot(footprint);
            let material = self.rng.pick(&self.palette.clone());
            let name = format!("obj{i}");
            let floating = self.rng.chance(0.15);
            let lift = if floating {
                size * self.rng.range(0.2, 1.5)
            } else {
                // Sunk a hair into the ground: no face coplanar with it.
                -0.002 * size
            };
            // On the ground's mean level (a heightfield's bumps may cover
            // a little of it).
            let base = V3::new(x, self.ground_y + lift, z);
            let kind = if thin {
                self.rng.pick(&["post", "plank", "fin", "rail"])
            } else {
                let r = self.rng.unit();
                if r < 0.36 {
                    "block"
                } else if r < 0.64 {
                    "sphere"
                } else if r < 0.78 {
                    "quad"
                } else if r < 0.89 {
                    "disk"
                } else {
                    "heightfield"
                }
            };
            let placed = self.object(kind, name, material, base, size);
            if thin {
                thin_made += 1;
            }
            self.objects.push(placed);
        }
        let kinds: Vec<&str> = self
            .objects
            .iter()
            .map(|p| self.shapes[p.shape].kind)
            .collect();
        let counts: Vec<String> = [
            ("box", "boxes"),
            ("sphere", "spheres"),
            ("quad", "quads"),
            ("disk", "disks"),
            ("heightfield", "heightfields"),
        ]
        .iter()
        .filter_map(|&(one, many)| {
            let n = kinds.iter().filter(|&&x| x == one).count();
            (n > 0).then(|| format!("{n} {}", if n == 1 { one } else { many }))
        })
        .collect();
        self.notes.push(format!(
            "{} objects ({}; {thin_made} thin), sizes {}–{} in a region of radius {}",
            self.objects.len(),
            counts.join(", "),
            approx(self.objects.iter().map(|p| p.size).fold(f64::MAX, f64::min)),
            approx(self.objects.iter().map(|p| p.size).fold(0.0, f64::max)),
            approx(self.region),
        ));
    }
    /// A spot in the region, away from the objects so far when one can be
    /// found in a few tries.
    pub(super) fn free_spot(&mut self, footprint: f64) -> (f64, f64) {
        let mut spot = (0.0, 0.0);
        for _ in 0..12 {
            let r = self.region * self.rng.unit().sqrt();
            let (s, c) = dmath::sin_cos_deg(self.rng.range(0.0, 360.0));
            spot = (r * s, r * c);
            let p = V3::new(spot.0, 0.0, spot.1);
            let clear = self.objects.iter().all(|o| {
                let d = V3::new(o.center.x, 0.0, o.center.z) - p;
                d.length() > 0.7 * o.radius + footprint
            });
            if clear {
                break;
            }
        }
        spot
    }
    /// One object of `kind` standing at `base` (bottom centre), of about
    /// `size`.
    pub(super) fn object(
        &mut self,
        kind: &str,
        name: String,
        material: String,
        base: V3,
        size: f64,
    ) -> Placed {
        let min_thin = 0.004 * self.u;
        let rotate_y = if self.rng.chance(0.75) {
            self.rng.range(0.0, 360.0)
        } else {
            0.0
        };
        let mut scale = None;
        let mut movable = true;
        let (shape_kind, comment, body, anchor, center, radius, top) = match kind {
            "block" | "post" | "plank" | "fin" | "rail" => {
                let (w, h, d, lift, comment) = match kind {
                    "block" => (
                        size * self.rng.range(0.4, 1.0),
                        size * self.rng.range(0.3, 1.5),
                        size * self.rng.range(0.4, 1.0),
                        0.0,
                        "box",
                    ),
                    "post" => {
                        let h = size * self.rng.range(1.0, 3.0);
                        let w = (h * self.rng.range(0.012, 0.06)).max(min_thin);
                        (w, h, w * self.rng.range(1.0, 2.0), 0.0, "thin post")
                    }
                    "plank" => {
                        let l = size * self.rng.range(1.0, 2.5);
                        let t = (l * self.rng.range(0.008, 0.04)).max(min_thin);
                        let lift = if self.rng.chance(0.5) {
                            size * self.rng.range(0.2, 1.0)
                        } else {
                            0.0
                        };
                        (l, t, l * self.rng.range(0.1, 0.4), lift, "thin plank")
                    }
                    "fin" => {
                        let l = size * self.rng.range(0.8, 2.0);
                        let t = (l * self.rng.range(0.005, 0.03)).max(min_thin);
                        (l, size * self.rng.range(0.5, 1.5), t, 0.0, "thin fin")
                    }
                    _ => {
                        // A rail: a long bar of tiny cross-section in the air.
                        let l = size * self.rng.range(1.5, 3.0);
                        let t = (l * self.rng.range(0.005, 0.02)).max(min_thin);
                        let lift = size * self.rng.range(0.3, 1.2);
                        (l, t, t, lift, "thin rail")
                    }
                };
                let body = format!(
                    "min = {}\nmax = {}\n",
                    vec3(V3::new(-w / 2.0, 0.0, -d / 2.0)),
                    vec3(V3::new(w / 2.0, h, d / 2.0))
                );
                let anchor = base + V3::new(0.0, lift, 0.0);
                let radius = 0.5 * (w * w + h * h + d * d).sqrt();
                (
                    "box",
                    comment.to_string(),
                    body,
                    anchor,
                    anchor + V3::new(0.0, h / 2.0, 0.0),
                    radius,
                    anchor.y + h,
                )
            }
            "sphere" => {
                let r = size / 2.0;
                let segments = self.rng.int(8, 48);
                let rings = self.rng.int((segments / 4).max(4), (segments / 2).max(6));
                let sy = if self.rng.chance(0.25) {
                    let sy = self.rng.range(0.3, 1.6);
                    scale = Some(V3::new(1.0, sy, 1.0));
                    sy
                } else {
                    1.0
                };
                let body = format!(
                    "center = {}\nradius = {}\nsegments = {segments}\nrings = {rings}\n",
                    vec3(V3::new(0.0, r, 0.0)),
                    num(r)
                );
                let center = base + V3::new(0.0, r * sy, 0.0);
                (
                    "sphere",
                    if sy == 1.0 { "sphere" } else { "ellipsoid" }.to_string(),
                    body,
                    base,
                    center,
                    r * sy.max(1.0),
                    base.y + 2.0 * r * sy,
                )
            }
            "quad" => {
                let a = size * self.rng.range(0.25, 0.75);
                let b = size * self.rng.range(0.25, 0.75);
                let pitch: f64 = if self.rng.chance(0.5) {
                    0.0
                } else {
                    self.rng.range(-70.0, 70.0)
                };
                let (sp, cp) = dmath::sin_cos_deg(pitch);
                let body = format!("corners = {}\n", corners(&tilted_corners(a, b, sp, cp)));
                // Centred on its local origin: its lowest edge on the base.
                let anchor = base + V3::new(0.0, b * cp.abs() + 0.002 * size, 0.0);
                (
                    "quad",
                    if pitch == 0.0 {
                        "standing card"
                    } else {
                        "tilted card"
                    }
                    .to_string(),
                    body,
                    anchor,
                    anchor,
                    (a * a + b * b).sqrt(),
                    anchor.y + b * cp.abs(),
                )
            }
            "disk" => {
                let r = size * self.rng.range(0.3, 0.6);
                let normal = if self.rng.chance(0.6) {
                    V3::new(self.rng.range(-0.4, 0.4), 1.0, self.rng.range(-0.4, 0.4))
                } else {
                    V3::new(
                        self.rng.range(-1.0, 1.0),
                        self.rng.range(0.05, 0.5),
                        self.rng.range(-1.0, 1.0),
                    )
                };
                let segments = self.rng.int(8, 48);
                let height = r + size * self.rng.range(0.0, 0.8);
                let anchor = base + V3::new(0.0, height, 0.0);
                let body = format!(
                    "center = [0, 0, 0]\nnormal = {}\nradius = {}\nsegments = {segments}\n",
                    vec3(normal),
                    num(r)
                );
                (
                    "disk",
                    "disk".to_string(),
                    body,
                    anchor,
                    anchor,
                    r,
                    anchor.y + r,
                )
            }
            _ => {
                movable = false;
                let hx = size * self.rng.range(0.4, 1.0);
                let hz = size * self.rng.range(0.4, 1.0);
                let amplitude = size * self.rng.range(0.1, 0.5);
                let cells = self.rng.chance(0.4);
                let n = [self.rng.int(6, 40), self.rng.int(6, 40)];
                let mut body = format!(
                    "min = [{}, {}]\nmax = [{}, {}]\nresolution = [{}, {}]\nbase_y = 0\namplitude = {}\nfrequency = {}\n",
                    num(-hx),
                    num(-hz),
                    num(hx),
                    num(hz),
                    n[0],
                    n[1],
                    num(amplitude),
                    num(self.rng.range(0.7, 3.0) / size),
                );
                if cells {
                    body.push_str("noise = \"cells\"\n");
                } else {
                    let _ = writeln!(body, "octaves = {}", self.rng.int(1, 5));
                }
                let _ = writeln!(body, "seed = {}", self.rng.seed32());
                let anchor = base + V3::new(0.0, amplitude, 0.0);
                (
                    "heightfield",
                    "heightfield patch".to_string(),
                    body,
                    anchor,
                    anchor,
                    (hx * hx + hz * hz + amplitude * amplitude).sqrt(),
                    anchor.y + amplitude,
                )
            }
        };
        self.shapes.push(Shape {
            comment: format!("{name}: {comment}, size {}", num(size)),
            kind: shape_kind,
            name,
            material,
            body,
            anchor: Some(anchor),
            rotate_y,
            scale,
            motion: Vec::new(),
        });
        Placed {
            shape: self.shapes.len() - 1,
            center,
            radius,
            top,
            size,
            movable,
        }
    }
    /// Centre and radius of the objects' bounding sphere (about), and the
    /// top of the highest.
    pub(super) fn extent(&self) -> (V3, f64, f64) {
        let n = self.objects.len() as f64;
        let centroid = self
            .objects
            .iter()
            .fold(V3::ZERO, |s, o| s + o.center * (1.0 / n));
        let radius = self
            .objects
            .iter()
            .map(|o| (o.center - centroid).length() + o.radius)
            .fold(0.5 * self.u, f64::max);
        let top = self
            .objects
            .iter()
            .map(|o| o.top)
            .fold(self.ground_top, f64::max);
        (centroid, radius, top)
    }
    // --- camera, ground, background ----------------------------------------

    pub(super) fn place_camera(&mut self) {
        let (centroid, rho, top) = self.extent();
        let fov_y = self.rng.range(30.0, 60.0);
        let aspect = self.aspect();
        let tan_y = dmath::tan_deg(fov_y / 2.0);
        let half = dmath::atan(tan_y.min(tan_y * aspect));
        let jitter = V3::new(
            self.rng.range(-0.1, 0.1),
            self.rng.range(-0.05, 0.05),
            self.rng.range(-0.1, 0.1),
        ) * rho;
        let mut target = centroid + jitter;
        let low = self.ground_top + 0.02 * self.u;
        target.y = target.y.min(top).max(low);
        let (lo, hi) = if self.kind == GenIntegrand::DepthOfField {
            (4.0, 30.0)
        } else {
            (6.0, 55.0)
        };
        let dir = self.rng.dir_up(lo, hi);
        let k = self.rng.range(0.45, 0.95);
        let mut distance = k * rho / dmath::sin_cos(half).0;
        let mut position = target + dir * distance;
        for _ in 0..16 {
            let inside = self
                .objects
                .iter()
                .any(|o| (position - o.center).length() < 1.05 * o.radius);
            if !inside {
                break;
            }
            distance *= 1.25;
            position = target + dir * distance;
        }
        position.y = position.y.max(self.ground_top + 0.05 * self.u);
        self.camera = Some(Camera::new(position, target, fov_y, aspect));
        self.notes.push(format!(
            "camera {} from the objects' centre, fov_y {}",
            approx(distance),
            approx(fov_y)
        ));
    }
}
