//! Random scenes nobody tuned (`mdas scene random`): for each integrand a
//! plausible, valid scene file, generated deterministically from a seed.
//!
//! [`random_scene`] returns the TOML text of a scene (format in
//! `docs/scene-format.md`) made for one integrand: a ground (a quad or a
//! heightfield) and 2–40 objects (boxes, spheres, quads, disks,
//! heightfield patches) of sizes spanning 20×, some of them thin (posts,
//! planks, fins), in plain and checkered materials, placed with
//! `transform`s; a camera at a random azimuth, elevation and distance that
//! frames them; a black or coloured background; and the lights that
//! integrand takes (quad area lights large and dim, tiny and bright or in
//! view for `area_light`; point and directional lights, one of them
//! sometimes dominant, for `depth_of_field` and `motion_blur`; a thin lens
//! focused on an object; keyframed motion; area, point and directional
//! lights or a room lit indirectly for `path`; an occlusion radius for
//! `ambient_occlusion`; 16–2000 lights of the many-light list for
//! `many_light`). No `[mdas]` table: MDAS takes `MdasParams::for_film`.
//!
//! **Determinism.** The same (integrand, seed, options) gives the same
//! text, byte for byte, on every machine: the random numbers come from a
//! SplitMix64 stream of this module (not `rand`, whose streams may change
//! between versions), and the few transcendental functions the layout
//! needs ([`dmath`]) are series in `+ − × ÷` and `sqrt` only (IEEE 754
//! rounds these exactly, whereas the platform's `sin` or `exp` may differ
//! in the last bit). Every number is written rounded to 5 decimals.
//! [`GENERATOR_VERSION`], in each file's header, changes whenever the
//! generated text for some seed changes.
//!
//! **Validity.** Coordinates stay within a few 10⁴ units (the format
//! allows ±10⁹), every shape has area, quads are planar by construction
//! (tilted quads are written as symmetric corners about their local
//! origin and placed with `transform`, so rounding cannot bend them), a
//! checkered ground never lies on a checker cell boundary, and the
//! integrand's limits hold (`max_bounces` keeps d ≤ 16, a `many_light`
//! scene has 16–2000 lights). `tests/scene_random.rs` loads every
//! integrand's scenes for many seeds.

use std::fmt::Write as _;
use std::ops::{Add, Mul, Neg, Sub};

mod effects;
mod generate;
mod lights;
mod world;

/// Version of the generator, written into every file's header; bumped
/// whenever the text generated for some (integrand, seed, options)
/// changes.
pub const GENERATOR_VERSION: u32 = 1;

/// The integrand a random scene is made for (its `[integrand] type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum GenIntegrand {
    AreaLight,
    DepthOfField,
    MotionBlur,
    Path,
    AmbientOcclusion,
    ManyLight,
}

impl GenIntegrand {
    pub const ALL: [GenIntegrand; 6] = [
        GenIntegrand::AreaLight,
        GenIntegrand::DepthOfField,
        GenIntegrand::MotionBlur,
        GenIntegrand::Path,
        GenIntegrand::AmbientOcclusion,
        GenIntegrand::ManyLight,
    ];

    /// The scene-format name (`[integrand] type`).
    pub fn name(self) -> &'static str {
        match self {
            GenIntegrand::AreaLight => "area_light",
            GenIntegrand::DepthOfField => "depth_of_field",
            GenIntegrand::MotionBlur => "motion_blur",
            GenIntegrand::Path => "path",
            GenIntegrand::AmbientOcclusion => "ambient_occlusion",
            GenIntegrand::ManyLight => "many_light",
        }
    }

    /// Every name, in the order of [`GenIntegrand::ALL`].
    pub fn names() -> [&'static str; 6] {
        GenIntegrand::ALL.map(GenIntegrand::name)
    }

    fn index(self) -> u64 {
        GenIntegrand::ALL
            .iter()
            .position(|&k| k == self)
            .expect("in ALL") as u64
    }
}

impl std::str::FromStr for GenIntegrand {
    type Err = String;
    fn from_str(s: &str) -> Result<GenIntegrand, String> {
        GenIntegrand::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                format!(
                    "unknown integrand '{s}', expected one of {}",
                    GenIntegrand::names().join(", ")
                )
            })
    }
}

