//! ASTC HDR blocks (4x4 and 6x6, 16 bytes a block), encoded and decoded by Arm's astcenc
//! (the `ctt-astcenc` crate vendors it) in its HDR-RGB/LDR-alpha profile at the medium preset.
//!
//! astcenc is a C++ build of over a minute on two cores, so it sits behind the cargo feature
//! `astc`; without it these formats are still named, listed and recognised in files, and
//! encoding or decoding them says which feature to build. Images are cut into bands of whole
//! block rows, each compressed on its own by a context of the worker thread: every block is
//! encoded from its own texels only (astcenc repeats the last row and column past the edge),
//! so the bytes do not depend on the number of threads.
//!
//! astcenc weighs HDR errors in log space, where a sun's block of 3600 read back as 2300 is a
//! small error; to a light probe it is most of the light. So each block whose read-back light is off
//! by more than `LIGHT_SHARE` of the image's is fitted again on its own: its texels scaled by
//! what it lost, per channel, a few rounds, the closest kept. A block that spans 15 stops has
//! weights a stop or two apart, so the sun's blocks stay coarse: on the real panoramas' 256 px
//! cubes the light error fell from 2.8 to 1.5 % (esplanade, 4x4) and from 8.1 to 2.3 % (6x6);
//! BC6H keeps it within 0.9 %.

#[cfg(not(feature = "astc"))]
use crate::image::Image;

/// The message for a build without the encoder.
#[cfg(not(feature = "astc"))]
fn missing() -> String {
    "ASTC HDR needs cubeforge built with the cargo feature `astc` \
     (cargo install --locked --path . --features astc)"
        .into()
}

/// Whether this build has astcenc.
pub(super) fn check_built() -> Result<(), String> {
    #[cfg(not(feature = "astc"))]
    return Err(missing());
    #[cfg(feature = "astc")]
    Ok(())
}

/// Encodes `img` as ASTC HDR blocks of `dim` x `dim` texels, row by row.
#[cfg(not(feature = "astc"))]
pub(super) fn encode(_img: &Image, _dim: usize) -> Result<Vec<u8>, String> {
    Err(missing())
}

/// Decodes a `w` x `h` image of ASTC blocks of `dim` x `dim` texels.
#[cfg(not(feature = "astc"))]
pub(super) fn decode(_bytes: &[u8], _w: usize, _h: usize, _dim: usize) -> Result<Image, String> {
    Err(missing())
}

#[cfg(feature = "astc")]
pub(super) use with_astcenc::{decode, encode};
#[cfg(feature = "uastc")]
pub(super) use with_astcenc::{keep_light, texel};

#[cfg(feature = "astc")]
mod with_astcenc {
    use super::super::packed::unsigned;
    use super::super::HALF_MAX;
    use crate::image::Image;
    use ctt_astcenc::{bindings, config_init, Context, Flags, Preset, Profile, Swizzle};
    use glam::Vec4;
    use rayon::prelude::*;
    use std::cell::RefCell;

    /// Block rows per task: enough work to hide the context's set-up, enough tasks for all cores.
    const BAND_BLOCK_ROWS: usize = 4;
    /// A block is fitted again when its light is off by more than this share of the image's
    /// (per channel): the sun's few blocks, not the sky's thousands.
    pub(super) const LIGHT_SHARE: f64 = 2e-4;
    /// Rounds of the refit, and the error (a share of the image's light) at which it stops.
    const REFIT_ROUNDS: usize = 6;
    const REFIT_CLOSE: f64 = LIGHT_SHARE / 8.0;

    /// A texel as the encoder takes it: negatives and NaN as 0, values past the largest half
    /// float clamped (HDR endpoints are unsigned half-float-like values), alpha in [0, 1].
    #[inline]
    pub(in super::super) fn texel(p: Vec4, scale: [f32; 3]) -> [f32; 4] {
        let c = |v: f32, k: f32| unsigned(unsigned(v, HALF_MAX) * k, HALF_MAX);
        [
            c(p.x, scale[0]),
            c(p.y, scale[1]),
            c(p.z, scale[2]),
            p.w.clamp(0.0, 1.0),
        ]
    }

    thread_local! {
        /// This thread's contexts, one per block size (set-up tables are per size).
        static CONTEXTS: RefCell<Vec<(usize, Context)>> = const { RefCell::new(Vec::new()) };
    }

