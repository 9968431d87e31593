//! The window sum written in AVX2 and FMA intrinsics: the portable loop in `sum.rs` was
//! vectorised by the compiler only while its accumulators happened to suit it (with the
//! weight total gone from them, it packed the four channels of one lane instead and ran the
//! GGX 256 chain's hybrid core four times slower, issue 45). The same operations in the same
//! order as the portable loop, lane by lane, so both give the same bits.

use super::super::{Shape, Window, MAX_DEGREE};
use super::{Candidates, LANES};
use glam::{Vec3, Vec4};
use std::arch::x86_64::*;

/// [`Candidates::mean`]'s sum, before the lobe's norm.
///
/// # Safety
/// The CPU must have AVX, AVX2 and FMA.
#[target_feature(enable = "avx,avx2,fma")]
pub(super) unsafe fn sum(c: &Candidates, window: &Window, n: Vec3) -> Vec4 {
    let cut = _mm256_set1_ps(window.u_cut);
    let (nx, ny, nz) = (
        _mm256_set1_ps(n.x),
        _mm256_set1_ps(n.y),
        _mm256_set1_ps(n.z),
    );
    let half = _mm256_set1_ps(0.5);
    let mut acc = [_mm256_setzero_ps(); 4];
    // One loop per shape, the weight's formula written into it.
    macro_rules! run {
        (|$u:ident| $weight:expr) => {
            for o in &c.octs {
                let dx = _mm256_sub_ps(nx, _mm256_load_ps(o.x.as_ptr()));
                let dy = _mm256_sub_ps(ny, _mm256_load_ps(o.y.as_ptr()));
                let dz = _mm256_sub_ps(nz, _mm256_load_ps(o.z.as_ptr()));
                let sq = _mm256_fmadd_ps(dy, dy, _mm256_mul_ps(dz, dz));
                let $u = _mm256_mul_ps(_mm256_fmadd_ps(dx, dx, sq), half);
                let w: __m256 = $weight;
                let within = _mm256_cmp_ps::<_CMP_LE_OQ>($u, cut);
                let w = _mm256_mul_ps(_mm256_and_ps(within, w), _mm256_load_ps(o.sa.as_ptr()));
                acc[0] = _mm256_fmadd_ps(w, _mm256_load_ps(o.r.as_ptr()), acc[0]);
                acc[1] = _mm256_fmadd_ps(w, _mm256_load_ps(o.g.as_ptr()), acc[1]);
                acc[2] = _mm256_fmadd_ps(w, _mm256_load_ps(o.b.as_ptr()), acc[2]);
                acc[3] = _mm256_fmadd_ps(w, _mm256_load_ps(o.a.as_ptr()), acc[3]);
            }
        };
    }
    match window.shape {
        Shape::Exp2 { q } => {
            let q = q.map(|v| _mm256_set1_ps(v));
            run!(|u| {
                let mut p = q[MAX_DEGREE];
                for &k in q[..MAX_DEGREE].iter().rev() {
                    p = _mm256_fmadd_ps(p, u, k);
                }
                exp2_small(_mm256_mul_ps(u, p))
            })
        }
        Shape::Ggx { a2, h } => {
            let (a2, h, one) = (_mm256_set1_ps(a2), _mm256_set1_ps(h), _mm256_set1_ps(1.0));
            run!(|u| {
                let r = _mm256_div_ps(a2, _mm256_fmadd_ps(h, u, a2));
                _mm256_mul_ps(_mm256_sub_ps(one, u), _mm256_mul_ps(r, r))
            })
        }
        Shape::Table { scale } => {
            let table = &window.table;
            let last = table.len() - 2;
            let (scale, zero, one) = (
                _mm256_set1_ps(scale),
                _mm256_setzero_ps(),
                _mm256_set1_ps(1.0),
            );
            let last_f = _mm256_set1_ps(last as f32);
            let base = table.as_ptr();
            run!(|u| {
                // t = max(u scale, 0); i = min(trunc t, last); f = min(t - i, 1).
                let t = _mm256_max_ps(_mm256_mul_ps(u, scale), zero);
                let i = _mm256_cvttps_epi32(_mm256_min_ps(t, last_f));
                let f = _mm256_min_ps(_mm256_sub_ps(t, _mm256_cvtepi32_ps(i)), one);
                let lo = _mm256_i32gather_ps::<4>(base, i);
                let hi = _mm256_i32gather_ps::<4>(base.add(1), i);
                _mm256_fmadd_ps(f, _mm256_sub_ps(hi, lo), lo)
            })
        }
    }
    let mut lanes = [[0.0f32; LANES]; 4];
    for (dst, v) in lanes.iter_mut().zip(acc) {
        _mm256_storeu_ps(dst.as_mut_ptr(), v);
    }
    let total =
        |v: &[f32; LANES]| ((v[0] + v[4]) + (v[2] + v[6])) + ((v[1] + v[5]) + (v[3] + v[7]));
    Vec4::new(
        total(&lanes[0]),
        total(&lanes[1]),
        total(&lanes[2]),
        total(&lanes[3]),
    )
}

