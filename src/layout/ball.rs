//! What mirror balls and angular maps share: a disc in a square, its corners outside the
//! sphere. Where a point may be looked up or located near the rim, the disc's part of a
//! texel, and the solid angle of a texel the rim may cut.

use glam::Vec2;

/// The largest distance from the centre (in disc radii) at which a ball `size` texels across
/// is looked up or located: half a texel inside the rim, so the texel a point names always
/// covers some of the sphere and the dark outside never bleeds in.
#[inline]
pub(crate) fn rim(size: usize) -> f32 {
    1.0 - 1.0 / size as f32
}

/// Normalised image coordinates `uv` of a ball `size` texels across, moved in onto
/// [`rim`] when they lie beyond it.
#[inline]
pub(crate) fn inside_rim(uv: Vec2, size: usize) -> Vec2 {
    let c = uv * 2.0 - Vec2::ONE;
    let max = rim(size);
    let len = c.length();
    if len > max {
        (c * (max / len) + Vec2::ONE) * 0.5
    } else {
        uv
    }
}

/// The distance from the centre (in disc radii) of continuous texel coordinates (x, y) of a
/// w x h ball, and a texel's area in disc radii squared; None outside the disc.
#[inline(always)]
pub(crate) fn radius_and_area(w: usize, h: usize, x: f32, y: f32) -> Option<(f32, f32)> {
    let (iw, ih) = (1.0 / w as f32, 1.0 / h as f32);
    let (sx, sy) = (2.0 * x * iw - 1.0, 2.0 * y * ih - 1.0);
    let r = (sx * sx + sy * sy).sqrt();
    if r > 1.0 {
        return None;
    }
    // Texel area in units of the disc radius squared.
    let area = 4.0 * iw * ih;
    Some((r, area))
}

/// Solid angle of texel (x, y) of a w x h ball whose solid angle per unit texel area is
/// `density`: a midpoint sum, 4 x 4 inside the disc, 16 x 16 on the rim, where the disc cuts
/// texels.
pub(crate) fn texel_solid_angle(
    w: usize,
    h: usize,
    x: usize,
    y: usize,
    density: impl Fn(f32, f32) -> f32,
) -> f64 {
    let corner_in = |cx: usize, cy: usize| {
        let sx = 2.0 * cx as f64 / w as f64 - 1.0;
        let sy = 2.0 * cy as f64 / h as f64 - 1.0;
        sx * sx + sy * sy < 1.0
    };
    let inside =
        corner_in(x, y) && corner_in(x + 1, y) && corner_in(x, y + 1) && corner_in(x + 1, y + 1);
    let k = if inside { 4 } else { 16 };
    let mut sum = 0.0f64;
    for j in 0..k {
        for i in 0..k {
            let px = x as f32 + (i as f32 + 0.5) / k as f32;
            let py = y as f32 + (j as f32 + 0.5) / k as f32;
            sum += density(px, py) as f64;
        }
    }
    sum / (k * k) as f64
}
