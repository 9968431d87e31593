//! Linear-light RGBA f32 images: the one pixel type every layout, filter and writer shares.

#![warn(missing_docs)]

use glam::Vec4;

/// How 8- and 16-bit values map to linear light. Float data is always linear.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ColorSpace {
    /// Colour: decode sRGB on read, encode on write.
    Srgb,
    /// Data (masks, normals) or float images: values are stored as they are.
    Linear,
}

/// The largest value an input keeps (larger ones are clamped on reading). Far above any
/// measured radiance (a sun is about 1e9 in absolute units), and low enough that sums of a
/// whole map's texels times their weights (2^28 texels or fewer) stay finite in f32.
pub const MAX_RADIANCE: f32 = 1e28;

/// How lookups read past an image's edges.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Edges {
    /// The edge texels repeat.
    Clamp,
    /// Columns wrap around (a panorama); rows clamp.
    WrapX,
    /// Each edge goes on as itself mirrored about its midpoint (an octahedral map): past
    /// column w - 1 at row y lies column w - 1 at row h - 1 - y, and likewise at every edge.
    Octahedral,
}

impl Edges {
    fn wrap_x(wrap: bool) -> Edges {
        if wrap {
            Edges::WrapX
        } else {
            Edges::Clamp
        }
    }
}

/// A linear RGBA f32 image, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width * height` pixels, row by row from the top.
    pub pixels: Vec<Vec4>,
}

impl Image {
    /// An all-zero (transparent black) image.
    pub fn new(width: usize, height: usize) -> Self {
        Image {
            width,
            height,
            // Zeroed by the allocator (fresh pages come zeroed from the kernel):
            // `vec![Vec4::ZERO; n]` writes every byte first, doubling the memory traffic of
            // images that are filled right after.
            pixels: crate::alloc::zeroed(width * height),
        }
    }

    /// An image of one value.
    pub fn filled(width: usize, height: usize, v: Vec4) -> Self {
        Image {
            width,
            height,
            pixels: vec![v; width * height],
        }
    }

    /// Builds an image by calling `f(x, y)` for every pixel, rows in parallel.
    pub fn from_fn(width: usize, height: usize, f: impl Fn(usize, usize) -> Vec4 + Sync) -> Self {
        Image::from_rows(width, height, |y, row| {
            for (x, p) in row.iter_mut().enumerate() {
                *p = f(x, y);
            }
        })
    }

    /// The image upside down (rows in reverse order): for files stored bottom row first.
    pub fn flipped_rows(&self) -> Image {
        let w = self.width.max(1);
        Image::from_rows(self.width, self.height, |y, row| {
            let from = self.height - 1 - y;
            row.copy_from_slice(&self.pixels[from * w..from * w + self.width]);
        })
    }

    /// Builds an image by letting `f(y, row)` fill each row, rows in parallel: for loops that
    /// keep per-row state (batches, scratch space) instead of working texel by texel. Each
    /// row is cleared just before `f` sees it, by the thread that fills it, not the whole
    /// image up front on one thread (see `alloc::uninit`).
    pub(crate) fn from_rows(
        width: usize,
        height: usize,
        f: impl Fn(usize, &mut [Vec4]) + Sync,
    ) -> Self {
        use rayon::prelude::*;
        use std::mem::MaybeUninit;
        let mut pixels = crate::alloc::uninit::<Vec4>(width * height);
        if width > 0 {
            pixels
                .par_chunks_mut(width)
                .enumerate()
                .for_each(|(y, row)| {
                    row.fill(MaybeUninit::new(Vec4::ZERO));
                    // SAFETY: every element of the row was just written; MaybeUninit<Vec4>
                    // has Vec4's layout.
                    let row = unsafe { &mut *(row as *mut [MaybeUninit<Vec4>] as *mut [Vec4]) };
                    f(y, row)
                });
        }
        Image {
            width,
            height,
            // SAFETY: every row was written above (no row: no element, width 0 or height 0).
            pixels: unsafe { crate::alloc::assume_init(pixels) },
        }
    }

    /// The pixel at column `x`, row `y` (panics outside the image).
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> Vec4 {
        self.pixels[y * self.width + x]
    }

    /// Sets the pixel at column `x`, row `y` (panics outside the image).
    #[inline]
    pub fn set(&mut self, x: usize, y: usize, v: Vec4) {
        self.pixels[y * self.width + x] = v;
    }

