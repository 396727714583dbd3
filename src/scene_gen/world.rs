//! The ground (plane or heightfield), the background, the room, and the
//! scene's text as written.

use super::*;

impl Gen {
    pub(super) fn make_ground(&mut self, material: &str, heightfield: bool, amplitude: f64) {
        // Large enough that the view axis and the rays through the film's
        // middle row and bottom corners meet it (the horizon, when the
        // view reaches it, at 60 times the region).
        let cam = self.cam();
        let mut half = 4.0 * self.region;
        for (nx, ny) in [
            (0.0, 0.0),
            (-1.0, 0.0),
            (1.0, 0.0),
            (-1.0, -1.0),
            (1.0, -1.0),
        ] {
            let dir = cam.at_ndc(nx, ny, 1.0) - cam.position;
            if dir.y < -1e-3 {
                let t = (self.ground_y - cam.position.y) / dir.y;
                let p = cam.position + dir * t;
                half = half.max(1.15 * p.x.abs().max(p.z.abs()));
            }
        }
        half = half.min(60.0 * self.region);
        if heightfield {
            let n = self.rng.int(24, 96);
            let mut body = format!(
                "min = [{}, {}]\nmax = [{}, {}]\nresolution = [{n}, {n}]\nbase_y = {}\namplitude = {}\nfrequency = {}\n",
                num(-half),
                num(-half),
                num(half),
                num(half),
                num(self.ground_y),
                num(amplitude),
                num(self.rng.range(0.05, 0.4) / self.u),
            );
            let _ = writeln!(
                body,
                "octaves = {}\nseed = {}",
                self.rng.int(2, 6),
                self.rng.seed32()
            );
            self.shapes.insert(
                0,
                Shape {
                    comment: "ground: rolling heightfield".into(),
                    kind: "heightfield",
                    name: "ground".into(),
                    material: material.into(),
                    body,
                    anchor: None,
                    rotate_y: 0.0,
                    scale: None,
                    motion: Vec::new(),
                },
            );
        } else {
            let y = self.ground_y;
            let c = quad_facing(
                [
                    V3::new(-half, y, -half),
                    V3::new(-half, y, half),
                    V3::new(half, y, half),
                    V3::new(half, y, -half),
                ],
                V3::Y,
            );
            self.shapes.insert(
                0,
                Shape {
                    comment: "ground: a plane".into(),
                    kind: "quad",
                    name: "ground".into(),
                    material: material.into(),
                    body: format!("corners = {}\n", corners(&c)),
                    anchor: None,
                    rotate_y: 0.0,
                    scale: None,
                    motion: Vec::new(),
                },
            );
        }
        for p in &mut self.objects {
            p.shape += 1;
        }
    }
    pub(super) fn make_background(&mut self) {
        let black = if self.kind == GenIntegrand::AmbientOcclusion {
            0.4
        } else {
            0.5
        };
        if self.rng.chance(black) {
            self.background = V3::ZERO;
            self.notes.push("black background".into());
        } else {
            let level = if self.kind == GenIntegrand::AmbientOcclusion {
                self.rng.range(0.3, 1.0)
            } else {
                self.rng.log_range(0.02, 0.6)
            };
            self.background = tint(&mut self.rng, 0.3) * level;
            self.notes
                .push(format!("coloured background {}", vec3(self.background)));
        }
    }
    /// `path` only: a room open toward the camera (floor, ceiling, back and
    /// side walls facing in), the camera outside the opening.
    pub(super) fn make_room(&mut self) {
        let (_, _, top) = self.extent();
        let reach = self
            .objects
            .iter()
            .map(|o| o.center.x.abs().max(o.center.z.abs()) + o.radius)
            .fold(self.region, f64::max);
        let w = reach * self.rng.range(1.05, 1.3);
        let d = reach * self.rng.range(1.05, 1.3);
        let y0 = self.ground_y;
        let h = ((top - y0) * self.rng.range(1.3, 2.0)).max(w * self.rng.range(0.7, 1.3));
        let y1 = y0 + h;
        let walls = [
            (
                "floor",
                V3::Y,
                [(-w, y0, -d), (-w, y0, d), (w, y0, d), (w, y0, -d)],
            ),
            (
                "ceiling",
                -V3::Y,
                [(-w, y1, -d), (-w, y1, d), (w, y1, d), (w, y1, -d)],
            ),
            (
                "back_wall",
                V3::new(0.0, 0.0, -1.0),
                [(-w, y0, d), (-w, y1, d), (w, y1, d), (w, y0, d)],
            ),
            (
                "left_wall",
                V3::new(1.0, 0.0, 0.0),
                [(-w, y0, -d), (-w, y1, -d), (-w, y1, d), (-w, y0, d)],
            ),
            (
                "right_wall",
                V3::new(-1.0, 0.0, 0.0),
                [(w, y0, -d), (w, y1, -d), (w, y1, d), (w, y0, d)],
            ),
        ];
        let mut inserted = 0;
        for (name, facing, c) in walls {
            let c = quad_facing(c.map(|(x, y, z)| V3::new(x, y, z)), facing);
            let material = if name == "floor" {
                "ground".to_string()
            } else {
                self.rng.pick(&self.palette.clone())
            };
            self.shapes.insert(
                inserted,
                Shape {
                    comment: format!("room {name}, facing in"),
                    kind: "quad",
                    name: name.into(),
                    material,
                    body: format!("corners = {}\n", corners(&c)),
                    anchor: None,
                    rotate_y: 0.0,
                    scale: None,
                    motion: Vec::new(),
                },
            );
            inserted += 1;
        }
        for p in &mut self.objects {
            p.shape += inserted;
        }
        // The camera outside the open side (z = −d), looking in.
        let fov_y = self.rng.range(30.0, 60.0);
        let aspect = self.aspect();
        let tan_y = dmath::tan_deg(fov_y / 2.0);
        let back = (0.5 * h / tan_y).max(w / (tan_y * aspect)) * self.rng.range(0.85, 1.15);
        let position = V3::new(
            self.rng.range(-0.3, 0.3) * w,
            y0 + h * self.rng.range(0.3, 0.7),
            -d - back,
        );
        let look_at = V3::new(
            self.rng.range(-0.15, 0.15) * w,
            y0 + h * self.rng.range(0.3, 0.5),
            self.rng.range(-0.2, 0.3) * d,
        );
        self.camera = Some(Camera::new(position, look_at, fov_y, aspect));
        self.room = Some(Room { w, y0, y1 });
        self.notes.push(format!(
            "a room {}×{}×{} open toward the camera, fov_y {}",
            approx(2.0 * w),
            approx(h),
            approx(2.0 * d),
            approx(fov_y)
        ));
    }
    // --- text ---------------------------------------------------------------