impl std::fmt::Display for GenIntegrand {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// What a random scene is generated for besides its integrand and seed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GenOptions {
    /// `[film] width`, written as given (the loader accepts 1..=16384).
    pub width: u32,
    /// `[film] height`, written as given (the loader accepts 1..=16384).
    pub height: u32,
}

impl Default for GenOptions {
    fn default() -> GenOptions {
        GenOptions {
            width: 128,
            height: 96,
        }
    }
}

/// The TOML text of a random scene for `kind` (see the module docs):
/// the same arguments give the same text. Its header names the generator,
/// the integrand, the seed and the command that regenerates it. The film
/// is `opts`' size; the camera frames the objects at that aspect ratio.
pub fn random_scene(kind: GenIntegrand, seed: u64, opts: &GenOptions) -> String {
    Gen::new(kind, seed, *opts).generate()
}

// ---------------------------------------------------------------------------
// Deterministic numbers.

/// SplitMix64 (Steele, Lea & Flood 2014): a 64-bit state stepped by the
/// golden-ratio increment and finalized by two xor-multiply rounds.
#[derive(Clone, Debug)]
struct Rng(u64);

impl Rng {
    fn new(kind: GenIntegrand, seed: u64) -> Rng {
        // Each integrand its own stream: seed 3 of `path` is not seed 3 of
        // `area_light` with other lights.
        let mut rng = Rng(seed ^ (kind.index() + 1).wrapping_mul(0xD1B5_4A32_D192_ED03));
        rng.next_u64();
        rng
    }

    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1), 53 bits.
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Log-uniform in [lo, hi) (both > 0): every factor of 2 as likely.
    fn log_range(&mut self, lo: f64, hi: f64) -> f64 {
        lo * dmath::exp(self.unit() * dmath::ln(hi / lo))
    }

    /// Uniform integer in lo..=hi.
    fn int(&mut self, lo: u32, hi: u32) -> u32 {
        lo + (self.next_u64() % u64::from(hi - lo + 1)) as u32
    }

    /// Integer in lo..=hi (lo ≥ 1), log-uniformly distributed.
    fn log_int(&mut self, lo: u32, hi: u32) -> u32 {
        (self.log_range(f64::from(lo), f64::from(hi) + 1.0).floor() as u32).clamp(lo, hi)
    }

    fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }

    fn pick<T: Clone>(&mut self, items: &[T]) -> T {
        items[(self.next_u64() % items.len() as u64) as usize].clone()
    }

    fn seed32(&mut self) -> u32 {
        (self.next_u64() >> 32) as u32
    }

    /// A direction at `azimuth` degrees about +y (0 = +z) and `elevation`
    /// degrees above the horizontal.
    fn dir_at(azimuth: f64, elevation: f64) -> V3 {
        let (sa, ca) = dmath::sin_cos_deg(azimuth);
        let (se, ce) = dmath::sin_cos_deg(elevation);
        V3::new(ce * sa, se, ce * ca)
    }

    /// A direction at a random azimuth and an elevation in [lo, hi] degrees.
    fn dir_up(&mut self, lo: f64, hi: f64) -> V3 {
        let azimuth = self.range(0.0, 360.0);
        let elevation = self.range(lo, hi);
        Rng::dir_at(azimuth, elevation)
    }
}

/// Transcendental functions from `+ − × ÷` and `sqrt` only, so that the
/// generated text is the same on every platform (see the module docs).
/// Accurate to a few ulps over the arguments used here.
mod dmath {
    use std::f64::consts::{FRAC_PI_2, LN_2, PI, SQRT_2};

    /// (sin x, cos x), x in radians: reduced to [−π, π], then Taylor series.
    pub fn sin_cos(x: f64) -> (f64, f64) {
        let k = (x / (2.0 * PI)).round();
        let r = x - k * (2.0 * PI);
        let (mut s, mut c) = (0.0, 0.0);
        let mut term = 1.0; // r^n / n!
        for n in 0..40u32 {
            match n % 4 {
                0 => c += term,
                1 => s += term,
                2 => c -= term,
                _ => s -= term,
            }
            term *= r / f64::from(n + 1);
        }
        (s, c)
    }

    pub fn sin_cos_deg(degrees: f64) -> (f64, f64) {
        sin_cos(degrees * (PI / 180.0))
    }