/// `sum::exp2_small` on eight lanes.
#[inline]
#[target_feature(enable = "avx,avx2,fma")]
fn exp2_small(x: __m256) -> __m256 {
    const MAGIC: f32 = 12_582_912.0;
    const C: [f32; 6] = super::EXP2_POLY;
    let magic = _mm256_set1_ps(MAGIC);
    let shifted = _mm256_add_ps(x, magic);
    let k = _mm256_sub_ps(shifted, magic);
    let f = _mm256_sub_ps(x, k);
    let mut p = _mm256_set1_ps(C[0]);
    for &c in &C[1..] {
        p = _mm256_fmadd_ps(p, f, _mm256_set1_ps(c));
    }
    let k_bits = _mm256_sub_epi32(
        _mm256_castps_si256(shifted),
        _mm256_set1_epi32(MAGIC.to_bits() as i32),
    );
    let pow = _mm256_slli_epi32::<23>(_mm256_add_epi32(k_bits, _mm256_set1_epi32(127)));
    _mm256_mul_ps(p, _mm256_castsi256_ps(pow))
}

#[cfg(test)]
mod tests {
    use super::super::super::{Lobe, Window};
    use super::super::Candidates;
    use glam::{Vec3, Vec4};

    /// The intrinsics give the portable loop's bits for every shape: a polynomial (cosine),
    /// GGX's own form and a table (Charlie), on candidates spread around the axis.
    #[test]
    fn intrinsics_match_the_portable_sum() {
        if !crate::simd::avx2_available() {
            return;
        }
        let windows = [
            Window::plan(Lobe::CosinePower { power: 200.0 }, 64, 7).expect("cosine window"),
            Window::core(Lobe::Ggx { alpha: 0.05 }, 0.1, 0.2, 64, 7).expect("ggx core"),
            Window::whole(Lobe::Charlie { alpha: 0.3 }, 16, 5, 8, 1e12).expect("charlie whole"),
        ];
        let mut c = Candidates::default();
        // 37 candidates: four octs and a partial one, up to 2 radians from the axis.
        for i in 0..37u32 {
            let t = i as f32 * 0.055;
            let p = i as f32 * 2.4;
            let d = Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
            let v = Vec4::new(1.0 + i as f32, 0.5 * i as f32, 3.0 / (1.0 + i as f32), 1.0);
            c.push(d, 1e-3 * (1.0 + (i % 5) as f32), v);
        }
        for w in &windows {
            for n in [Vec3::Z, Vec3::new(0.1, 0.05, 1.0).normalize()] {
                // SAFETY: checked above that the CPU has AVX2 and FMA.
                let fast = unsafe { super::sum(&c, w, n) };
                let slow = c.portable_sum(w, n);
                assert_eq!(
                    fast.to_array().map(f32::to_bits),
                    slow.to_array().map(f32::to_bits)
                );
                assert!(slow.w > 0.0, "the candidates reach the lobe");
            }
        }
    }
}
