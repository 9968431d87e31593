//! Filament's irradiance spherical harmonics in a KTX 1 key/value entry (key `sh`).

use super::{KeyValue, SH_KEY};

/// The `sh` key/value pair: nine lines of "r g b", as `cmgen` writes it (each value the
/// shortest that reads back as the same f32, in exponent form when very small or large; NaN and
/// infinities written as 0).
pub fn sh_key_value(sh: &[[f64; 3]; 9]) -> KeyValue {
    let mut text = String::new();
    for c in sh {
        let f = |v: f64| {
            let v = if v.is_finite() { v as f32 } else { 0.0 };
            if v == 0.0 || (1e-4..1e6).contains(&v.abs()) {
                format!("{v}")
            } else {
                format!("{v:e}")
            }
        };
        text.push_str(&format!("{} {} {}\n", f(c[0]), f(c[1]), f(c[2])));
    }
    KeyValue::text(SH_KEY, &text)
}

/// Parses an `sh` value (27 numbers separated by white space, as Filament's
/// `Ktx1Bundle::getSphericalHarmonics` reads it); None when it does not hold 27 numbers.
pub fn parse_sh(value: &[u8]) -> Option<[[f64; 3]; 9]> {
    let text = std::str::from_utf8(value.strip_suffix(&[0]).unwrap_or(value)).ok()?;
    let numbers: Vec<f64> = text
        .split_whitespace()
        .map(|t| t.parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<_>>()?;
    (numbers.len() == 27)
        .then(|| std::array::from_fn(|i| std::array::from_fn(|c| numbers[3 * i + c])))
}