    pub fn tan_deg(degrees: f64) -> f64 {
        let (s, c) = sin_cos_deg(degrees);
        s / c
    }

    /// e^x for |x| < 700: x = k·ln 2 + r with |r| ≤ ln2/2, Taylor series
    /// for e^r, times 2^k built from its bits.
    pub fn exp(x: f64) -> f64 {
        let k = (x / LN_2).round();
        let r = x - k * LN_2;
        let (mut sum, mut term) = (0.0, 1.0);
        for n in 1..30u32 {
            sum += term;
            term *= r / f64::from(n);
        }
        let two_k = f64::from_bits(((1023 + k as i64) as u64) << 52);
        sum * two_k
    }

    /// ln y for a positive, normal y: y = m·2^e with m in [√½, √2), ln m =
    /// 2·atanh((m − 1)/(m + 1)) by its series.
    pub fn ln(y: f64) -> f64 {
        let bits = y.to_bits();
        let mut e = ((bits >> 52) & 0x7ff) as i64 - 1023;
        let mut m = f64::from_bits((bits & ((1u64 << 52) - 1)) | (1023u64 << 52));
        if m > SQRT_2 {
            m /= 2.0;
            e += 1;
        }
        let s = (m - 1.0) / (m + 1.0);
        let s2 = s * s;
        let (mut sum, mut power) = (0.0, s);
        for i in 0..30u32 {
            sum += power / f64::from(2 * i + 1);
            power *= s2;
        }
        2.0 * sum + e as f64 * LN_2
    }

    /// atan x: |x| > 1 through π/2 − atan(1/x), then two argument halvings
    /// atan x = 2·atan(x / (1 + √(1 + x²))) down to |x| ≤ 0.2, then the
    /// series.
    pub fn atan(x: f64) -> f64 {
        if x.abs() > 1.0 {
            return FRAC_PI_2.copysign(x) - atan(1.0 / x);
        }
        let mut r = x;
        for _ in 0..2 {
            r /= 1.0 + (1.0 + r * r).sqrt();
        }
        let r2 = r * r;
        let (mut sum, mut power) = (0.0, r);
        for i in 0..40u32 {
            let term = power / f64::from(2 * i + 1);
            sum += if i % 2 == 0 { term } else { -term };
            power *= r2;
        }
        4.0 * sum
    }

    /// atan2(y, x) in radians, (−π, π].
    pub fn atan2(y: f64, x: f64) -> f64 {
        if x > 0.0 {
            atan(y / x)
        } else if x < 0.0 {
            if y >= 0.0 {
                atan(y / x) + PI
            } else {
                atan(y / x) - PI
            }
        } else if y > 0.0 {
            FRAC_PI_2
        } else if y < 0.0 {
            -FRAC_PI_2
        } else {
            0.0
        }
    }

    pub fn atan2_deg(y: f64, x: f64) -> f64 {
        atan2(y, x) * (180.0 / PI)
    }
}

// ---------------------------------------------------------------------------
// Vectors and text.

#[derive(Clone, Copy, Debug, PartialEq)]
struct V3 {
    x: f64,
    y: f64,
    z: f64,
}

impl V3 {
    const ZERO: V3 = V3::new(0.0, 0.0, 0.0);
    const Y: V3 = V3::new(0.0, 1.0, 0.0);

    const fn new(x: f64, y: f64, z: f64) -> V3 {
        V3 { x, y, z }
    }

    fn splat(v: f64) -> V3 {
        V3::new(v, v, v)
    }

    fn dot(self, o: V3) -> f64 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    fn cross(self, o: V3) -> V3 {
        V3::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }

    fn length(self) -> f64 {
        self.dot(self).sqrt()
    }

    fn normalize(self) -> V3 {
        self * (1.0 / self.length())
    }

    fn max_element(self) -> f64 {
        self.x.max(self.y).max(self.z)
    }
}