    /// Copies a `w` x `h` block starting at (x0, y0).
    pub(crate) fn crop(&self, x0: usize, y0: usize, w: usize, h: usize) -> Image {
        let mut out = Image::new(w, h);
        // Rows in parallel: a cross's faces are cut out before anything else can run.
        use rayon::prelude::*;
        out.pixels
            .par_chunks_mut(w.max(1))
            .enumerate()
            .for_each(|(y, row)| {
                let src = (y0 + y) * self.width + x0;
                row.copy_from_slice(&self.pixels[src..src + w]);
            });
        out
    }

    /// Pastes `src` with its top-left corner at (x0, y0).
    pub(crate) fn paste(&mut self, src: &Image, x0: usize, y0: usize) {
        for y in 0..src.height {
            let dst = (y0 + y) * self.width + x0;
            self.pixels[dst..dst + src.width]
                .copy_from_slice(&src.pixels[y * src.width..(y + 1) * src.width]);
        }
    }

    /// Turned 180 degrees (the vertical cross stores -Z that way).
    pub(crate) fn rotated_180(&self) -> Image {
        let mut out = self.clone();
        out.pixels.reverse();
        out
    }

    /// Half the size in each dimension, each pixel the mean of the 2x2 block above it
    /// (an odd last row or column is folded into its neighbour so nothing is dropped).
    pub fn downsample_2x(&self) -> Image {
        self.downsample_2x_weighted(|_, _| 1.0, Vec4::INFINITY)
    }

    /// This image and `count - 1` box-filtered halvings of it (a 2D texture's mip chain).
    pub fn mip_chain(&self, count: usize) -> Vec<Image> {
        let mut levels = vec![self.clone()];
        while levels.len() < count {
            let next = levels[levels.len() - 1].downsample_2x();
            levels.push(next);
        }
        levels
    }

    /// `downsample_2x` with each texel above weighted by `weight(x, y)` (the part of the
    /// sphere it covers, so a pyramid keeps the flux) and first clamped to `ceiling`.
    pub(crate) fn downsample_2x_weighted(
        &self,
        weight: impl Fn(usize, usize) -> f32 + Sync,
        ceiling: Vec4,
    ) -> Image {
        let (w, h) = self.half_size();
        Image::from_rows(w, h, |y, row| self.reduce_row(y, row, &weight, ceiling))
    }

    /// `downsample_2x_weighted` where the weight depends on the row only (a panorama's):
    /// the two rows' weights folded into two factors, four texels summed in pairs.
    pub(crate) fn downsample_2x_rows(&self, row_weight: &[f32], ceiling: Vec4) -> Image {
        let (w, h) = self.half_size();
        Image::from_rows(w, h, |y, out| {
            self.reduce_row_by_rows(y, out, row_weight, ceiling)
        })
    }

    /// Row `y` of `downsample_2x_rows` into `out`.
    pub(crate) fn reduce_row_by_rows(
        &self,
        y: usize,
        out: &mut [Vec4],
        row_weight: &[f32],
        ceiling: Vec4,
    ) {
        let src = self.width;
        let rows = self.half_rows(y);
        if src != 2 * out.len() || rows.len() != 2 {
            return self.reduce_row(y, out, &|_, y| row_weight[y], ceiling);
        }
        let (a, b) = (rows.start, rows.start + 1);
        let (wa, wb) = (row_weight[a], row_weight[b]);
        let total = 2.0 * (wa + wb);
        if total <= 0.0 {
            return out.fill(Vec4::ZERO);
        }
        let (fa, fb) = (wa / total, wb / total);
        let ra = &self.pixels[a * src..(a + 1) * src];
        let rb = &self.pixels[b * src..(b + 1) * src];
        for ((o, pa), pb) in out
            .iter_mut()
            .zip(ra.chunks_exact(2))
            .zip(rb.chunks_exact(2))
        {
            *o = (pa[0].min(ceiling) + pa[1].min(ceiling)) * fa
                + (pb[0].min(ceiling) + pb[1].min(ceiling)) * fb;
        }
    }

    /// The size `downsample_2x*` gives.
    pub(crate) fn half_size(&self) -> (usize, usize) {
        ((self.width / 2).max(1), (self.height / 2).max(1))
    }

    /// The source rows `y0..y1` that row `y` of the half-size image averages.
    pub(crate) fn half_rows(&self, y: usize) -> std::ops::Range<usize> {
        let h = self.half_size().1;
        let sy = self.height as f32 / h as f32;
        let y0 = (y as f32 * sy) as usize;
        let y1 = (((y + 1) as f32 * sy) as usize)
            .min(self.height)
            .max(y0 + 1);
        y0..y1
    }