    /// Runs `f` with this thread's context for `dim` x `dim` blocks.
    fn with_context<T>(
        dim: usize,
        f: impl FnOnce(&mut Context) -> Result<T, String>,
    ) -> Result<T, String> {
        CONTEXTS.with(|cell| {
            let mut contexts = cell.borrow_mut();
            let i = match contexts.iter().position(|(d, _)| *d == dim) {
                Some(i) => i,
                None => {
                    let config = config_init(
                        Profile::HdrRgbLdrA,
                        dim as u32,
                        dim as u32,
                        1,
                        Preset::Medium,
                        Flags::empty(),
                    )
                    .map_err(|e| format!("astcenc cannot take {dim}x{dim} blocks: {e}"))?;
                    let context =
                        Context::new(&config).map_err(|e| format!("astcenc failed: {e}"))?;
                    contexts.push((dim, context));
                    contexts.len() - 1
                }
            };
            f(&mut contexts[i].1)
        })
    }

    /// An astcenc image over `texels` (RGBA f32, `w` x `h`); `slot` must outlive its use.
    fn image(slot: &mut *mut std::ffi::c_void, w: usize, h: usize) -> bindings::astcenc_image {
        bindings::astcenc_image {
            dim_x: w as u32,
            dim_y: h as u32,
            dim_z: 1,
            data_type: bindings::astcenc_type_ASTCENC_TYPE_F32,
            data: slot,
        }
    }

    pub(in super::super) fn encode(img: &Image, dim: usize) -> Result<Vec<u8>, String> {
        let (w, h) = (img.width, img.height);
        if w == 0 || h == 0 {
            return Ok(Vec::new());
        }
        let row_blocks = w.div_ceil(dim);
        let band_rows = BAND_BLOCK_ROWS * dim;
        let mut out = vec![0u8; row_blocks * h.div_ceil(dim) * 16];
        out.par_chunks_mut(row_blocks * 16 * BAND_BLOCK_ROWS)
            .zip(img.pixels.par_chunks(w * band_rows))
            .try_for_each(|(blocks, rows)| {
                let mut texels: Vec<f32> = rows.iter().flat_map(|&p| texel(p, [1.0; 3])).collect();
                let mut slot = texels.as_mut_ptr().cast::<std::ffi::c_void>();
                let mut src = image(&mut slot, w, rows.len() / w);
                with_context(dim, |ctx| {
                    let done = ctx.compress(&mut src, Swizzle::IDENTITY, blocks);
                    ctx.compress_reset()
                        .and(done)
                        .map_err(|e| format!("astcenc failed: {e}"))
                })
            })?;
        keep_light(img, dim, &mut out, &|texels| encode_block(dim, texels))?;
        Ok(out)
    }

    /// One block of `dim` x `dim` texels (RGBA f32, row by row) as astcenc encodes it.
    fn encode_block(dim: usize, texels: &mut [f32]) -> Result<[u8; 16], String> {
        let mut block = [0u8; 16];
        let mut slot = texels.as_mut_ptr().cast::<std::ffi::c_void>();
        let mut src = image(&mut slot, dim, dim);
        with_context(dim, |ctx| {
            let done = ctx.compress(&mut src, Swizzle::IDENTITY, &mut block);
            ctx.compress_reset()
                .and(done)
                .map_err(|e| format!("astcenc failed: {e}"))
        })?;
        Ok(block)
    }

    /// Encodes one block of `dim` x `dim` texels (RGBA f32, rows top to bottom; the encoder
    /// may change them).
    pub(in super::super) type BlockEncoder<'a> =
        dyn Fn(&mut [f32]) -> Result<[u8; 16], String> + Sync + 'a;

    /// Per-channel light (sums) of the in-image texels of block `b` of `img`, read through
    /// `texel` as the encoder took them.
    fn block_light(img: &Image, dim: usize, b: (usize, usize)) -> [f64; 3] {
        let mut sum = [0f64; 3];
        for y in b.1 * dim..((b.1 + 1) * dim).min(img.height) {
            for x in b.0 * dim..((b.0 + 1) * dim).min(img.width) {
                let t = texel(img.pixels[y * img.width + x], [1.0; 3]);
                for c in 0..3 {
                    sum[c] += t[c] as f64;
                }
            }
        }
        sum
    }

    /// Refits the blocks of `blocks` (the encoding of `img`) whose light is off by more than
    /// [`LIGHT_SHARE`] of the image's, each on its own by `encode`, in parallel. Any encoder
    /// of ASTC HDR blocks can use it (astcenc's, basis_universal's UASTC HDR).
    pub(in super::super) fn keep_light(
        img: &Image,
        dim: usize,
        blocks: &mut [u8],
        encode: &BlockEncoder,
    ) -> Result<(), String> {
        let back = decode(blocks, img.width, img.height, dim)?;
        let row_blocks = img.width.div_ceil(dim);
        let count = row_blocks * img.height.div_ceil(dim);
        let at = |b: usize| (b % row_blocks, b / row_blocks);
        let lights: Vec<([f64; 3], [f64; 3])> = (0..count)
            .into_par_iter()
            .map(|b| {
                let s = block_light(img, dim, at(b));
                (s, block_light(&back, dim, at(b)))
            })
            .collect();
        let mut total = [0f64; 3];
        for (s, _) in &lights {
            for c in 0..3 {
                total[c] += s[c];
            }
        }
        let refits: Vec<Option<[u8; 16]>> = lights
            .par_iter()
            .enumerate()
            .map(|(b, (s, d))| {
                let off = (0..3).any(|c| (d[c] - s[c]).abs() > LIGHT_SHARE * total[c]);
                if off {
                    refit(
                        img,
                        dim,
                        at(b),
                        [*s, *d, total],
                        &blocks[b * 16..b * 16 + 16],
                        encode,
                    )
                } else {
                    Ok(None)
                }
            })
            .collect::<Result<_, String>>()?;
        for (b, bytes) in refits.into_iter().enumerate() {
            if let Some(bytes) = bytes {
                blocks[b * 16..b * 16 + 16].copy_from_slice(&bytes);
            }
        }
        Ok(())
    }