impl Add for V3 {
    type Output = V3;
    fn add(self, o: V3) -> V3 {
        V3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl Sub for V3 {
    type Output = V3;
    fn sub(self, o: V3) -> V3 {
        V3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Mul<f64> for V3 {
    type Output = V3;
    fn mul(self, s: f64) -> V3 {
        V3::new(self.x * s, self.y * s, self.z * s)
    }
}

impl Neg for V3 {
    type Output = V3;
    fn neg(self) -> V3 {
        V3::new(-self.x, -self.y, -self.z)
    }
}

/// Rounded to 5 decimals, written without trailing zeros (`1.5`, `-2`,
/// `0.00125`). Rounding is symmetric (half away from zero), so
/// `num(-x) == "-" + num(x)`: symmetric corners stay symmetric.
fn num(x: f64) -> String {
    let r = (x * 1e5).round() / 1e5;
    let mut s = format!("{r:.5}");
    while s.ends_with('0') {
        s.pop();
    }
    if s.ends_with('.') {
        s.pop();
    }
    if s == "-0" {
        s = "0".into();
    }
    s
}

/// Three significant digits, for the header's notes.
fn approx(x: f64) -> String {
    let digits = if x.abs() >= 100.0 {
        0
    } else if x.abs() >= 10.0 {
        1
    } else if x.abs() >= 1.0 {
        2
    } else {
        3
    };
    let scale = [1.0, 10.0, 100.0, 1000.0][digits];
    num((x * scale).round() / scale)
}

fn vec3(v: V3) -> String {
    format!("[{}, {}, {}]", num(v.x), num(v.y), num(v.z))
}

fn corners(c: &[V3; 4]) -> String {
    let parts: Vec<String> = c.iter().map(|&p| vec3(p)).collect();
    format!("[{}]", parts.join(", "))
}

/// `c` in order, or reversed when its normal (c1 − c0) × (c2 − c0) points
/// away from `facing`.
fn quad_facing(c: [V3; 4], facing: V3) -> [V3; 4] {
    if (c[1] - c[0]).cross(c[2] - c[0]).dot(facing) >= 0.0 {
        c
    } else {
        [c[3], c[2], c[1], c[0]]
    }
}

/// A colour with its largest channel 1 and the others in [lo, 1].
fn tint(rng: &mut Rng, lo: f64) -> V3 {
    let mut c = [1.0, rng.range(lo, 1.0), rng.range(lo, 1.0)];
    // Rotate so that any channel may be the full one.
    let k = rng.int(0, 2) as usize;
    c.rotate_left(k);
    V3::new(c[0], c[1], c[2])
}

/// An albedo in [0.05, 0.9]³: a lightness, a saturation and a hue.
fn albedo(rng: &mut Rng) -> V3 {
    let lightness = rng.range(0.08, 0.85);
    let saturation = if rng.chance(0.3) {
        0.0
    } else {
        rng.range(0.1, 0.9)
    };
    let hue = tint(rng, 0.0);
    let c = |h: f64| (lightness * (1.0 - saturation + saturation * h)).clamp(0.05, 0.9);
    V3::new(c(hue.x), c(hue.y), c(hue.z))
}

// ---------------------------------------------------------------------------
// The scene being generated.

struct Material {
    name: String,
    albedo: V3,
    emission: Option<V3>,
    checker: Option<(V3, f64)>,
}

struct Key {
    time: f64,
    translate: V3,
    /// (axis, degrees).
    rotate: Option<(V3, f64)>,
}

struct Shape {
    comment: String,
    kind: &'static str,
    name: String,
    material: String,
    /// The type's own keys, one per line, in local coordinates when
    /// `anchor` is set, else in world coordinates.
    body: String,
    /// World position of the local origin: `transform.translate` of a
    /// static shape, the keyframes' base of a moving one.
    anchor: Option<V3>,
    /// `transform.rotate_y`, degrees (0: none).
    rotate_y: f64,
    /// `transform.scale` (None: 1).
    scale: Option<V3>,
    motion: Vec<Key>,
}

/// An object's place, for framing and lights: world bounding sphere, top,
/// size and whether it may move.
#[derive(Clone, Copy)]
struct Placed {
    shape: usize,
    center: V3,
    radius: f64,
    top: f64,
    size: f64,
    movable: bool,
}

/// The room of a `path` scene: x in [−w, w], z in [−d, d], floor at y0,
/// ceiling at y1, open toward −z.
#[derive(Clone, Copy)]
struct Room {
    w: f64,
    y0: f64,
    y1: f64,
}

struct Camera {
    position: V3,
    look_at: V3,
    fov_y: f64,
    /// tan of the half field of view, vertically and horizontally.
    tan_y: f64,
    tan_x: f64,
    forward: V3,
    right: V3,
    up: V3,
}

impl Camera {
    fn new(position: V3, look_at: V3, fov_y: f64, aspect: f64) -> Camera {
        let forward = (look_at - position).normalize();
        let right = forward.cross(V3::Y).normalize();
        let up = right.cross(forward);
        let tan_y = dmath::tan_deg(fov_y / 2.0);
        Camera {
            position,
            look_at,
            fov_y,
            tan_y,
            tan_x: tan_y * aspect,
            forward,
            right,
            up,
        }
    }

    /// The point at `depth` along the view axis that projects to
    /// normalized device coordinates (nx, ny) ∈ [−1, 1]² (+y up).
    fn at_ndc(&self, nx: f64, ny: f64, depth: f64) -> V3 {
        self.position
            + (self.forward + self.right * (nx * self.tan_x) + self.up * (ny * self.tan_y)) * depth
    }
}

struct Gen {
    kind: GenIntegrand,
    seed: u64,
    opts: GenOptions,
    rng: Rng,
    /// World unit: every length is a multiple of it.
    u: f64,
    /// Radius of the region the objects stand in.
    region: f64,
    ground_y: f64,
    /// Height of the ground's highest point (heightfield ground).
    ground_top: f64,
    materials: Vec<Material>,
    /// Names of the non-emissive materials objects may use.
    palette: Vec<String>,
    shapes: Vec<Shape>,
    objects: Vec<Placed>,
    /// `[[light]]` and `[[light_set]]` tables, in order.
    lights: String,
    light_sets: String,
    integrand: String,
    background: V3,
    camera: Option<Camera>,
    room: Option<Room>,
    aperture: Option<(f64, f64)>,
    shutter: Option<(f64, f64)>,
    /// What the header's summary says.
    notes: Vec<String>,
    emissive_surfaces: bool,
}

/// Corners of a quad of half sizes a (along local x) × b centred on the
/// local origin and tilted so that its normal (c1 − c0) × (c2 − c0) is
/// (0, sin φ, cos φ): (∓a, ∓b·cos φ, ±b·sin φ). Symmetric about the
/// origin, so rounding keeps it planar.
fn tilted_corners(a: f64, b: f64, sin_phi: f64, cos_phi: f64) -> [V3; 4] {
    let (p, q) = (b * cos_phi, b * sin_phi);
    [
        V3::new(-a, -p, q),
        V3::new(a, -p, q),
        V3::new(a, p, -q),
        V3::new(-a, p, -q),
    ]
}

fn round5(x: f64) -> f64 {
    (x * 1e5).round() / 1e5
}

fn write_shape(out: &mut String, s: &Shape) {
    if !s.comment.is_empty() {
        let _ = writeln!(out, "# {}", s.comment);
    }
    let _ = write!(
        out,
        "[[shape]]\ntype = \"{}\"\nname = \"{}\"\nmaterial = \"{}\"\n{}",
        s.kind, s.name, s.material, s.body
    );
    let mut transform = Vec::new();
    if let Some(scale) = s.scale {
        transform.push(format!("scale = {}", vec3(scale)));
    }
    if round5(s.rotate_y) != 0.0 {
        transform.push(format!("rotate_y = {}", num(s.rotate_y)));
    }
    if let (Some(anchor), true) = (s.anchor, s.motion.is_empty()) {
        transform.push(format!("translate = {}", vec3(anchor)));
    }
    if !transform.is_empty() {
        let _ = writeln!(out, "transform = {{ {} }}", transform.join(", "));
    }
    if !s.motion.is_empty() {
        out.push_str("motion = [\n");
        for k in &s.motion {
            let _ = write!(
                out,
                "    {{ time = {}, translate = {}",
                num(k.time),
                vec3(k.translate)
            );
            if let Some((axis, degrees)) = k.rotate {
                let _ = write!(
                    out,
                    ", rotate = [{}, {}, {}, {}]",
                    num(axis.x),
                    num(axis.y),
                    num(axis.z),
                    num(degrees)
                );
            }
            out.push_str(" },\n");
        }
        out.push_str("]\n");
    }
    out.push('\n');
}

#[cfg(test)]
mod tests;