    pub(super) fn write(self) -> String {
        let mut out = String::new();
        let name = self.kind.name();
        let (w, h) = (self.opts.width, self.opts.height);
        let _ = writeln!(
            out,
            "# Random {name} scene, seed {}: made by mdas scene_gen v{GENERATOR_VERSION} \
             (`mdas scene random`), tuned by nobody.",
            self.seed
        );
        let _ = writeln!(
            out,
            "# Regenerate: mdas scene random --integrand {name} --seed {} --width {w} --height {h} -o FILE.toml",
            self.seed
        );
        for note in &self.notes {
            let _ = writeln!(out, "# - {note}");
        }
        let _ = writeln!(out, "# No [mdas] table: MDAS takes MdasParams::for_film.\n");
        let _ = writeln!(out, "background = {}\n", vec3(self.background));
        let _ = writeln!(out, "[film]\nwidth = {w}\nheight = {h}\n");
        let cam = self.cam();
        let _ = writeln!(
            out,
            "[camera]\nposition = {}\nlook_at = {}\nup = [0, 1, 0]\nfov_y = {}",
            vec3(cam.position),
            vec3(cam.look_at),
            num(cam.fov_y)
        );
        if let Some((aperture, focus)) = self.aperture {
            let _ = writeln!(
                out,
                "aperture_radius = {}\nfocus_distance = {}",
                num(aperture),
                num(focus)
            );
        }
        if let Some((open, close)) = self.shutter {
            let _ = writeln!(
                out,
                "shutter_open = {}\nshutter_close = {}",
                num(open),
                num(close)
            );
        }
        out.push('\n');
        for m in &self.materials {
            let _ = writeln!(
                out,
                "[[material]]\nname = \"{}\"\nalbedo = {}",
                m.name,
                vec3(m.albedo)
            );
            if let Some(e) = m.emission {
                let _ = writeln!(out, "emission = {}", vec3(e));
            }
            if let Some((b, s)) = m.checker {
                let _ = writeln!(
                    out,
                    "checker = {{ albedo2 = {}, scale = {} }}",
                    vec3(b),
                    num(s)
                );
            }
            out.push('\n');
        }
        for s in &self.shapes {
            write_shape(&mut out, s);
        }
        out.push_str(&self.lights);
        out.push_str(&self.light_sets);
        let _ = write!(out, "[integrand]\n{}", self.integrand);
        out
    }
}
