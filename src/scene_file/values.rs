//! Value types with their own checks at deserialization time.

use glam::Vec3;
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;
use std::fmt;
use toml::Spanned;

// Value types with their own checks at deserialization time (the TOML
// deserializer attaches the value's span to their errors).

pub(super) type S<T> = Spanned<T>;

/// A finite number that fits an f32; integers are accepted.
#[derive(Clone, Copy, Debug)]
pub(super) struct Num(pub(super) f32);

impl Num {
    fn finite<E: de::Error>(v: f64) -> Result<Num, E> {
        Num::checked(v).map_err(E::custom)
    }

    /// `v` as a finite f32, or why not (the message of every number key).
    pub(super) fn checked(v: f64) -> Result<Num, String> {
        let x = v as f32;
        if !v.is_finite() {
            // TOML spells them nan, inf, -inf.
            Err(format!(
                "expected a finite number, found {}",
                v.to_string().to_lowercase()
            ))
        } else if !x.is_finite() {
            Err(format!("number {v:e} is out of range"))
        } else {
            Ok(Num(x))
        }
    }
}

impl<'de> Deserialize<'de> for Num {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Num;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Num, E> {
                Num::finite(v)
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Num, E> {
                Num::finite(v as f64)
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Num, E> {
                Num::finite(v as f64)
            }
        }
        d.deserialize_any(V)
    }
}

/// Read a sequence of numbers, counting (not keeping) any beyond `max`.
pub(super) fn numbers<'de, A: SeqAccess<'de>>(
    mut seq: A,
    max: usize,
) -> Result<(Vec<f32>, usize), A::Error> {
    let mut values = Vec::new();
    let mut count = 0;
    while count < max {
        match seq.next_element::<Num>()? {
            Some(Num(x)) => values.push(x),
            None => return Ok((values, count)),
        }
        count += 1;
    }
    while seq.next_element::<de::IgnoredAny>()?.is_some() {
        count += 1;
    }
    Ok((values, count))
}

/// `[x, y, z]`: exactly three finite numbers.
#[derive(Clone, Copy, Debug)]
pub(super) struct V3(pub(super) Vec3);

impl<'de> Deserialize<'de> for V3 {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = V3;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an array of 3 numbers")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<V3, A::Error> {
                match numbers(seq, 3)? {
                    (v, 3) => Ok(V3(Vec3::new(v[0], v[1], v[2]))),
                    (_, n) => Err(de::Error::custom(format!(
                        "expected an array of 3 numbers, found {n} element{}",
                        if n == 1 { "" } else { "s" }
                    ))),
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// `scale = s` or `scale = [sx, sy, sz]`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Scale(pub(super) Vec3);

impl<'de> Deserialize<'de> for Scale {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Scale;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an array of 3 numbers")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Scale, E> {
                Num::finite(v).map(|Num(s)| Scale(Vec3::splat(s)))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Scale, E> {
                self.visit_f64(v as f64)
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Scale, E> {
                self.visit_f64(v as f64)
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Scale, A::Error> {
                V3::deserialize(de::value::SeqAccessDeserializer::new(seq)).map(|v| Scale(v.0))
            }
        }
        d.deserialize_any(V)
    }
}

/// A value whose kind its key decides (an `[mdas]` key: the integrator's
/// registry, `crate::integrator::mdas::PARAMS`, holds the kinds).
#[derive(Clone, Debug)]
pub(super) enum Loose {
    Int(i64),
    Float(f64),
    Str(String),
    /// Anything else, by what it is ("a boolean", "an array", "a table").
    Other(&'static str),
}

impl<'de> Deserialize<'de> for Loose {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Loose;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or a string")
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Loose, E> {
                Ok(Loose::Int(v))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Loose, E> {
                Ok(i64::try_from(v).map_or(Loose::Float(v as f64), Loose::Int))
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Loose, E> {
                Ok(Loose::Float(v))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Loose, E> {
                Ok(Loose::Str(v.to_string()))
            }
            fn visit_bool<E: de::Error>(self, _: bool) -> Result<Loose, E> {
                Ok(Loose::Other("a boolean"))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Loose, A::Error> {
                while seq.next_element::<de::IgnoredAny>()?.is_some() {}
                Ok(Loose::Other("an array"))
            }
            fn visit_map<A: de::MapAccess<'de>>(self, mut map: A) -> Result<Loose, A::Error> {
                while map
                    .next_entry::<de::IgnoredAny, de::IgnoredAny>()?
                    .is_some()
                {}
                Ok(Loose::Other("a table or a date"))
            }
        }
        d.deserialize_any(V)
    }
}

impl Loose {
    /// What it is, for a message.
    pub(super) fn what(&self) -> String {
        match self {
            Loose::Int(i) => format!("integer {i}"),
            Loose::Float(x) => format!("floating point {x}"),
            Loose::Str(s) => format!("string \"{s}\""),
            Loose::Other(what) => (*what).to_string(),
        }
    }
}

/// `[x, y, z]` as a scene file writes it, for messages.
pub(super) fn fmt3(v: Vec3) -> String {
    format!("[{}, {}, {}]", v.x, v.y, v.z)
}
