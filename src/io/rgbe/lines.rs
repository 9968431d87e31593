//! Finding and walking scanlines. Run-length lines have no index, so where each one starts is
//! only known by walking the one before; this is the part that makes a large file's decode
//! parallel anyway, kept apart from turning bytes into texels.

use rayon::prelude::*;

/// Where each of the `h` scanlines of `w` texels starts, the first at `first`; Err(y) when
/// line y is truncated or malformed. Run-length lines have no index, so each start is found
/// by walking the line before: a large file is walked in pieces in parallel, each piece
/// from the first place in it that starts a line of this width (2, 2, width) and parses.
/// Walks are deterministic, so once the true walk reaches a start a piece's walk found, the
/// rest of that piece is the same; a piece whose walk it misses (a false start) is walked
/// again from the true start. The result is the one-piece walk's, always.
pub(super) fn line_starts(
    data: &[u8],
    first: usize,
    w: usize,
    h: usize,
) -> std::result::Result<Vec<usize>, usize> {
    /// Candidate starts tried per piece before leaving the piece to the true walk: a file
    /// full of false starts costs at most this many line walks a piece.
    const TRIES: usize = 8;
    let key = [2, 2, (w >> 8) as u8, (w & 0xff) as u8];
    let rle = (8..0x8000).contains(&w) && data.get(first..first + 4) == Some(&key[..]);
    let len = data.len().saturating_sub(first);
    let pieces = if rle && len >= 1 << 20 {
        (4 * rayon::current_num_threads()).min(len >> 16)
    } else {
        1
    };
    let bound = |i: usize| first + len * i / pieces;
    // Each piece's walk: the starts it found (each line parsed), and where it left off.
    let walks: Vec<(Vec<usize>, usize)> = (1..pieces)
        .into_par_iter()
        .map(|i| {
            let (lo, hi) = (bound(i), bound(i + 1));
            let mut from = lo;
            for _ in 0..TRIES {
                let Some(at) = data[from..hi].windows(4).position(|k| k == key) else {
                    break;
                };
                let mut p = from + at;
                let mut found = Vec::new();
                while p < hi {
                    match scanline(data, p, w, None) {
                        Some(next) => {
                            found.push(p);
                            p = next;
                        }
                        None => break,
                    }
                }
                if !found.is_empty() {
                    return (found, p);
                }
                from += at + 1;
            }
            (Vec::new(), hi)
        })
        .collect();
    let mut starts = Vec::with_capacity(h);
    let mut p = first;
    // The true walk through piece `i`, from `p`, until it leaves the piece or has every line.
    let walk = |starts: &mut Vec<usize>, p: &mut usize, end: usize| {
        while *p < end && starts.len() < h {
            let next = scanline(data, *p, w, None).ok_or(starts.len())?;
            starts.push(*p);
            *p = next;
        }
        Ok::<(), usize>(())
    };
    walk(&mut starts, &mut p, bound(1))?;
    for (i, (found, left_off)) in walks.iter().enumerate() {
        if starts.len() == h {
            break;
        }
        match found.binary_search(&p) {
            Ok(k) => {
                let take = (found.len() - k).min(h - starts.len());
                starts.extend_from_slice(&found[k..k + take]);
                p = found.get(k + take).copied().unwrap_or(*left_off);
            }
            Err(_) => walk(&mut starts, &mut p, bound(i + 2))?,
        }
    }
    walk(&mut starts, &mut p, usize::MAX)?;
    Ok(starts)
}

/// Walks the scanline of `w` texels that starts at byte `p`, writing its texels to `out` when
/// given, as four planes of `w` bytes (R, G, B, E: a run-length channel's literals are then
/// one copy, its runs one fill); returns where the next one starts, or None if the line is
/// malformed. New-style lines hold four run-length-coded channels; anything else is old-style
/// texels (flat, or with (1, 1, 1, n) repeat markers).
pub(super) fn scanline(
    data: &[u8],
    mut p: usize,
    w: usize,
    mut out: Option<&mut [u8]>,
) -> Option<usize> {
    let first: [u8; 4] = data.get(p..p + 4)?.try_into().ok()?;
    p += 4;
    if first[0] == 2 && first[1] == 2 && first[2] < 128 {
        for c in 0..4 {
            let mut x = 0;
            while x < w {
                let code = *data.get(p)? as usize;
                p += 1;
                if code <= 128 {
                    let values = data.get(p..p + code)?;
                    if x + code > w {
                        return None;
                    }
                    if let Some(o) = out.as_deref_mut() {
                        o[c * w + x..c * w + x + code].copy_from_slice(values);
                    }
                    p += code;
                    x += code;
                } else {
                    let n = code - 128;
                    let v = *data.get(p)?;
                    p += 1;
                    if x + n > w {
                        return None;
                    }
                    if let Some(o) = out.as_deref_mut() {
                        o[c * w + x..c * w + x + n].fill(v);
                    }
                    x += n;
                }
            }
        }
        return Some(p);
    }
    let marker = |t: &[u8; 4]| t[0] == 1 && t[1] == 1 && t[2] == 1;
    if marker(&first) {
        return None;
    }
    let put = |o: &mut [u8], x: usize, t: [u8; 4]| {
        for (c, v) in t.into_iter().enumerate() {
            o[c * w + x] = v;
        }
    };
    if let Some(o) = out.as_deref_mut() {
        put(o, 0, first);
    }
    let (mut x, mut shift, mut prev) = (1, 0u32, first);
    while x < w {
        let t: [u8; 4] = data.get(p..p + 4)?.try_into().ok()?;
        p += 4;
        if marker(&t) {
            // Consecutive markers count in base 256, least significant first.
            let n = (t[3] as usize).checked_shl(shift).filter(|_| shift < 32)?;
            shift += 8;
            if x + n > w {
                return None;
            }
            if let Some(o) = out.as_deref_mut() {
                for (c, v) in prev.into_iter().enumerate() {
                    o[c * w + x..c * w + x + n].fill(v);
                }
            }
            x += n;
        } else {
            shift = 0;
            prev = t;
            if let Some(o) = out.as_deref_mut() {
                put(o, x, t);
            }
            x += 1;
        }
    }
    Some(p)
}
