//! Checked numbers and the defaults of recipe fields. Each check runs inside the visitor, while
//! the parser still stands on the value, so its error points at the value's line (serde_json
//! places an error where it is raised; toml at the value being read).

#![warn(missing_docs)]

use serde::de::{self, Deserializer, Visitor};
use serde::Deserialize;
use std::fmt;

pub(super) fn origin() -> [f32; 2] {
    [0.0, 0.0]
}
pub(super) fn right() -> [f32; 2] {
    [1.0, 0.0]
}
pub(super) fn middle() -> [f32; 2] {
    [0.5, 0.5]
}
pub(super) fn half() -> f32 {
    0.5
}
pub(super) fn one() -> f32 {
    1.0
}
pub(super) fn eight() -> u32 {
    8
}
pub(super) fn eight_cells() -> [u32; 2] {
    [8, 8]
}
pub(super) fn one_octave() -> u32 {
    1
}
pub(super) fn unit_range() -> [f32; 2] {
    [0.0, 1.0]
}

/// Reads any number (integer or float) and passes it through `check`.
pub(super) fn checked<'de, D: Deserializer<'de>>(
    d: D,
    check: impl Fn(f64) -> std::result::Result<f64, String>,
) -> std::result::Result<f64, D::Error> {
    struct V<F>(F);
    impl<F: Fn(f64) -> std::result::Result<f64, String>> Visitor<'_> for V<F> {
        type Value = f64;
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("a number")
        }
        fn visit_f64<E: de::Error>(self, v: f64) -> std::result::Result<f64, E> {
            (self.0)(v).map_err(E::custom)
        }
        fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<f64, E> {
            self.visit_f64(v as f64)
        }
        fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<f64, E> {
            self.visit_f64(v as f64)
        }
    }
    d.deserialize_any(V(check))
}

pub(super) fn check_unit(v: f64) -> std::result::Result<f64, String> {
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "{v} is outside [0, 1]: values, levels and positions are fractions from 0 to 1"
        ))
    }
}

pub(super) fn check_whole(v: f64, max: u32, what: &str) -> std::result::Result<f64, String> {
    if v.fract() == 0.0 && (1.0..=max as f64).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "{v}: {what} must be a whole number from 1 to {max}"
        ))
    }
}

/// A fraction in [0, 1].
struct Unit(f32);

impl<'de> Deserialize<'de> for Unit {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Unit, D::Error> {
        checked(d, check_unit).map(|v| Unit(v as f32))
    }
}

pub(super) fn unit<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<f32, D::Error> {
    Ok(Unit::deserialize(d)?.0)
}

pub(super) fn pair<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<[f32; 2], D::Error> {
    let [a, b] = <[Unit; 2]>::deserialize(d)?;
    Ok([a.0, b.0])
}

pub(super) fn point<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<[f32; 2], D::Error> {
    pair(d)
}

pub(super) fn ranged<'de, D: Deserializer<'de>>(
    d: D,
    ok: impl Fn(f64) -> bool,
    what: &str,
) -> std::result::Result<f32, D::Error> {
    checked(d, |v| {
        if ok(v) {
            Ok(v)
        } else {
            Err(format!("{v}: {what}"))
        }
    })
    .map(|v| v as f32)
}

pub(super) fn radius<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<f32, D::Error> {
    ranged(
        d,
        |v| v > 0.0 && v <= 2.0,
        "the radius must be above 0 and at most 2 (a fraction of the image)",
    )
}

pub(super) fn gamma<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<f32, D::Error> {
    ranged(
        d,
        |v| v > 0.0 && v <= 10.0,
        "gamma must be above 0 and at most 10",
    )
}

pub(super) fn angle<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<f32, D::Error> {
    ranged(
        d,
        f64::is_finite,
        "the angle must be a finite number of degrees",
    )
}

pub(super) fn lod_bias<'de, D: Deserializer<'de>>(
    d: D,
) -> std::result::Result<Option<f32>, D::Error> {
    ranged(
        d,
        |v| (0.0..=16.0).contains(&v),
        "max_lod_bias must be from 0 to 16 (mip levels)",
    )
    .map(Some)
}

pub(super) fn count<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<u32, D::Error> {
    checked(d, |v| check_whole(v, 4096, "the stripe count")).map(|v| v as u32)
}

pub(super) fn octaves<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<u32, D::Error> {
    checked(d, |v| check_whole(v, 12, "octaves")).map(|v| v as u32)
}

/// Cells across and down, each 1 to 65536.
struct Cells(u32);

impl<'de> Deserialize<'de> for Cells {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Cells, D::Error> {
        checked(d, |v| check_whole(v, 65536, "a cell count")).map(|v| Cells(v as u32))
    }
}

pub(super) fn cells<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<[u32; 2], D::Error> {
    let [a, b] = <[Cells; 2]>::deserialize(d)?;
    Ok([a.0, b.0])
}

pub(super) fn some_unit<'de, D: Deserializer<'de>>(
    d: D,
) -> std::result::Result<Option<f32>, D::Error> {
    unit(d).map(Some)
}
