//! The lights of each integrand: area lights, delta lights, the path
//! tracer's lights, emissive objects, occlusion and many-light sets.

use super::*;

impl Gen {
    // --- lights -------------------------------------------------------------

    /// A point around the objects at distance `r` from the look-at point,
    /// `lo`–`hi` degrees above the horizon and above every object.
    pub(super) fn light_spot(&mut self, lo: f64, hi: f64, r: f64) -> V3 {
        let (_, _, top) = self.extent();
        let target = self.cam().look_at;
        let mut p = target + self.rng.dir_up(lo, hi) * r;
        p.y = p.y.max(top + 0.2 * self.u);
        p
    }
    /// Irradiance a light should give the objects: `dominant` ones 10×.
    pub(super) fn irradiance(&mut self, dominant: bool) -> f64 {
        let e = self.rng.log_range(0.4, 3.0);
        if dominant {
            10.0 * e
        } else {
            e
        }
    }
    /// A quad light of half sizes `a` × `b` at `center` emitting toward
    /// `normal`: a `[[light]] type = "quad"` when it faces straight down or
    /// up (its corners share one y, exactly planar), else an emissive
    /// `[[shape]]` quad tilted by `transform` (corners symmetric about its
    /// origin, planar after rounding).
    pub(super) fn quad_light(
        &mut self,
        comment: &str,
        center: V3,
        normal: V3,
        a: f64,
        b: f64,
        radiance: V3,
    ) {
        let n = normal.normalize();
        if n.y.abs() > 0.9999 {
            let c = quad_facing(
                [
                    center + V3::new(-a, 0.0, -b),
                    center + V3::new(a, 0.0, -b),
                    center + V3::new(a, 0.0, b),
                    center + V3::new(-a, 0.0, b),
                ],
                n,
            );
            let _ = write!(
                self.lights,
                "# {comment}\n[[light]]\ntype = \"quad\"\ncorners = {}\nradiance = {}\n\n",
                corners(&c),
                vec3(radiance)
            );
            self.emissive_surfaces = true;
        } else {
            let material = self.emitter(radiance);
            let sp = n.y;
            let cp = (1.0 - n.y * n.y).sqrt();
            let rotate_y = dmath::atan2_deg(n.x, n.z);
            let index = self.shapes.len();
            self.shapes.push(Shape {
                comment: comment.into(),
                kind: "quad",
                name: format!("lamp{index}"),
                material,
                body: format!("corners = {}\n", corners(&tilted_corners(a, b, sp, cp))),
                anchor: Some(center),
                rotate_y,
                scale: None,
                motion: Vec::new(),
            });
        }
    }
    pub(super) fn area_light_lights(&mut self) {
        let count = self.rng.int(1, 3);
        let dominant = if count > 1 && self.rng.chance(0.5) {
            Some(self.rng.int(0, count - 1))
        } else {
            None
        };
        let mut made = Vec::new();
        for i in 0..count {
            let style = self.rng.pick(&[
                "overhead",
                "overhead",
                "large dim",
                "tiny bright",
                "in view",
            ]);
            let e = self.irradiance(dominant == Some(i));
            made.push(self.area_light(style, e));
        }
        self.notes.push(format!("area lights: {}", made.join(", ")));
        self.integrand = "type = \"area_light\"\n".into();
    }
    /// One quad area light of `style` giving about irradiance `e`; what it
    /// became.
    pub(super) fn area_light(&mut self, style: &str, e: f64) -> String {
        let (_, rho, _) = self.extent();
        let target = self.cam().look_at;
        let color = tint(&mut self.rng, 0.6);
        if style == "in view" {
            if let Some((center, normal)) = self.in_view_spot() {
                let half = self.u * self.rng.range(0.05, 0.4);
                let r = (center - target).length();
                let radiance = color * (e * r * r / (4.0 * half * half)).max(2.0);
                self.quad_light(
                    "quad light in view, facing the camera side",
                    center,
                    normal,
                    half,
                    half,
                    radiance,
                );
                return "in view".into();
            }
        }
        let (half_a, half_b, r, what) = match style {
            "large dim" => {
                let s = self.region * self.rng.range(0.3, 0.8);
                (
                    s,
                    s * self.rng.range(0.5, 1.0),
                    rho * self.rng.range(1.0, 2.0),
                    "large dim",
                )
            }
            "tiny bright" => {
                let s = self.u * self.rng.range(0.01, 0.04);
                (s, s, rho * self.rng.range(0.6, 1.5), "tiny bright")
            }
            _ => {
                let s = self.u * self.rng.range(0.1, 0.5);
                (
                    s,
                    s * self.rng.range(0.5, 1.0),
                    rho * self.rng.range(0.8, 2.0),
                    "overhead",
                )
            }
        };
        let center = self.light_spot(30.0, 85.0, r);
        let r = (center - target).length();
        let mut radiance = e * r * r / (4.0 * half_a * half_b);
        if what == "tiny bright" {
            radiance = radiance.clamp(200.0, 1e6);
        }
        let normal = if self.rng.chance(0.5) {
            -V3::Y
        } else {
            target - center
        };
        self.quad_light(
            &format!("{what} quad light, facing the objects"),
            center,
            normal,
            half_a,
            half_b,
            color * radiance,
        );
        what.into()
    }
    /// A spot inside the view, behind the look-at point and above the
    /// ground, for an emitter the camera sees, with the normal between the
    /// directions to the camera and to the objects (both on its front).
    pub(super) fn in_view_spot(&mut self) -> Option<(V3, V3)> {
        let (_, _, top) = self.extent();
        let cam = self.cam();
        let (cam_pos, target) = (cam.position, cam.look_at);
        let d = (target - cam_pos).length();
        for _ in 0..24 {
            let nx = self.rng.range(-0.7, 0.7);
            let ny = self.rng.range(0.1, 0.85);
            let depth = d * self.rng.range(1.05, 1.8);
            let p = self.cam().at_ndc(nx, ny, depth);
            let clear = self
                .objects
                .iter()
                .all(|o| (p - o.center).length() > 1.2 * o.radius + 0.5 * self.u);
            if p.y > self.ground_top + 0.5 * self.u && p.y < top + 4.0 * d && clear {
                let n = (cam_pos - p).normalize() + (target - p).normalize();
                return Some((p, n));
            }
        }
        None
    }
    /// 1–4 point and directional lights, sometimes one dominant (10× the
    /// irradiance of the others).
    pub(super) fn delta_lights(&mut self) {
        let (_, rho, _) = self.extent();
        let target = self.cam().look_at;
        let count = self.rng.int(1, 4);
        let dominant = if count > 1 && self.rng.chance(0.4) {
            Some(self.rng.int(0, count - 1))
        } else {
            None
        };
        let (mut points, mut suns) = (0, 0);
        for i in 0..count {
            let e = self.irradiance(dominant == Some(i));
            let color = tint(&mut self.rng, 0.55);
            if self.rng.chance(0.6) {
                let r = rho * self.rng.range(0.7, 3.0);
                let p = self.light_spot(15.0, 80.0, r);
                let d = (p - target).length();
                let _ = write!(
                    self.lights,
                    "[[light]]\ntype = \"point\"\nposition = {}\nintensity = {}\n\n",
                    vec3(p),
                    vec3(color * (e * d * d))
                );
                points += 1;
            } else {
                let dir = -self.rng.dir_up(20.0, 85.0);
                let _ = write!(
                    self.lights,
                    "[[light]]\ntype = \"directional\"\ndirection = {}\nirradiance = {}\n\n",
                    vec3(dir),
                    vec3(color * e)
                );
                suns += 1;
            }
        }
        self.notes.push(format!(
            "{points} point and {suns} directional light(s){}",
            if dominant.is_some() {
                ", one dominant"
            } else {
                ""
            }
        ));
    }
    /// `path`: area, point and directional lights (outdoors), or a room
    /// lit mostly indirectly; 1–4 bounces (1–3 with emissive surfaces, so
    /// that d ≤ 16).
    pub(super) fn path_lights(&mut self, room: bool) {
        if let (true, Some(Room { w, y0, y1 })) = (room, self.room) {
            let h = y1 - y0;
            let y = y1 - 0.04 * h;
            let half = w * self.rng.range(0.1, 0.3);
            let e = self.irradiance(false);
            // Four times the direct estimate L·A/h²: most of it arrives
            // after a bounce.
            let radiance =
                tint(&mut self.rng, 0.7) * (4.0 * e * h * h / (4.0 * half * half)).max(1.0);
            let x = self.rng.range(-0.3, 0.3) * w;
            let z = self.rng.range(-0.3, 0.3) * w;
            match self.rng.int(0, 2) {
                0 => {
                    self.quad_light(
                        "light under the ceiling, facing it: the room is lit by the bounce",
                        V3::new(x, y, z),
                        V3::Y,
                        half,
                        half,
                        radiance,
                    );
                    self.notes
                        .push("lit indirectly (a quad light facing the ceiling)".into());
                }
                1 => {
                    self.quad_light(
                        "ceiling light facing down",
                        V3::new(x, y, z),
                        -V3::Y,
                        half,
                        half,
                        radiance,
                    );
                    self.notes.push("a ceiling quad light".into());
                }
                _ => {
                    let p = V3::new(x, y - 0.1 * h, z);
                    let d = p.y - y0;
                    let intensity = tint(&mut self.rng, 0.7) * (e * d * d);
                    let _ = write!(
                        self.lights,
                        "[[light]]\ntype = \"point\"\nposition = {}\nintensity = {}\n\n",
                        vec3(p),
                        vec3(intensity)
                    );
                    self.notes.push("a point light in the room".into());
                }
            }
            if self.rng.chance(0.3) {
                self.emissive_object();
            }
        } else {
            match self.rng.pick(&["sun", "area", "points", "mixed"]) {
                "sun" => {
                    if self.background == V3::ZERO && self.rng.chance(0.7) {
                        self.background = V3::new(0.35, 0.5, 0.8) * self.rng.range(0.2, 1.0);
                        self.notes.push(format!("sky {}", vec3(self.background)));
                    }
                    let e = self.irradiance(false);
                    let dir = -self.rng.dir_up(20.0, 80.0);
                    let _ = write!(
                        self.lights,
                        "# the sun\n[[light]]\ntype = \"directional\"\ndirection = {}\nirradiance = {}\n\n",
                        vec3(dir),
                        vec3(tint(&mut self.rng, 0.75) * e)
                    );
                    self.notes.push("a sun".into());
                }
                "area" => {
                    let count = self.rng.int(1, 2);
                    for _ in 0..count {
                        let style =
                            self.rng
                                .pick(&["overhead", "large dim", "tiny bright", "in view"]);
                        let e = self.irradiance(false);
                        let made = self.area_light(style, e);
                        self.notes.push(format!("an area light: {made}"));
                    }
                    if self.rng.chance(0.3) {
                        self.emissive_object();
                    }
                }
                "points" => self.delta_lights(),
                _ => {
                    let style = self.rng.pick(&["overhead", "tiny bright", "in view"]);
                    let e = self.irradiance(false);
                    let made = self.area_light(style, e);
                    self.notes.push(format!("an area light: {made}"));
                    self.delta_lights();
                }
            }
        }
        let limit = if self.emissive_surfaces { 3 } else { 4 };
        let bounces = self.rng.int(1, limit);
        self.integrand = format!("type = \"path\"\nmax_bounces = {bounces}\n");
        self.notes.push(format!("{bounces} bounce(s)"));
    }
    /// One object turned into an emitter (a glowing sphere or box).
    pub(super) fn emissive_object(&mut self) {
        let i = self.rng.int(0, self.objects.len() as u32 - 1) as usize;
        let radiance = tint(&mut self.rng, 0.5) * self.rng.log_range(1.0, 20.0);
        let material = self.emitter(radiance);
        let shape = &mut self.shapes[self.objects[i].shape];
        shape.material = material;
        shape.comment.push_str(", emissive");
        self.notes.push(format!("{} glows", shape.name));
    }
    pub(super) fn occlusion(&mut self) {
        let (_, rho, _) = self.extent();
        let radius = rho * self.rng.log_range(0.05, 0.5);
        self.integrand = format!("type = \"ambient_occlusion\"\nradius = {}\n", num(radius));
        self.notes
            .push(format!("occlusion radius {}", approx(radius)));
    }
    /// `many_light`: 16–2000 lights of the many-light list from one to
    /// four sources: `[[light]]` points, emissive spheres and quads, and a
    /// `box`, `grid` or `surface` light set (sometimes orbiting).
    pub(super) fn many_lights(&mut self) {
        let (_, rho, top) = self.extent();
        let target_count = self.rng.log_int(16, 2000);
        let mut total = 0u32;
        let e_total = self.rng.log_range(1.0, 4.0);
        let dominant_source = self.rng.int(0, 5);
        let mut sources = Vec::new();
        let share = |rng: &mut Rng, source: u32, n: u32| -> f64 {
            let e = e_total * f64::from(n) / f64::from(target_count);
            if source == dominant_source && rng.chance(0.5) {
                10.0 * e
            } else {
                e
            }
        };
        let low = self.ground_top + 0.1 * (top - self.ground_top);
        let high = top + 0.5 * rho;
        let r = self.region;
        if self.rng.chance(0.4) {
            let n = self.rng.int(4, 48).min(target_count - total);
            let e = share(&mut self.rng, 0, n);
            for _ in 0..n {
                let p = V3::new(
                    self.rng.range(-r, r),
                    self.rng.range(low, high),
                    self.rng.range(-r, r),
                );
                let d = (p - self.cam().look_at).length();
                let intensity = tint(&mut self.rng, 0.4) * (e * d * d / f64::from(n));
                let _ = write!(
                    self.lights,
                    "[[light]]\ntype = \"point\"\nposition = {}\nintensity = {}\n\n",
                    vec3(p),
                    vec3(intensity)
                );
            }
            total += n;
            sources.push(format!("{n} point lights"));
        }
        if self.rng.chance(0.35) {
            let segments = self.rng.int(4, 8);
            let rings = self.rng.int(2, 4);
            let per = 2 * segments * (rings - 1);
            let n = self.rng.int(1, 16).min((target_count - total) / per);
            if n > 0 {
                let e = share(&mut self.rng, 1, n * per);
                for _ in 0..n {
                    let radius = self.u * self.rng.range(0.03, 0.2);
                    let p = V3::new(
                        self.rng.range(-r, r),
                        self.rng.range(low, high) + radius,
                        self.rng.range(-r, r),
                    );
                    let d = (p - self.cam().look_at).length();
                    let area = std::f64::consts::PI * radius * radius;
                    let radiance = tint(&mut self.rng, 0.4) * (e * d * d / (f64::from(n) * area));
                    let material = self.emitter(radiance);
                    let index = self.shapes.len();
                    self.shapes.push(Shape {
                        comment: "emissive sphere".into(),
                        kind: "sphere",
                        name: format!("lamp{index}"),
                        material,
                        body: format!(
                            "center = {}\nradius = {}\nsegments = {segments}\nrings = {rings}\n",
                            vec3(p),
                            num(radius)
                        ),
                        anchor: None,
                        rotate_y: 0.0,
                        scale: None,
                        motion: Vec::new(),
                    });
                }
                total += n * per;
                sources.push(format!("{n} emissive spheres of {per} triangles"));
            }
        }
        if self.rng.chance(0.3) {
            let n = self.rng.int(2, 40).min((target_count - total) / 2);
            if n > 0 {
                let e = share(&mut self.rng, 2, 2 * n);
                for _ in 0..n {
                    let half = self.u * self.rng.range(0.03, 0.3);
                    let p = V3::new(
                        self.rng.range(-r, r),
                        self.rng.range(top, high) + half,
                        self.rng.range(-r, r),
                    );
                    let d = (p - self.cam().look_at).length();
                    let radiance =
                        tint(&mut self.rng, 0.4) * (e * d * d / (f64::from(n) * 4.0 * half * half));
                    let normal = if self.rng.chance(0.5) {
                        -V3::Y
                    } else {
                        self.cam().look_at - p
                    };
                    self.quad_light("small quad light", p, normal, half, half, radiance);
                }
                total += 2 * n;
                sources.push(format!("{n} quad lights"));
            }
        }
        let left = target_count - total;
        if left > 0 && (total < 16 || self.rng.chance(0.8)) {
            let kind = self.rng.pick(&["box", "grid", "surface"]);
            let (count, body) = match kind {
                "box" => {
                    let above = self.rng.chance(0.5);
                    let y0 = if above { top } else { low };
                    (
                        left,
                        format!(
                            "count = {left}\nmin = {}\nmax = {}\n",
                            vec3(V3::new(-r, y0, -r)),
                            vec3(V3::new(r, high.max(y0 + 0.1 * self.u), r))
                        ),
                    )
                }
                "grid" => {
                    let nx = (f64::from(left).sqrt() * self.rng.range(0.5, 1.5))
                        .round()
                        .clamp(1.0, f64::from(left)) as u32;
                    let nz = (left / nx).max(1);
                    let y = self.rng.range(top, high) + 0.05 * self.u;
                    (
                        nx * nz,
                        format!(
                            "min = [{}, {}]\nmax = [{}, {}]\nresolution = [{nx}, {nz}]\ny = {}\n",
                            num(-r),
                            num(-r),
                            num(r),
                            num(r),
                            num(y)
                        ),
                    )
                }
                _ => {
                    let area = (8.0 * r) * (8.0 * r);
                    let offset = (area / f64::from(left)).sqrt() * self.rng.range(0.2, 0.8);
                    (
                        left,
                        format!(
                            "count = {left}\noffset = {}\n",
                            num(offset.min(2.0 * self.u))
                        ),
                    )
                }
            };
            let e = share(&mut self.rng, 3, count);
            let d = rho.max(high - self.cam().look_at.y);
            let intensity = tint(&mut self.rng, 0.5) * (e * d * d / f64::from(count));
            let mut text = format!(
                "[[light_set]]\ntype = \"{kind}\"\n{body}intensity = {}\nseed = {}\n",
                vec3(intensity),
                self.rng.seed32()
            );
            if self.rng.chance(0.6) {
                let _ = writeln!(
                    text,
                    "intensity_jitter = {}\ncolor_jitter = {}",
                    num(self.rng.range(0.0, 0.9)),
                    num(self.rng.range(0.0, 0.5))
                );
            }
            let orbit = self.rng.chance(0.3);
            if orbit {
                let _ = writeln!(
                    text,
                    "orbit_radius = {}\norbit_speed = {}",
                    num(r * self.rng.range(0.02, 0.3)),
                    num(self.rng.range(-3.0, 3.0))
                );
            }
            text.push('\n');
            self.light_sets.push_str(&text);
            total += count;
            sources.push(format!(
                "a {kind} light set of {count}{}",
                if orbit { ", orbiting" } else { "" }
            ));
        }
        if total < 16 {
            let n = 16 - total + self.rng.int(0, 48);
            let d = rho.max(high - self.cam().look_at.y);
            let intensity = V3::splat(e_total * d * d / f64::from(n));
            let _ = write!(
                self.light_sets,
                "[[light_set]]\ntype = \"box\"\ncount = {n}\nmin = {}\nmax = {}\nintensity = {}\nseed = {}\n\n",
                vec3(V3::new(-r, top, -r)),
                vec3(V3::new(r, high.max(top + 0.1 * self.u), r)),
                vec3(intensity),
                self.rng.seed32()
            );
            total += n;
            sources.push(format!("a box light set of {n}"));
        }
        self.notes
            .push(format!("{total} lights: {}", sources.join(", ")));
        self.integrand = "type = \"many_light\"\n".into();
    }
}
