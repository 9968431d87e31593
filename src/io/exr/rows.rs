//! The common layout in bands of rows (`stream`): each band's blocks checked to tile it, the
//! bands decoded in parallel and handed to a fold, either whole as texels or a row at a time
//! as planes. A fold that reduces rows (a 16K panorama to an 8K copy) takes them as planes:
//! each row is converted, sanitized, measured and reduced while it is in cache, and no texel
//! of the full image is ever widened to four floats in memory.

use super::blocks::{self, Block, Held, Scratch};
use super::checks::RawChunk;
use super::Layout;
use crate::io::band_shape::Rows;
use exr::meta::MetaData;
use glam::Vec4;
use rayon::prelude::*;

/// How `map_bands` reads: the chunks are ZSTD (see `read_meta`), the lines are sanitized,
/// and the rows a band holds (a power of two no smaller than any block's lines).
pub(super) struct BandRead {
    pub zstd: bool,
    pub sanitize: bool,
    pub lines: usize,
}

/// The layer's chunks by band of `lines` rows, each band's in row order; an error where a
/// block crosses a band or lines are missing.
fn group<'c, 'd>(
    h: usize,
    chunks: &'c [RawChunk<'d>],
    lines: usize,
) -> std::result::Result<Vec<Vec<&'c RawChunk<'d>>>, String> {
    let mut bands: Vec<Vec<&RawChunk>> = vec![Vec::new(); h.div_ceil(lines)];
    for c in chunks {
        let (y, n) = (c.bounds.position.1 as usize, c.bounds.size.1);
        if n == 0 || y + n > h || y / lines != (y + n - 1) / lines {
            return Err(format!("the block at line {y} crosses a band"));
        }
        bands[y / lines].push(c);
    }
    for (i, band) in bands.iter_mut().enumerate() {
        band.sort_by_key(|c| c.bounds.position.1);
        let mut next = i * lines;
        for c in band.iter() {
            if c.bounds.position.1 as usize != next {
                return Err(format!(
                    "scan lines {next} to {} are missing",
                    c.bounds.position.1
                ));
            }
            next += c.bounds.size.1;
        }
        if next != h.min((i + 1) * lines) {
            return Err(format!(
                "scan lines {next} to {} are missing",
                h.min((i + 1) * lines)
            ));
        }
    }
    Ok(bands)
}

/// The layer in bands of `lines` rows, the bands `pick` keeps decoded in parallel, each into
/// a thread's buffer (sanitized if asked) and handed to `fold(first row, rows)`: how a
/// panorama is reduced as it is decoded, the whole never held. The folds in band order (None
/// where not picked) and the values replaced.
pub(super) fn map_bands<T: Send>(
    meta: &MetaData,
    layout: &Layout,
    chunks: &[RawChunk],
    how: BandRead,
    pick: &(dyn Fn(usize) -> bool + Sync),
    fold: &(dyn Fn(usize, &[Vec4]) -> T + Sync),
) -> std::result::Result<(Vec<Option<T>>, usize), String> {
    let w = meta.headers[0].layer_size.0;
    let make = blocks::scratch(w);
    let sanitize = how.sanitize;
    let each = |(s, buf): &mut (Scratch, Vec<Vec4>), block: &Block, y0, n, band: Band| {
        buf.resize(n * w, Vec4::ZERO);
        let mut replaced = 0;
        for c in band {
            let y = c.bounds.position.1 as usize;
            let rows = &mut buf[(y - y0) * w..(y - y0 + c.bounds.size.1) * w];
            replaced += block.decode(s, y, c, rows, sanitize)?;
        }
        Ok((fold(y0, &buf[..n * w]), replaced))
    };
    each_band(
        meta,
        layout,
        chunks,
        how,
        pick,
        || (make(), Vec::new()),
        each,
    )
}

/// `map_bands` with each band handed to `fold(first row, rows, its rows)` a row at a time,
/// as planes ([`Rows`]).
pub(super) fn map_rows<T: Send>(
    meta: &MetaData,
    layout: &Layout,
    chunks: &[RawChunk],
    how: BandRead,
    pick: &(dyn Fn(usize) -> bool + Sync),
    fold: &(dyn Fn(usize, usize, &mut dyn Rows) -> T + Sync),
) -> std::result::Result<(Vec<Option<T>>, usize), String> {
    let sanitize = how.sanitize;
    let each = |s: &mut Scratch, block: &Block, y0, n, band: Band| {
        let mut rows = BandRows {
            block,
            chunks: band.into_iter(),
            s,
            current: None,
            line: 0,
            lines: 0,
            sanitize,
            replaced: 0,
            error: None,
        };
        let done = fold(y0, n, &mut rows);
        match rows.error {
            Some(e) => Err(e),
            None => Ok((done, rows.replaced)),
        }
    };
    let make = blocks::scratch(meta.headers[0].layer_size.0);
    each_band(meta, layout, chunks, how, pick, make, each)
}

/// One band's chunks, in row order.
type Band<'c, 'd> = Vec<&'c RawChunk<'d>>;

