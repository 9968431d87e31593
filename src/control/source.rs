//! Sources: where a parameter's values come from (a constant, an image channel, a pattern) and
//! the operations on them (remap, invert, multiply, mix), read from a number or a table and
//! evaluated to a plane of values.

#![warn(missing_docs)]

use super::image::{ImageChannel, ImageFile};
use super::numbers::{check_unit, gamma, one, pair, some_unit, unit_range};
use super::pattern::{Checker, LinearGradient, Noise, RadialGradient, Stripes};
use rayon::prelude::*;
use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::Deserialize;
use std::fmt;

/// Where a parameter's values come from, and what is done to them.
#[derive(Clone, Debug)]
pub struct Source {
    /// Where the values come from.
    pub kind: Kind,
    /// Levels, applied first.
    pub remap: Option<Remap>,
    /// `1 - v`, after the remap.
    pub invert: bool,
    /// Multiplied in after inverting.
    pub multiply: Option<Box<Source>>,
    /// Blended in last.
    pub mix: Option<Box<Mix>>,
}

/// The kinds of source.
#[derive(Clone, Debug)]
pub enum Kind {
    /// The same value everywhere, in [0, 1].
    Constant(f32),
    /// One channel of an image file, resized to the output.
    Image(ImageChannel),
    /// `linear_gradient`.
    LinearGradient(LinearGradient),
    /// `radial_gradient`.
    RadialGradient(RadialGradient),
    /// `checker`.
    Checker(Checker),
    /// `stripes`.
    Stripes(Stripes),
    /// `noise`.
    Noise(Noise),
}

/// Levels: input range, output range, gamma.
#[derive(Clone, Debug, Deserialize)]
#[serde(try_from = "RawRemap")]
pub struct Remap {
    /// The levels that become 0 and 1 (`in`); values outside are clamped. Never equal.
    pub input: [f32; 2],
    /// What 0 and 1 then become (`out`).
    pub output: [f32; 2],
    /// `t^(1/gamma)` between the two: above 1 brightens, like the middle slider of Levels.
    pub gamma: f32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRemap {
    #[serde(rename = "in", default = "unit_range", deserialize_with = "pair")]
    input: [f32; 2],
    #[serde(rename = "out", default = "unit_range", deserialize_with = "pair")]
    output: [f32; 2],
    #[serde(default = "one", deserialize_with = "gamma")]
    gamma: f32,
}

impl TryFrom<RawRemap> for Remap {
    type Error = String;
    fn try_from(r: RawRemap) -> std::result::Result<Remap, String> {
        if r.input[0] == r.input[1] {
            return Err(format!(
                "remap: `in` needs two different levels, not {} and {}",
                r.input[0], r.input[1]
            ));
        }
        Ok(Remap {
            input: r.input,
            output: r.output,
            gamma: r.gamma,
        })
    }
}

impl Remap {
    /// Levels applied to one value.
    #[inline]
    pub(crate) fn apply(&self, v: f32) -> f32 {
        let [i0, i1] = self.input;
        let [o0, o1] = self.output;
        let mut t = ((v - i0) / (i1 - i0)).clamp(0.0, 1.0);
        if self.gamma != 1.0 {
            t = t.powf(1.0 / self.gamma);
        }
        o0 * (1.0 - t) + o1 * t
    }
}

/// `v * (1 - amount) + with * amount`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mix {
    /// What is blended in.
    pub with: Source,
    /// How much of it, per texel: 0 keeps the value, 1 replaces it.
    pub amount: Source,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSource {
    #[serde(default, deserialize_with = "some_unit")]
    constant: Option<f32>,
    image: Option<ImageChannel>,
    linear_gradient: Option<LinearGradient>,
    radial_gradient: Option<RadialGradient>,
    checker: Option<Checker>,
    stripes: Option<Stripes>,
    noise: Option<Noise>,
    remap: Option<Remap>,
    #[serde(default)]
    invert: bool,
    multiply: Option<Box<Source>>,
    mix: Option<Box<Mix>>,
}

const KINDS: &str = "constant, image, linear_gradient, radial_gradient, checker, stripes or noise";

impl TryFrom<RawSource> for Source {
    type Error = String;
    fn try_from(r: RawSource) -> std::result::Result<Source, String> {
        let mut kinds: Vec<(&str, Kind)> = Vec::new();
        if let Some(v) = r.constant {
            kinds.push(("constant", Kind::Constant(v)));
        }
        if let Some(v) = r.image {
            kinds.push(("image", Kind::Image(v)));
        }
        if let Some(v) = r.linear_gradient {
            kinds.push(("linear_gradient", Kind::LinearGradient(v)));
        }
        if let Some(v) = r.radial_gradient {
            kinds.push(("radial_gradient", Kind::RadialGradient(v)));
        }
        if let Some(v) = r.checker {
            kinds.push(("checker", Kind::Checker(v)));
        }
        if let Some(v) = r.stripes {
            kinds.push(("stripes", Kind::Stripes(v)));
        }
        if let Some(v) = r.noise {
            kinds.push(("noise", Kind::Noise(v)));
        }
        if kinds.len() != 1 {
            let names: Vec<&str> = kinds.iter().map(|(n, _)| *n).collect();
            return Err(if names.is_empty() {
                format!("a source needs one of {KINDS}")
            } else {
                format!(
                    "a source has exactly one of {KINDS}, but this one has {}",
                    names.join(" and ")
                )
            });
        }
        if let Kind::LinearGradient(g) = &kinds[0].1 {
            if g.from == g.to {
                return Err("linear_gradient: `from` and `to` are the same point".into());
            }
        }
        Ok(Source {
            kind: kinds.pop().map(|(_, k)| k).unwrap_or(Kind::Constant(0.0)),
            remap: r.remap,
            invert: r.invert,
            multiply: r.multiply,
            mix: r.mix,
        })
    }
}

impl<'de> Deserialize<'de> for Source {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Source, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Source;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                write!(f, "a number from 0 to 1, or a table with one of {KINDS}")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> std::result::Result<Source, E> {
                check_unit(v)
                    .map(|v| Source::constant(v as f32))
                    .map_err(E::custom)
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<Source, E> {
                self.visit_f64(v as f64)
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<Source, E> {
                self.visit_f64(v as f64)
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> std::result::Result<Source, A::Error> {
                let raw = RawSource::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Source::try_from(raw).map_err(de::Error::custom)
            }
        }
        d.deserialize_any(V)
    }
}

impl Source {
    /// A constant with no operations.
    pub(crate) fn constant(v: f32) -> Source {
        Source {
            kind: Kind::Constant(v),
            remap: None,
            invert: false,
            multiply: None,
            mix: None,
        }
    }