    /// The block at `b` encoded again with its texels scaled per channel by the light it lost,
    /// a few rounds; the encoding whose light is closest to the block's source light when it
    /// beats `first`. `light` holds the block's source light, the light `first` reads back with
    /// and the image's, per channel: errors count as shares of the image's light, so a channel
    /// that is nearly 0 in the block (a saturated blue sun's red) does not steer the fit.
    fn refit(
        img: &Image,
        dim: usize,
        b: (usize, usize),
        light: [[f64; 3]; 3],
        first: &[u8],
        encode: &BlockEncoder,
    ) -> Result<Option<[u8; 16]>, String> {
        let [source, mut got, total] = light;
        let error = |d: &[f64; 3]| {
            (0..3)
                .map(|c| (d[c] - source[c]).abs() / total[c].max(1e-30))
                .fold(0.0, f64::max)
        };
        let mut best = (error(&got), None);
        let mut scale = [1f32; 3];
        let mut texels = vec![0f32; dim * dim * 4];
        for _ in 0..REFIT_ROUNDS {
            for c in 0..3 {
                if got[c] > 0.0 && source[c] > 0.0 {
                    scale[c] = (scale[c] as f64 * source[c] / got[c]).clamp(0.25, 4.0) as f32;
                }
            }
            // The block alone, edges repeated past the image as astcenc repeats them.
            for y in 0..dim {
                for x in 0..dim {
                    let sy = (b.1 * dim + y).min(img.height - 1);
                    let sx = (b.0 * dim + x).min(img.width - 1);
                    let t = texel(img.pixels[sy * img.width + sx], scale);
                    texels[(y * dim + x) * 4..][..4].copy_from_slice(&t);
                }
            }
            let block = encode(&mut texels)?;
            let decoded = decode(&block, dim, dim, dim)?;
            got = [0.0; 3];
            for y in 0..dim.min(img.height - b.1 * dim) {
                for x in 0..dim.min(img.width - b.0 * dim) {
                    let v = decoded.pixels[y * dim + x];
                    for c in 0..3 {
                        got[c] += v[c] as f64;
                    }
                }
            }
            let e = error(&got);
            if e < best.0 {
                best = (e, Some(block));
            }
            if e < REFIT_CLOSE {
                break;
            }
        }
        Ok(best.1.filter(|b| b[..] != first[..]))
    }

    pub(in super::super) fn decode(
        bytes: &[u8],
        w: usize,
        h: usize,
        dim: usize,
    ) -> Result<Image, String> {
        let mut pixels = vec![Vec4::ZERO; w * h];
        if w > 0 && h > 0 {
            let band_bytes = w.div_ceil(dim) * 16 * BAND_BLOCK_ROWS;
            pixels
                .par_chunks_mut(w * BAND_BLOCK_ROWS * dim)
                .zip(bytes.par_chunks(band_bytes))
                .try_for_each(|(rows, blocks)| {
                    let mut texels = vec![0f32; rows.len() * 4];
                    let mut slot = texels.as_mut_ptr().cast::<std::ffi::c_void>();
                    let mut dst = image(&mut slot, w, rows.len() / w);
                    with_context(dim, |ctx| {
                        let done = ctx.decompress(blocks, &mut dst, Swizzle::IDENTITY);
                        ctx.decompress_reset()
                            .and(done)
                            .map_err(|e| format!("astcenc cannot decode: {e}"))
                    })?;
                    // Error blocks (a damaged file) decode to NaN in the HDR profile: read as 0.
                    let f = |v: f32| if v.is_finite() { v } else { 0.0 };
                    for (p, t) in rows.iter_mut().zip(texels.chunks_exact(4)) {
                        *p = Vec4::new(f(t[0]), f(t[1]), f(t[2]), f(t[3]));
                    }
                    Ok::<(), String>(())
                })?;
        }
        Ok(Image {
            width: w,
            height: h,
            pixels,
        })
    }
}