    /// Row `y` of `downsample_2x_weighted` into `out`.
    pub(crate) fn reduce_row(
        &self,
        y: usize,
        out: &mut [Vec4],
        weight: &impl Fn(usize, usize) -> f32,
        ceiling: Vec4,
    ) {
        let rows = self.half_rows(y);
        if self.width == 2 * out.len() && rows.len() == 2 {
            // The common case, 2 x 2 blocks, with no index arithmetic (same sums, same order).
            let w = self.width;
            let (a, b) = (rows.start, rows.start + 1);
            let (ra, rb) = (
                &self.pixels[a * w..(a + 1) * w],
                &self.pixels[b * w..(b + 1) * w],
            );
            for (x, o) in out.iter_mut().enumerate() {
                let (x0, x1) = (2 * x, 2 * x + 1);
                let (w0, w1, w2, w3) = (weight(x0, a), weight(x1, a), weight(x0, b), weight(x1, b));
                let acc = ra[x0].min(ceiling) * w0
                    + ra[x1].min(ceiling) * w1
                    + rb[x0].min(ceiling) * w2
                    + rb[x1].min(ceiling) * w3;
                let total = w0 + w1 + w2 + w3;
                *o = if total > 0.0 { acc / total } else { Vec4::ZERO };
            }
            return;
        }
        let sx = self.width as f32 / out.len() as f32;
        for (x, o) in out.iter_mut().enumerate() {
            let x0 = (x as f32 * sx) as usize;
            let x1 = (((x + 1) as f32 * sx) as usize).min(self.width).max(x0 + 1);
            let mut acc = Vec4::ZERO;
            let mut total = 0.0;
            for yy in rows.clone() {
                for xx in x0..x1 {
                    let a = weight(xx, yy);
                    acc += self.get(xx, yy).min(ceiling) * a;
                    total += a;
                }
            }
            *o = if total > 0.0 { acc / total } else { Vec4::ZERO };
        }
    }

    /// Replaces NaN, infinite and negative values by 0, clamps values above [`MAX_RADIANCE`],
    /// and returns how many were replaced.
    pub fn sanitize(&mut self) -> usize {
        use rayon::prelude::*;
        self.pixels.par_iter_mut().map(sanitize_texel).sum()
    }

    /// Bilinear sample at continuous pixel coordinates (pixel centres at i + 0.5).
    /// `wrap_x` repeats horizontally (panoramas); otherwise edges clamp.
    #[inline]
    pub fn bilinear(&self, x: f32, y: f32, wrap_x: bool) -> Vec4 {
        self.bilinear_below(x, y, Edges::wrap_x(wrap_x), Vec4::INFINITY)
    }

    /// `bilinear` of the image with every texel first clamped to `ceiling` (per channel).
    #[inline]
    pub(crate) fn bilinear_below(&self, x: f32, y: f32, edges: Edges, ceiling: Vec4) -> Vec4 {
        let fx = x - 0.5;
        let fy = y - 0.5;
        let x0 = floor_small(fx);
        let y0 = floor_small(fy);
        let ax = fx - x0;
        let ay = fy - y0;
        if edges == Edges::Octahedral {
            let (x0, y0) = (x0 as isize, y0 as isize);
            let p = |x: isize, y: isize| self.pixels[self.folded(x, y)].min(ceiling);
            let r0 = p(x0, y0).lerp(p(x0 + 1, y0), ax);
            let r1 = p(x0, y0 + 1).lerp(p(x0 + 1, y0 + 1), ax);
            return r0.lerp(r1, ay);
        }
        let (xa, xb) = self.cols(x0 as isize, edges == Edges::WrapX);
        let ya = clampi(y0 as isize, self.height);
        let yb = clampi(y0 as isize + 1, self.height);
        let p = |y: usize, x: usize| self.pixels[y * self.width + x].min(ceiling);
        let r0 = p(ya, xa).lerp(p(ya, xb), ax);
        let r1 = p(yb, xa).lerp(p(yb, xb), ax);
        r0.lerp(r1, ay)
    }

    /// `out[i]` = `bilinear(x[i], y[i], wrap_x)` for a batch: see `bilinear_many_below`.
    pub fn bilinear_many(&self, x: &[f32], y: &[f32], wrap_x: bool, out: &mut [Vec4]) {
        self.bilinear_many_below(x, y, wrap_x, Vec4::INFINITY, out)
    }