/// What `map_bands` and `map_rows` share: the chunks grouped by band, and the bands `pick`
/// keeps handed in parallel to `each(a thread's state from init, the layer's blocks, first
/// row, rows, the band's chunks)`, which gives the band's fold and its values replaced.
fn each_band<S, T: Send>(
    meta: &MetaData,
    layout: &Layout,
    chunks: &[RawChunk],
    BandRead { zstd, lines, .. }: BandRead,
    pick: &(dyn Fn(usize) -> bool + Sync),
    init: impl Fn() -> S + Sync + Send,
    each: impl Fn(&mut S, &Block, usize, usize, Band) -> Result<(T, usize), String> + Sync + Send,
) -> std::result::Result<(Vec<Option<T>>, usize), String> {
    let h = meta.headers[0].layer_size.1;
    let bands = group(h, chunks, lines)?;
    let block = Block::new(meta, layout, zstd);
    let done: Vec<(Option<T>, usize)> = bands
        .into_par_iter()
        .enumerate()
        .map_init(init, |s, (i, band)| {
            if !pick(i) {
                return Ok((None, 0));
            }
            let y0 = i * lines;
            let n = h.min(y0 + lines) - y0;
            each(s, &block, y0, n, band).map(|(t, r)| (Some(t), r))
        })
        .collect::<Result<_, String>>()?;
    let replaced = done.iter().map(|d| d.1).sum();
    Ok((done.into_iter().map(|d| d.0).collect(), replaced))
}

/// One band's rows, decoded a block at a time as they are asked for.
struct BandRows<'a, 'c, 'd> {
    block: &'a Block<'a>,
    chunks: std::vec::IntoIter<&'c RawChunk<'d>>,
    s: &'a mut Scratch,
    current: Option<(&'c RawChunk<'d>, Held)>,
    /// The next line of the current block, and its count of lines.
    line: usize,
    lines: usize,
    sanitize: bool,
    replaced: usize,
    error: Option<String>,
}

impl BandRows<'_, '_, '_> {
    /// Unpacks the band's next block into the thread's buffer.
    fn next_block(&mut self) -> std::result::Result<(), String> {
        let Some(c) = self.chunks.next() else {
            return Err("a band ends before its rows".into());
        };
        let y = c.bounds.position.1 as usize;
        let lines = c.bounds.size.1;
        let held = self.block.unpack(&mut self.s.unpack, y, c, lines)?;
        self.current = Some((c, held));
        (self.line, self.lines) = (0, lines);
        Ok(())
    }
}

impl Rows for BandRows<'_, '_, '_> {
    fn next_into(&mut self, planes: &mut [f32]) {
        if self.error.is_none() && self.line == self.lines {
            if let Err(e) = self.next_block() {
                self.error = Some(e);
            }
        }
        let Some((chunk, held)) = self.current.filter(|_| self.error.is_none()) else {
            planes.fill(0.0);
            return;
        };
        let Block {
            slots,
            alpha,
            line_bytes,
            ..
        } = *self.block;
        let samples = held.samples(chunk, &self.s.unpack, line_bytes * self.lines);
        let start = self.line * line_bytes;
        let written = blocks::line_planes(samples, start, slots, alpha, planes, &mut self.s.halves);
        // The common layout has R, G and B; alpha is filled where absent.
        debug_assert_eq!(written, [true; 4]);
        if self.sanitize {
            self.replaced += sanitize_values(planes);
        }
        self.line += 1;
    }
}

/// `image::sanitize_texel` of each value of `values` (a plane of one channel): NaN, infinite
/// and negative values are 0, values above `MAX_RADIANCE` that; how many were replaced.
fn sanitize_values(values: &mut [f32]) -> usize {
    let mut count = 0;
    for chunk in values.chunks_mut(64) {
        // Almost every value is in range (NaN compares false): one test for a chunk.
        let fine = chunk.iter().fold(true, |ok, &v| {
            ok & (0.0..=crate::image::MAX_RADIANCE).contains(&v)
        });
        if fine {
            continue;
        }
        for v in chunk {
            if !v.is_finite() || *v < 0.0 {
                *v = 0.0;
                count += 1;
            } else if *v > crate::image::MAX_RADIANCE {
                *v = crate::image::MAX_RADIANCE;
                count += 1;
            }
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use glam::Vec4;

    #[test]
    fn planes_are_sanitized_as_texels_are() {
        let odd = [
            f32::NAN,
            f32::INFINITY,
            -1.0,
            2e30,
            0.5,
            -0.0,
            f32::NEG_INFINITY,
            3.0,
        ];
        let texels: Vec<Vec4> = odd.chunks(4).map(Vec4::from_slice).collect();
        let mut fixed = texels.clone();
        let expected: usize = fixed.iter_mut().map(crate::image::sanitize_texel).sum();
        let mut values: Vec<f32> = (0..70).map(|i| odd[i % 8]).collect();
        let count = super::sanitize_values(&mut values);
        // Five of every eight (minus zero is in range), and four of the six left over.
        assert_eq!(expected, 5);
        assert_eq!(count, 8 * 5 + 4);
        for (i, v) in values.iter().enumerate() {
            assert_eq!(
                v.to_bits(),
                fixed[(i % 8) / 4][i % 4].to_bits(),
                "value {i}"
            );
        }
    }
}
