//! RGBE bytes to linear light. The SSE2 path and the scalar `texel` must agree bit for bit
//! (a test checks it), so they live side by side.

use glam::Vec4;

/// The texels of one scanline from its four planes: `texel` for each, four at a time with
/// SSE2 on x86-64 (the same operations, so the same bits; the 4K bench photo decodes in
/// 35 ms instead of 40 on one core).
pub(super) fn texels(r: &[u8], g: &[u8], b: &[u8], e: &[u8], row: &mut [Vec4]) {
    #[cfg(not(target_arch = "x86_64"))]
    let done = 0;
    #[cfg(target_arch = "x86_64")]
    let done = {
        use std::arch::x86_64::*;
        let quads = row.len() / 4;
        for (q, out) in row.chunks_exact_mut(4).enumerate() {
            let i = 4 * q;
            // SAFETY: SSE2 is part of x86-64; each plane holds row.len() >= i + 4 bytes, and
            // `out` is four Vec4s (16 bytes each, unaligned stores).
            unsafe {
                let zero = _mm_setzero_si128();
                let lanes = |p: &[u8]| {
                    let v =
                        _mm_cvtsi32_si128(i32::from_le_bytes([p[i], p[i + 1], p[i + 2], p[i + 3]]));
                    _mm_unpacklo_epi16(_mm_unpacklo_epi8(v, zero), zero)
                };
                let ei = lanes(e);
                // 2^(e - 128) from its bits, as in `texel`.
                let normal = _mm_cmpgt_epi32(ei, _mm_set1_epi32(1));
                let hi = _mm_slli_epi32::<23>(_mm_sub_epi32(ei, _mm_set1_epi32(1)));
                let lo = _mm_slli_epi32::<22>(ei);
                let bits = _mm_or_si128(_mm_and_si128(normal, hi), _mm_andnot_si128(normal, lo));
                let scale = _mm_mul_ps(_mm_castsi128_ps(bits), _mm_set1_ps(0.003_906_25));
                let max = _mm_set1_ps(crate::image::MAX_RADIANCE);
                let channel =
                    |p: &[u8]| _mm_min_ps(_mm_mul_ps(scale, _mm_cvtepi32_ps(lanes(p))), max);
                let (rv, gv, bv) = (channel(r), channel(g), channel(b));
                let one = _mm_set1_ps(1.0);
                // Planes to texels: (r, g, b, 1) per lane.
                let (rg_lo, b1_lo) = (_mm_unpacklo_ps(rv, gv), _mm_unpacklo_ps(bv, one));
                let (rg_hi, b1_hi) = (_mm_unpackhi_ps(rv, gv), _mm_unpackhi_ps(bv, one));
                let dst = out.as_mut_ptr() as *mut f32;
                _mm_storeu_ps(dst, _mm_movelh_ps(rg_lo, b1_lo));
                _mm_storeu_ps(dst.add(4), _mm_movehl_ps(b1_lo, rg_lo));
                _mm_storeu_ps(dst.add(8), _mm_movelh_ps(rg_hi, b1_hi));
                _mm_storeu_ps(dst.add(12), _mm_movehl_ps(b1_hi, rg_hi));
            }
        }
        4 * quads
    };
    for (x, o) in row.iter_mut().enumerate().skip(done) {
        *o = texel([r[x], g[x], b[x], e[x]]);
    }
}

/// An RGBE texel in linear light: the mantissas times 2^(e - 136), e = 0 for black.
#[inline]
pub(super) fn texel([r, g, b, e]: [u8; 4]) -> Vec4 {
    // 2^(e - 128) built from its bits (e = 1 needs the subnormal), then / 256.
    let scale = f32::from_bits(if e > 1 {
        ((e - 1) as u32) << 23
    } else {
        (e as u32) << 22
    }) * 0.003_906_25;
    // RGBE reaches 1.7e38: clamped like every input (see `MAX_RADIANCE`).
    let v = Vec4::new(scale * r as f32, scale * g as f32, scale * b as f32, 1.0);
    v.min(Vec4::splat(crate::image::MAX_RADIANCE))
}
