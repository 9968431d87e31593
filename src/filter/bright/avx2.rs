//! [`BrightSum::at`] for eight output texels at once, a texel to an AVX lane: each texel's sum
//! takes the same operations in the same order as the four-lane loop (one accumulator per
//! member lane, masked where a patch is out of a texel's reach), so the bits are the same,
//! while the eight share each member's loads and the lobe's division runs eight wide.

use super::BrightSum;
use glam::Vec3;
use std::arch::x86_64::*;
use std::f32::consts::PI;

/// The bright part of a GGX lobe of `alpha` at each of `ns` (1 to 8 unit directions).
///
/// # Safety
/// The CPU must have AVX and AVX2.
#[target_feature(enable = "avx,avx2")]
#[allow(clippy::needless_range_loop)] // one lane index into the quad's six vectors and `acc`
pub(super) unsafe fn ggx_at8(s: &BrightSum, alpha: f32, ns: &[Vec3], out: &mut [Vec3]) {
    let k = ns.len().min(8);
    // Lanes past `k` repeat the last direction; their sums are never read.
    let at = |i: usize| ns[i.min(k - 1)];
    let xs: [f32; 8] = std::array::from_fn(|i| at(i).x);
    let ys: [f32; 8] = std::array::from_fn(|i| at(i).y);
    let zs: [f32; 8] = std::array::from_fn(|i| at(i).z);
    let (nx, ny, nz) = (
        _mm256_loadu_ps(xs.as_ptr()),
        _mm256_loadu_ps(ys.as_ptr()),
        _mm256_loadu_ps(zs.as_ptr()),
    );
    use std::arch::x86_64::_mm256_set1_ps as set;
    // n.dot(a), as glam's Vec3::dot: (x x' + y y') + z z'.
    macro_rules! dot {
        ($ax:expr, $ay:expr, $az:expr) => {
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(nx, $ax), _mm256_mul_ps(ny, $ay)),
                _mm256_mul_ps(nz, $az),
            )
        };
    }
    // `at` goes on where !(dot <= limit): NaN included.
    let (all_axis, all_limit) = s.all;
    let inside = _mm256_cmp_ps::<_CMP_NLE_UQ>(
        dot!(set(all_axis.x), set(all_axis.y), set(all_axis.z)),
        set(all_limit),
    );
    let live = (1i32 << k) - 1;
    if _mm256_movemask_ps(inside) & live == 0 {
        out[..k].fill(Vec3::ZERO);
        return;
    }
    let a2 = alpha * alpha;
    let (va2, am1, one, half, pi, zero) = (
        set(a2),
        set(a2 - 1.0),
        set(1.0),
        set(0.5),
        set(PI),
        _mm256_setzero_ps(),
    );
    // acc[channel][member lane], eight texels each.
    let mut acc = [[zero; 4]; 3];
    for (axis, limit, quads) in &s.patches {
        let reach = _mm256_and_ps(
            inside,
            _mm256_cmp_ps::<_CMP_NLE_UQ>(dot!(set(axis.x), set(axis.y), set(axis.z)), set(*limit)),
        );
        let bits = _mm256_movemask_ps(reach);
        if bits & live == 0 {
            continue;
        }
        let every = bits == 0xff;
        for q in quads {
            for l in 0..4 {
                let c = dot!(set(q.x[l]), set(q.y[l]), set(q.z[l]));
                // The weights of `BrightSum::weights`, operation for operation.
                let nh2 = _mm256_mul_ps(_mm256_add_ps(c, one), half);
                let d = _mm256_add_ps(_mm256_mul_ps(nh2, am1), one);
                let w = _mm256_mul_ps(
                    _mm256_div_ps(va2, _mm256_mul_ps(_mm256_mul_ps(d, d), pi)),
                    c,
                );
                let w = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(w, zero), w);
                for (ch, v) in [q.r[l], q.g[l], q.b[l]].into_iter().enumerate() {
                    let sum = _mm256_add_ps(acc[ch][l], _mm256_mul_ps(w, set(v)));
                    acc[ch][l] = if every {
                        sum
                    } else {
                        _mm256_blendv_ps(acc[ch][l], sum, reach)
                    };
                }
            }
        }
    }
    // The lanes added as `at` adds them: (0 + 2) + (1 + 3).
    let mut t = [[0.0f32; 8]; 3];
    for (ch, a) in acc.iter().enumerate() {
        let v = _mm256_add_ps(_mm256_add_ps(a[0], a[2]), _mm256_add_ps(a[1], a[3]));
        _mm256_storeu_ps(t[ch].as_mut_ptr(), v);
    }
    for (i, o) in out[..k].iter_mut().enumerate() {
        *o = Vec3::new(t[0][i], t[1][i], t[2][i]);
    }
}
