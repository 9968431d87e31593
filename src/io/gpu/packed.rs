//! The packed HDR number formats E5B9G9R9 (shared exponent) and B10G11R11 (unsigned floats),
//! after the Vulkan specification's conversion rules.

use super::RGB9E5_MAX;
use glam::Vec4;

/// `v` clamped to [0, max], NaN to 0: what the unsigned float formats store.
#[inline]
pub(super) fn unsigned(v: f32, max: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, max)
    }
}

/// An unsigned float with a 5-bit exponent (bias 15) and `mbits` of mantissa, rounded to
/// nearest: bits = exponent << mbits | mantissa. A mantissa that rounds up to 2^mbits carries
/// into the exponent, which is the right next value.
pub(super) fn pack_ufloat(v: f32, mbits: u32, max: f32) -> u32 {
    let v = unsigned(v, max) as f64;
    if v < f64::powi(2.0, -14) {
        // Denormal: exponent field 0, value = m * 2^(-14 - mbits).
        return (v * f64::powi(2.0, 14 + mbits as i32)).round() as u32;
    }
    let e = v.log2().floor() as i32;
    // log2 may land one off right at a power of two.
    let e = if f64::powi(2.0, e) > v {
        e - 1
    } else if f64::powi(2.0, e + 1) <= v {
        e + 1
    } else {
        e
    };
    let m = ((v / f64::powi(2.0, e) - 1.0) * f64::from(1u32 << mbits)).round() as u32;
    (((e + 15) as u32) << mbits) + m
}

/// The value of an unsigned float's bits (see [`pack_ufloat`]); exponent 31 is infinity or
/// NaN, as in half floats.
pub(super) fn unpack_ufloat(bits: u32, mbits: u32) -> f32 {
    let e = (bits >> mbits) as i32;
    let m = (bits & ((1 << mbits) - 1)) as f32;
    let scale = (1u32 << mbits) as f32;
    match e {
        0 => m / scale * f32::powi(2.0, -14),
        31 if m == 0.0 => f32::INFINITY,
        31 => f32::NAN,
        _ => (1.0 + m / scale) * f32::powi(2.0, e - 15),
    }
}

/// Packs RGB into E5B9G9R9 as the Vulkan specification's conversion does: the exponent from
/// the largest channel, each mantissa rounded to nearest.
pub(super) fn pack_rgb9e5(p: Vec4) -> u32 {
    const N: i32 = 9;
    const B: i32 = 15;
    let c = [p.x, p.y, p.z].map(|v| unsigned(v, RGB9E5_MAX) as f64);
    let max = c[0].max(c[1]).max(c[2]);
    if max == 0.0 {
        return 0;
    }
    let floor_log2 = {
        let e = max.log2().floor() as i32;
        if f64::powi(2.0, e) > max {
            e - 1
        } else if f64::powi(2.0, e + 1) <= max {
            e + 1
        } else {
            e
        }
    };
    let mut exp = floor_log2.max(-B - 1) + 1 + B;
    let maxm = (max / f64::powi(2.0, exp - B - N) + 0.5).floor() as i32;
    if maxm == 1 << N {
        exp += 1;
    }
    let scale = f64::powi(2.0, exp - B - N);
    let m = c.map(|v| ((v / scale + 0.5).floor() as u32).min(511));
    m[0] | (m[1] << 9) | (m[2] << 18) | ((exp as u32) << 27)
}

pub(super) fn unpack_rgb9e5(w: u32) -> Vec4 {
    let scale = f32::powi(2.0, (w >> 27) as i32 - 15 - 9);
    Vec4::new(
        (w & 0x1FF) as f32 * scale,
        ((w >> 9) & 0x1FF) as f32 * scale,
        ((w >> 18) & 0x1FF) as f32 * scale,
        1.0,
    )
}

#[cfg(test)]
mod tests {
    use super::super::{UF10_MAX, UF11_MAX};
    use super::*;

    #[test]
    fn packed_floats_match_the_spec_values() {
        // 1.0: exponent 15, mantissa 0.
        assert_eq!(pack_ufloat(1.0, 6, UF11_MAX), 15 << 6);
        assert_eq!(pack_ufloat(1.0, 5, UF10_MAX), 15 << 5);
        assert_eq!(unpack_ufloat(15 << 6, 6), 1.0);
        // Largest values and clamping.
        assert_eq!(pack_ufloat(1e9, 6, UF11_MAX), (30 << 6) | 63);
        assert_eq!(unpack_ufloat((30 << 6) | 63, 6), UF11_MAX);
        assert_eq!(unpack_ufloat((30 << 5) | 31, 5), UF10_MAX);
        assert_eq!(pack_ufloat(-3.0, 6, UF11_MAX), 0);
        assert_eq!(pack_ufloat(f32::NAN, 6, UF11_MAX), 0);
        // Smallest denormal and a mantissa that carries.
        let tiny = f32::powi(2.0, -20);
        assert_eq!(pack_ufloat(tiny, 6, UF11_MAX), 1);
        assert_eq!(unpack_ufloat(1, 6), tiny);
        assert_eq!(pack_ufloat(1.999, 6, UF11_MAX), 16 << 6);
        // Every 11-bit value round-trips.
        for bits in 0..(31 << 6) {
            assert_eq!(pack_ufloat(unpack_ufloat(bits, 6), 6, UF11_MAX), bits);
        }
        for bits in 0..(31 << 5) {
            assert_eq!(pack_ufloat(unpack_ufloat(bits, 5), 5, UF10_MAX), bits);
        }
    }

    #[test]
    fn shared_exponent_matches_the_spec_values() {
        // 1.0 = 256 * 2^(16 - 15 - 9).
        let w = pack_rgb9e5(Vec4::new(1.0, 0.5, 0.0, 1.0));
        assert_eq!(w >> 27, 16);
        assert_eq!(w & 0x1FF, 256);
        assert_eq!((w >> 9) & 0x1FF, 128);
        assert_eq!(unpack_rgb9e5(w), Vec4::new(1.0, 0.5, 0.0, 1.0));
        assert_eq!(pack_rgb9e5(Vec4::ZERO), 0);
        let max = unpack_rgb9e5(pack_rgb9e5(Vec4::splat(1e9)));
        assert_eq!(max.x, RGB9E5_MAX);
        assert_eq!(pack_rgb9e5(Vec4::new(-1.0, f32::NAN, 0.0, 1.0)), 0);
        // Relative error within half a unit of the 9-bit mantissa of the largest channel.
        for v in [0.001f32, 0.3, 7.7, 123.4, 5000.0, 60000.0] {
            let d = unpack_rgb9e5(pack_rgb9e5(Vec4::new(v, v * 0.5, v * 0.25, 1.0)));
            assert!((d.x - v).abs() <= v / 512.0, "{v} -> {}", d.x);
        }
    }
}
