//! The camera effects: the thin lens and its bokeh, and motion.

use super::*;

impl Gen {
    /// `depth_of_field`: a thin lens focused on one of the objects.
    pub(super) fn thin_lens(&mut self) {
        let i = self.rng.int(0, self.objects.len() as u32 - 1) as usize;
        let cam = self.cam();
        let along = (self.objects[i].center - cam.position).dot(cam.forward);
        let axis = (cam.look_at - cam.position).length();
        let (focus, on) = if along > 0.05 * axis {
            (along, self.shapes[self.objects[i].shape].name.clone())
        } else {
            (axis, "the look-at point".into())
        };
        let aperture = (focus * self.rng.log_range(0.004, 0.05)).max(1e-3);
        self.aperture = Some((aperture, focus));
        self.notes.push(format!(
            "thin lens: aperture radius {}, focused on {on} at {}",
            approx(aperture),
            approx(focus)
        ));
        self.integrand = "type = \"depth_of_field\"\n".into();
    }
    /// `depth_of_field`: small emissive spheres in view, in front of and
    /// behind the plane of focus (bokeh).
    pub(super) fn bokeh_spheres(&mut self) {
        let count = self.rng.int(1, 6);
        let d = {
            let cam = self.cam();
            (cam.look_at - cam.position).length()
        };
        let mut made = 0;
        for _ in 0..count {
            let nx = self.rng.range(-0.9, 0.9);
            let ny = self.rng.range(-0.2, 0.9);
            let depth = d * self.rng.range(0.4, 2.0);
            let p = self.cam().at_ndc(nx, ny, depth);
            let r = self.u * self.rng.range(0.02, 0.1);
            if p.y < self.ground_top + 2.0 * r
                || self
                    .objects
                    .iter()
                    .any(|o| (p - o.center).length() < o.radius + r)
            {
                continue;
            }
            let radiance = tint(&mut self.rng, 0.4) * self.rng.log_range(5.0, 60.0);
            let material = self.emitter(radiance);
            let index = self.shapes.len();
            self.shapes.push(Shape {
                comment: "small emissive sphere in view (bokeh)".into(),
                kind: "sphere",
                name: format!("bokeh{index}"),
                material,
                body: format!(
                    "center = {}\nradius = {}\nsegments = 12\nrings = 6\n",
                    vec3(p),
                    num(r)
                ),
                anchor: None,
                rotate_y: 0.0,
                scale: None,
                motion: Vec::new(),
            });
            made += 1;
        }
        if made > 0 {
            self.notes
                .push(format!("{made} emissive sphere(s) in view"));
        }
    }
    /// `motion_blur`: a shutter, and keyframed motion on some objects (fast
    /// and slow, straight, arced or stopping within the shutter, some
    /// turning); the others stay still.
    pub(super) fn motion(&mut self) {
        let (open, close) = match self.rng.int(0, 3) {
            0 | 1 => (0.0, 1.0),
            2 => (0.0, 0.5),
            _ => {
                let open = self.rng.range(-1.0, 1.0);
                (open, open + self.rng.range(0.05, 2.0))
            }
        };
        let (open, close) = (round5(open), round5(close));
        self.shutter = Some((open, close));
        let movable: Vec<usize> = (0..self.objects.len())
            .filter(|&i| self.objects[i].movable)
            .collect();
        let mut moving: Vec<usize> = movable
            .iter()
            .copied()
            .filter(|_| self.rng.chance(0.55))
            .collect();
        if moving.is_empty() {
            if let Some(&i) = movable.first() {
                moving.push(i);
            } else {
                // Only heightfield patches: the first one moves anyway.
                self.objects[0].movable = true;
                moving.push(0);
            }
        }
        if moving.len() == self.objects.len() && moving.len() > 2 {
            moving.pop();
        }
        let (mut fast, mut slow, mut turning) = (0, 0, 0);
        let span = close - open;
        for &i in &moving {
            let o = self.objects[i];
            let speed = if self.rng.chance(0.5) {
                fast += 1;
                o.size * self.rng.range(1.0, 4.0)
            } else {
                slow += 1;
                o.size * self.rng.range(0.05, 0.3)
            };
            let mut dir = self.rng.dir_up(-10.0, 10.0);
            if self.rng.chance(0.2) {
                dir = V3::new(0.0, if self.rng.chance(0.5) { 1.0 } else { -0.5 }, 0.0);
            }
            let delta = dir.normalize() * speed;
            let rotate = if self.rng.chance(0.35) {
                turning += 1;
                let axis = V3::new(
                    self.rng.range(-1.0, 1.0),
                    self.rng.range(0.2, 1.0),
                    self.rng.range(-1.0, 1.0),
                );
                let angle =
                    self.rng.range(15.0, 170.0) * if self.rng.chance(0.5) { 1.0 } else { -1.0 };
                Some((axis, angle))
            } else {
                None
            };
            let base = self.shapes[o.shape].anchor.expect("objects are anchored");
            let half_turn = rotate.map(|(a, deg)| (a, deg / 2.0));
            let pattern = self.rng.int(0, 2);
            let arc = V3::Y * (o.size * self.rng.range(0.2, 1.0));
            let times = [
                round5(open + span * self.rng.range(0.3, 0.7)),
                round5(open + span * self.rng.range(0.05, 0.35)),
                round5(open + span * self.rng.range(0.55, 0.95)),
            ];
            self.shapes[o.shape].motion = match pattern {
                0 => vec![
                    Key {
                        time: open,
                        translate: base,
                        rotate: None,
                    },
                    Key {
                        time: close,
                        translate: base + delta,
                        rotate,
                    },
                ],
                1 => {
                    vec![
                        Key {
                            time: open,
                            translate: base,
                            rotate: None,
                        },
                        Key {
                            time: times[0],
                            translate: base + delta * 0.5 + arc,
                            rotate: half_turn,
                        },
                        Key {
                            time: close,
                            translate: base + delta,
                            rotate,
                        },
                    ]
                }
                _ => vec![
                    Key {
                        time: times[1],
                        translate: base,
                        rotate: None,
                    },
                    Key {
                        time: times[2],
                        translate: base + delta,
                        rotate,
                    },
                ],
            };
        }
        self.notes.push(format!(
            "shutter [{}, {}]; {} moving ({fast} fast, {slow} slow, {turning} turning), {} still",
            num(open),
            num(close),
            moving.len(),
            self.objects.len() - moving.len()
        ));
        self.integrand = "type = \"motion_blur\"\n".into();
    }
}