    /// `out[i]` = `bilinear_below(x[i], y[i], wrap_x, ceiling)` for coordinates within one
    /// image width of the image (all a projection produces), in three passes: the coordinate
    /// arithmetic in vector lanes, prefetches for every tap so many cache misses are in flight
    /// at once (a lookup at a time was bound by one miss at a time), then the texel reads.
    pub(crate) fn bilinear_many_below(
        &self,
        x: &[f32],
        y: &[f32],
        wrap_x: bool,
        ceiling: Vec4,
        out: &mut [Vec4],
    ) {
        const CHUNK: usize = 64;
        for ((x, y), out) in x
            .chunks(CHUNK)
            .zip(y.chunks(CHUNK))
            .zip(out.chunks_mut(CHUNK))
        {
            let n = out.len();
            let mut col = [[0i32; CHUNK]; 2];
            let mut row = [[0i32; CHUNK]; 2];
            let mut ax = [0.0f32; CHUNK];
            let mut ay = [0.0f32; CHUNK];
            // Float arithmetic throughout (column wrap and clamps included) so the loop
            // vectorises; the clamped values convert to integers exactly.
            let (wf, hf) = (self.width as f32, self.height as f32);
            for i in 0..n {
                let fx = x[i] - 0.5;
                let fy = y[i] - 0.5;
                let x0 = floor_small(fx);
                let y0 = floor_small(fy);
                ax[i] = fx - x0;
                ay[i] = fy - y0;
                let x1 = x0 + 1.0;
                let (xa, xb) = if wrap_x {
                    (
                        if x0 < 0.0 { x0 + wf } else { x0 },
                        if x1 >= wf { x1 - wf } else { x1 },
                    )
                } else {
                    (x0, x1)
                };
                col[0][i] = index(xa, wf);
                col[1][i] = index(xb, wf);
                row[0][i] = index(y0, hf);
                row[1][i] = index(y0 + 1.0, hf);
            }
            let at = |r: i32, c: i32| r as usize * self.width + c as usize;
            #[cfg(target_arch = "x86_64")]
            for i in 0..n {
                use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
                let p = self.pixels.as_ptr();
                // SAFETY: the indices lie inside the pixel buffer (clamped above); a prefetch
                // never faults and brings nothing into the program.
                unsafe {
                    _mm_prefetch::<_MM_HINT_T0>(p.add(at(row[0][i], col[0][i])) as *const i8);
                    _mm_prefetch::<_MM_HINT_T0>(p.add(at(row[1][i], col[0][i])) as *const i8);
                }
            }
            for (i, o) in out.iter_mut().enumerate() {
                let p = |k: usize| self.pixels[k].min(ceiling);
                let (ra, rb) = (row[0][i], row[1][i]);
                let (ca, cb) = (col[0][i], col[1][i]);
                let r0 = p(at(ra, ca)).lerp(p(at(ra, cb)), ax[i]);
                let r1 = p(at(rb, ca)).lerp(p(at(rb, cb)), ax[i]);
                *o = r0.lerp(r1, ay[i]);
            }
        }
    }

    #[inline]
    fn cols(&self, x0: isize, wrap_x: bool) -> (usize, usize) {
        if wrap_x {
            // Coordinates come from 0..width (plus half a texel), so one wrap suffices;
            // rem_euclid stays for anything further out.
            let w = self.width as isize;
            let wrap = |v: isize| {
                if (0..w).contains(&v) {
                    v as usize
                } else if (-w..0).contains(&v) {
                    (v + w) as usize
                } else {
                    v.rem_euclid(w) as usize
                }
            };
            (wrap(x0), wrap(x0 + 1))
        } else {
            (clampi(x0, self.width), clampi(x0 + 1, self.width))
        }
    }

    /// The index of texel (x, y) of an octahedral map, at most an image's size beyond its
    /// edges, each edge mirrored about its midpoint ([`Edges::Octahedral`]).
    #[inline]
    fn folded(&self, mut x: isize, mut y: isize) -> usize {
        let (w, h) = (self.width as isize, self.height as isize);
        if x < 0 || x >= w {
            x = if x < 0 { -1 - x } else { 2 * w - 1 - x };
            y = h - 1 - y;
        }
        if y < 0 || y >= h {
            y = if y < 0 { -1 - y } else { 2 * h - 1 - y };
            x = w - 1 - x;
        }
        clampi(y, self.height) * self.width + clampi(x, self.width)
    }

    /// Catmull-Rom bicubic sample, clamped to the range of the 2x2 texels around the point so it
    /// sharpens without ringing (never below zero, never past the local extremes).
    pub fn bicubic(&self, x: f32, y: f32, wrap_x: bool) -> Vec4 {
        self.bicubic_below(x, y, Edges::wrap_x(wrap_x), Vec4::INFINITY)
    }