    pub(super) fn first_image(&self) -> Option<&ImageFile> {
        let mut v = Vec::new();
        self.images(&mut v);
        v.into_iter().next()
    }

    pub(super) fn images<'a>(&'a self, out: &mut Vec<&'a ImageFile>) {
        if let Kind::Image(i) = &self.kind {
            out.push(&i.path);
        }
        if let Some(m) = &self.multiply {
            m.images(out);
        }
        if let Some(m) = &self.mix {
            m.with.images(out);
            m.amount.images(out);
        }
    }

    /// The values at `width` x `height`, rows top to bottom, each in [0, 1].
    pub(crate) fn eval(&self, width: usize, height: usize) -> Vec<f32> {
        let mut v = match &self.kind {
            Kind::Constant(c) => vec![*c; width * height],
            Kind::Image(i) => i.eval(width, height),
            Kind::LinearGradient(g) => g.eval(width, height),
            Kind::RadialGradient(g) => g.eval(width, height),
            Kind::Checker(c) => c.eval(width, height),
            Kind::Stripes(s) => s.eval(width, height),
            Kind::Noise(n) => n.eval(width, height),
        };
        if let Some(r) = &self.remap {
            v.par_iter_mut().for_each(|x| *x = r.apply(*x));
        }
        if self.invert {
            v.par_iter_mut().for_each(|x| *x = 1.0 - *x);
        }
        if let Some(m) = &self.multiply {
            let o = m.eval(width, height);
            v.par_iter_mut().zip(o).for_each(|(x, o)| *x *= o);
        }
        if let Some(m) = &self.mix {
            let with = m.with.eval(width, height);
            let amount = m.amount.eval(width, height);
            v.par_iter_mut()
                .zip(with)
                .zip(amount)
                .for_each(|((x, b), t)| *x = *x * (1.0 - t) + b * t);
        }
        v
    }

    /// One line saying where the values come from and what is done to them.
    pub(crate) fn describe(&self) -> String {
        let mut s = match &self.kind {
            Kind::Constant(c) => format!("{c}"),
            Kind::Image(i) => format!(
                "{} of {}{}",
                i.channel.name(),
                i.path.name,
                if i.srgb && !i.path.float {
                    " (sRGB decoded)"
                } else if i.srgb {
                    " (float data: srgb ignored)"
                } else {
                    ""
                }
            ),
            Kind::LinearGradient(g) => format!(
                "linear gradient ({}, {}) to ({}, {})",
                g.from[0], g.from[1], g.to[0], g.to[1]
            ),
            Kind::RadialGradient(g) => format!(
                "radial gradient at ({}, {}), radius {}",
                g.center[0], g.center[1], g.radius
            ),
            Kind::Checker(c) => format!("checker {}x{} cells", c.cells[0], c.cells[1]),
            Kind::Stripes(st) => format!(
                "stripes, count {} at {} deg, width {}{}",
                st.count,
                st.angle,
                st.width,
                if st.offset != 0.0 {
                    format!(", offset {}", st.offset)
                } else {
                    String::new()
                }
            ),
            Kind::Noise(n) => format!(
                "noise {}x{} cells, seed {}{}",
                n.cells[0],
                n.cells[1],
                n.seed,
                if n.octaves > 1 {
                    format!(", {} octaves x {}", n.octaves, n.persistence)
                } else {
                    String::new()
                }
            ),
        };
        if let Some(r) = &self.remap {
            s += &format!(
                ", remapped {}..{} to {}..{}",
                r.input[0], r.input[1], r.output[0], r.output[1]
            );
            if r.gamma != 1.0 {
                s += &format!(" gamma {}", r.gamma);
            }
        }
        if self.invert {
            s += ", inverted";
        }
        if let Some(m) = &self.multiply {
            s += &format!(", times [{}]", m.describe());
        }
        if let Some(m) = &self.mix {
            s += &format!(
                ", mixed with [{}] by [{}]",
                m.with.describe(),
                m.amount.describe()
            );
        }
        s
    }
}
