//! The weighted mean of a tile's candidates: lanes of eight, the weight formulas and their
//! 2^x. Everything here is inlined into the kernel, and its order of operations fixes the
//! output's bits, so it is kept together.

use super::{Shape, Window, MAX_DEGREE};
use glam::{Vec3, Vec4};

#[cfg(target_arch = "x86_64")]
mod avx2;

/// Candidate texels per lane group: eight, one AVX register (two SSE ones without AVX).
const LANES: usize = 8;

/// Eight candidate texels in lanes: direction, solid angle, value.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct Oct {
    x: [f32; LANES],
    y: [f32; LANES],
    z: [f32; LANES],
    sa: [f32; LANES],
    r: [f32; LANES],
    g: [f32; LANES],
    b: [f32; LANES],
    a: [f32; LANES],
}

/// The texels a tile gathered, eight to an oct (padding has no solid angle).
#[derive(Default)]
pub(super) struct Candidates {
    octs: Vec<Oct>,
    len: usize,
}

impl Candidates {
    pub(super) fn clear(&mut self) {
        self.octs.clear();
        self.len = 0;
    }

    pub(super) fn push(&mut self, d: Vec3, sa: f32, v: Vec4) {
        let l = self.len % LANES;
        if l == 0 {
            // Padding points along the first member (a finite weight) with no solid angle.
            let zero = [0.0; LANES];
            self.octs.push(Oct {
                x: [d.x; LANES],
                y: [d.y; LANES],
                z: [d.z; LANES],
                sa: zero,
                r: zero,
                g: zero,
                b: zero,
                a: zero,
            });
        }
        let o = self.octs.last_mut().expect("an oct");
        (o.x[l], o.y[l], o.z[l], o.sa[l]) = (d.x, d.y, d.z, sa);
        (o.r[l], o.g[l], o.b[l], o.a[l]) = (v.x, v.y, v.z, v.w);
        self.len += 1;
    }

    /// The candidates' light around unit `n`: their weighted sum over the lobe's integral.
    #[inline(always)]
    pub(super) fn mean(&self, window: &Window, n: Vec3) -> Vec4 {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::avx2_available() {
            // SAFETY: the CPU has AVX, AVX2 and FMA (checked just above).
            return unsafe { avx2::sum(self, window, n) } * window.norm;
        }
        self.portable_sum(window, n) * window.norm
    }

    /// [`Candidates::mean`]'s sum before the norm, in portable code.
    #[inline(always)]
    fn portable_sum(&self, window: &Window, n: Vec3) -> Vec4 {
        let cut = window.u_cut;
        match window.shape {
            Shape::Exp2 { q } => self.sum_with(n, cut, |u| exp2_weight(&q, u)),
            Shape::Ggx { a2, h } => self.sum_with(n, cut, |u| ggx_weight(a2, h, u)),
            Shape::Table { scale } => {
                let t = &window.table;
                self.sum_with(n, cut, |u| table_weight(t, scale, u))
            }
        }
    }

    /// The sum with `weight` (over the peak, a function of 1 - cos) for u up to `cut`: each
    /// lane summed in order, the lanes added in a fixed order, so every build and thread
    /// count gives the same bits. The lane loop is written lane by lane for the compiler to
    /// turn into one eight-wide instruction per step (two four-wide ones without AVX).
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into nine arrays, for the vectoriser
    fn sum_with(&self, n: Vec3, cut: f32, weight: impl Fn(f32) -> f32) -> Vec4 {
        let mut acc = [[0.0f32; LANES]; 4];
        for o in &self.octs {
            for l in 0..LANES {
                // 1 - cos from the difference: |n - d|^2 / 2, precise for small angles.
                let (dx, dy, dz) = (n.x - o.x[l], n.y - o.y[l], n.z - o.z[l]);
                let u = dx.mul_add(dx, dy.mul_add(dy, dz * dz)) * 0.5;
                let w = weight(u);
                let w = if u <= cut { w } else { 0.0 } * o.sa[l];
                acc[0][l] = w.mul_add(o.r[l], acc[0][l]);
                acc[1][l] = w.mul_add(o.g[l], acc[1][l]);
                acc[2][l] = w.mul_add(o.b[l], acc[2][l]);
                acc[3][l] = w.mul_add(o.a[l], acc[3][l]);
            }
        }
        let total =
            |v: &[f32; LANES]| ((v[0] + v[4]) + (v[2] + v[6])) + ((v[1] + v[5]) + (v[3] + v[7]));
        Vec4::new(
            total(&acc[0]),
            total(&acc[1]),
            total(&acc[2]),
            total(&acc[3]),
        )
    }
}

/// [`Shape::Exp2`]'s weight at `u`.
#[inline(always)]
pub(super) fn exp2_weight(q: &[f32; MAX_DEGREE + 1], u: f32) -> f32 {
    let mut p = q[MAX_DEGREE];
    for &c in q[..MAX_DEGREE].iter().rev() {
        p = p.mul_add(u, c);
    }
    exp2_small(u * p)
}

/// [`Shape::Table`]'s weight at `u` (0 <= u; past the table's end, its last step).
#[inline(always)]
pub(super) fn table_weight(table: &[f32], scale: f32, u: f32) -> f32 {
    let last = table.len() - 2;
    let t = (u * scale).max(0.0);
    let i = (t as usize).min(last);
    let f = (t - i as f32).min(1.0);
    f.mul_add(table[i + 1] - table[i], table[i])
}

/// [`Shape::Ggx`]'s weight at `u`.
#[inline(always)]
pub(super) fn ggx_weight(a2: f32, h: f32, u: f32) -> f32 {
    let r = a2 / h.mul_add(u, a2);
    (1.0 - u) * (r * r)
}

/// [`exp2_small`]'s polynomial for 2^f, highest power first.
const EXP2_POLY: [f32; 6] = [
    1.327_647_1e-3,
    9.675_541e-3,
    5.550_713e-2,
    0.240_221_2,
    0.693_146_94,
    1.000_000_1,
];

/// 2^x for -126 < x <= 0 (a log weight): 2^round(x) from the exponent bits, times a degree-5
/// polynomial for 2^f on |f| <= 1/2 (fitted for relative error: 7.5e-8, 2.3e-7 in f32).
/// Rounding by adding and taking away 1.5 2^23 keeps it to additions, so it vectorises
/// without SSE4.1's round.
#[inline(always)]
pub(super) fn exp2_small(x: f32) -> f32 {
    const MAGIC: f32 = 12_582_912.0;
    let shifted = x + MAGIC;
    let k = shifted - MAGIC;
    let f = x - k;
    const C: [f32; 6] = EXP2_POLY;
    let mut p = C[0];
    for &c in &C[1..] {
        p = p.mul_add(f, c);
    }
    // The integer k sits in the low bits of `shifted`; 2^k's bits are (k + 127) << 23.
    let k_bits = shifted.to_bits().wrapping_sub(MAGIC.to_bits());
    p * f32::from_bits(k_bits.wrapping_add(127) << 23)
}