    /// `bicubic` of the image with every texel first clamped to `ceiling` (per channel).
    pub(crate) fn bicubic_below(&self, x: f32, y: f32, edges: Edges, ceiling: Vec4) -> Vec4 {
        let fx = x - 0.5;
        let fy = y - 0.5;
        let x0 = fx.floor();
        let y0 = fy.floor();
        let wx = catmull_rom(fx - x0);
        let wy = catmull_rom(fy - y0);
        let w = self.width as isize;
        let (xs, ys) = (x0 as isize - 1, y0 as isize - 1);
        // The 4 x 4 texels' indices, edges resolved once (not per tap).
        let idx: [[usize; 4]; 4] = if edges == Edges::Octahedral {
            std::array::from_fn(|j| {
                std::array::from_fn(|i| self.folded(xs + i as isize, ys + j as isize))
            })
        } else {
            let cols: [usize; 4] = std::array::from_fn(|i| {
                let xi = xs + i as isize;
                if edges == Edges::WrapX {
                    xi.rem_euclid(w) as usize
                } else {
                    clampi(xi, self.width)
                }
            });
            std::array::from_fn(|j| {
                let row = clampi(ys + j as isize, self.height) * self.width;
                cols.map(|c| row + c)
            })
        };
        let mut acc = Vec4::ZERO;
        let mut lo = Vec4::splat(f32::INFINITY);
        let mut hi = Vec4::splat(f32::NEG_INFINITY);
        for (j, wyj) in wy.iter().enumerate() {
            let mut row = Vec4::ZERO;
            for (i, wxi) in wx.iter().enumerate() {
                let p = self.pixels[idx[j][i]].min(ceiling);
                if (1..=2).contains(&i) && (1..=2).contains(&j) {
                    lo = lo.min(p);
                    hi = hi.max(p);
                }
                row += p * *wxi;
            }
            acc += row * *wyj;
        }
        acc.clamp(lo, hi)
    }
}

/// floor() for pixel coordinates (|v| < 4e6, far beyond any image), without a libm call (the
/// baseline x86-64 target has no rounding instruction) and without the saturating integer
/// cast that keeps a loop scalar.
#[inline(always)]
#[allow(clippy::manual_clamp)] // clamp keeps NaN; max/min drop it, which the cast needs
fn floor_small(v: f32) -> f32 {
    let c = v.max(-4.0e6).min(4.0e6);
    // SAFETY: `c` is finite (max/min drop NaN) and far inside i32's range.
    let t = unsafe { c.to_int_unchecked::<i32>() } as f32;
    if t > c {
        t - 1.0
    } else {
        t
    }
}

/// An integral coordinate clamped to 0..n-1, as an index.
#[inline(always)]
fn index(v: f32, n: f32) -> i32 {
    // SAFETY: max/min drop NaN and bound the value to 0..n-1 < 2^31.
    unsafe { v.max(0.0).min(n - 1.0).to_int_unchecked::<i32>() }
}

#[inline]
fn clampi(v: isize, n: usize) -> usize {
    v.clamp(0, n as isize - 1) as usize
}

#[inline]
fn catmull_rom(t: f32) -> [f32; 4] {
    let t2 = t * t;
    let t3 = t2 * t;
    [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ]
}

/// sRGB transfer function, decode (IEC 61966-2-1).
#[inline]
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// sRGB transfer function, encode.
#[inline]
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Rec. 709 luminance of linear RGB.
#[inline]
pub fn luminance(p: Vec4) -> f32 {
    0.2126 * p.x + 0.7152 * p.y + 0.0722 * p.z
}

/// [`Image::sanitize`] of one texel: its NaN, infinite and negative values by 0, values above
/// [`MAX_RADIANCE`] by that; how many were replaced.
#[inline]
pub(crate) fn sanitize_texel(p: &mut Vec4) -> usize {
    // Almost every texel is in range (NaN compares false): one vector test for those.
    if (p.cmpge(Vec4::ZERO) & p.cmple(Vec4::splat(MAX_RADIANCE))).all() {
        return 0;
    }
    let mut count = 0;
    for c in 0..4 {
        let v = p[c];
        if !v.is_finite() || v < 0.0 {
            p[c] = 0.0;
            count += 1;
        } else if v > MAX_RADIANCE {
            p[c] = MAX_RADIANCE;
            count += 1;
        }
    }
    count
}
