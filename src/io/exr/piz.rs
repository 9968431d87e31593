//! PIZ blocks (OpenEXR's wavelet and Huffman coding) decoded here for the common layout. The
//! exr crate's decoder finds every Huffman code longer than 14 bits by trying the candidates
//! that share its first 14 bits one by one, a byte read at a time; float samples, whose low
//! mantissa bits are noise, are mostly such codes: a 4096 x 2048 float PIZ panorama took 0.63 s
//! to decode on two threads (VM), 4x its ZIP twin. Here a code's length comes from the
//! canonical code's first value per length (at most one comparison per length in use past the
//! 14-bit table), the bits from one unaligned 64-bit load.
//!
//! The format, after OpenEXR's `ImfPizCompressor` and `ImfHuf`: a bitmap of the 16-bit values
//! present and its reverse table, the Huffman-coded words (a repeat symbol with an 8-bit count
//! for runs), each channel's plane of words run through a 2D Haar-like wavelet inverse, then
//! mapped back through the table and interleaved into scan lines.

/// Bits of the direct decoding table (as OpenEXR's own decoder).
const TABLE_BITS: u32 = 14;
/// Symbols: every 16-bit value and the repeat symbol past them.
const SYMBOLS: usize = (1 << 16) + 1;
/// Longest code.
const MAX_LEN: usize = 58;
/// Code-length table escapes: 59-62 stand for 2-5 zero lengths, 63 for 6-261 (an 8-bit count).
const SHORT_ZERO_RUN: u64 = 59;
const LONG_ZERO_RUN: u64 = 63;
const SHORTEST_LONG_RUN: u64 = 2 + LONG_ZERO_RUN - SHORT_ZERO_RUN;

/// Buffers a thread keeps between blocks.
#[derive(Default)]
pub(super) struct Scratch {
    words: Vec<u16>,
    bits: Vec<u8>,
    lengths: Vec<u8>,
    table: Vec<u32>,
    lut: Vec<u16>,
}

/// Decodes one PIZ block of `lines` scan lines of `width` texels whose channels (in file
/// order) take `words` 16-bit words per sample, into `out` in the stored form (for each line,
/// each channel's samples, little-endian).
pub(super) fn decompress(
    data: &[u8],
    words: &[usize],
    width: usize,
    lines: usize,
    s: &mut Scratch,
    out: &mut Vec<u8>,
) -> Result<(), String> {
    let per_texel: usize = words.iter().sum();
    let total = width * lines * per_texel;
    let mut rest = data;
    let mut take = |n: usize| -> Result<&[u8], String> {
        if rest.len() < n {
            return Err("the PIZ block is truncated".into());
        }
        let (head, tail) = rest.split_at(n);
        rest = tail;
        Ok(head)
    };
    let u16_at = |b: &[u8]| u16::from_le_bytes([b[0], b[1]]) as usize;
    let (lo, hi) = (u16_at(take(2)?), u16_at(take(2)?));
    const BITMAP: usize = (1 << 16) / 8;
    if lo >= BITMAP || hi >= BITMAP {
        return Err("the PIZ block's bitmap is out of range".into());
    }
    let mut bitmap = [0u8; BITMAP];
    if lo <= hi {
        bitmap[lo..=hi].copy_from_slice(take(hi - lo + 1)?);
    }
    // The values present, in order (0 always): the words index them.
    s.lut.clear();
    s.lut
        .extend((0..=u16::MAX).filter(|&v| v == 0 || bitmap[v as usize >> 3] >> (v & 7) & 1 != 0));
    let max_value = (s.lut.len() - 1) as u16;
    let length = i32::from_le_bytes(take(4)?.try_into().expect("four bytes"));
    let coded = take(usize::try_from(length).map_err(|_| "the PIZ block's length is negative")?)?;
    s.words.clear();
    s.words.resize(total, 0);
    huffman(
        coded,
        &mut s.words,
        &mut s.bits,
        &mut s.lengths,
        &mut s.table,
    )?;
    // Each channel's plane, each word of a sample (a float's two halves) on its own.
    let mut start = 0;
    for &n in words {
        let plane = &mut s.words[start..start + width * lines * n];
        for offset in 0..n {
            wavelet_decode(&mut plane[offset..], width, lines, n, width * n, max_value);
        }
        start += width * lines * n;
    }
    let lut = &s.lut;
    for w in s.words.iter_mut() {
        // Words past the table's end are what the table holds there: 0.
        *w = lut.get(*w as usize).copied().unwrap_or(0);
    }
    out.clear();
    out.reserve(2 * total);
    for y in 0..lines {
        let mut start = 0;
        for &n in words {
            let row = &s.words[start + y * width * n..start + (y + 1) * width * n];
            out.extend(row.iter().flat_map(|w| w.to_le_bytes()));
            start += width * lines * n;
        }
    }
    Ok(())
}

/// The error for a PIZ block's Huffman data that `what`.
fn bad<T>(what: &str) -> Result<T, String> {
    Err(format!("the PIZ block's Huffman data {what}"))
}

/// OpenEXR's Huffman stream into `out`, which it must fill exactly.
fn huffman(
    data: &[u8],
    out: &mut [u16],
    bits: &mut Vec<u8>,
    lengths: &mut Vec<u8>,
    table: &mut Vec<u32>,
) -> Result<(), String> {
    if out.is_empty() {
        return Ok(());
    }
    let (first_sym, last_sym, n_bits) = header(data)?;
    let stream_bytes = data.len() - 20;
    // The stream, padded so a 64-bit read past its end finds zeros.
    bits.clear();
    bits.extend_from_slice(&data[20..]);
    bits.resize(stream_bytes + 16, 0);
    let pos = code_lengths(bits, stream_bytes, (first_sym, last_sym), lengths)?;
    // The codes start at the next whole byte.
    let (start, avail) = (pos.div_ceil(8) * 8, 8 * stream_bytes as u64);
    if start > avail {
        return bad("is truncated in its code table");
    }
    if n_bits > avail - start {
        return bad("claims more bits than it holds");
    }
    let code = canonical(lengths, (first_sym, last_sym), table)?;
    decode(
        bits,
        start..start + n_bits,
        table,
        &code,
        last_sym as u32,
        out,
    )
}

/// The header, every field checked against the block before use: the first and last symbol
/// of the code table (the last is the repeat symbol), the table's length in bytes (OpenEXR's
/// own reader ignores it; it must still fit), the coded bits, and a reserved word.
fn header(data: &[u8]) -> Result<(usize, usize, u64), String> {
    if data.len() < 20 {
        return bad("is truncated");
    }
    let word = |i: usize| u32::from_le_bytes(data[4 * i..4 * i + 4].try_into().expect("4 bytes"));
    let (first_sym, last_sym) = (word(0) as usize, word(1) as usize);
    let (table_len, n_bits) = (word(2) as usize, word(3) as u64);
    let stream_bytes = data.len() - 20;
    if first_sym >= SYMBOLS || last_sym >= SYMBOLS {
        return Err(format!(
            "the PIZ block's Huffman data has an invalid table size (symbols {first_sym} to {last_sym}, at most {})",
            SYMBOLS - 1
        ));
    }
    if first_sym > last_sym {
        return Err(format!(
            "the PIZ block's Huffman data has its first symbol ({first_sym}) after its last ({last_sym})"
        ));
    }
    if table_len > stream_bytes {
        return Err(format!(
            "the PIZ block's Huffman data claims a {table_len}-byte code table in {stream_bytes} bytes"
        ));
    }
    Ok((first_sym, last_sym, n_bits))
}

/// Code lengths into `lengths`, six bits each from the first symbol to the last, with runs
/// of zeros; returns the bit position after them.
fn code_lengths(
    bits: &[u8],
    stream_bytes: usize,
    (first_sym, last_sym): (usize, usize),
    lengths: &mut Vec<u8>,
) -> Result<u64, String> {
    lengths.clear();
    lengths.resize(SYMBOLS, 0);
    let mut pos = 0u64;
    let read = |n: u32, pos: &mut u64| -> u64 {
        let v = peek(bits, *pos) >> (64 - n);
        *pos += n as u64;
        v
    };
    let mut sym = first_sym;
    while sym <= last_sym {
        if pos > 8 * stream_bytes as u64 {
            return bad("is truncated in its code table");
        }
        let l = read(6, &mut pos);
        let zeros = if l == LONG_ZERO_RUN {
            (read(8, &mut pos) + SHORTEST_LONG_RUN) as usize
        } else if l >= SHORT_ZERO_RUN {
            (l - SHORT_ZERO_RUN + 2) as usize
        } else {
            lengths[sym] = l as u8;
            sym += 1;
            continue;
        };
        if sym + zeros > last_sym + 1 {
            return bad("has a code table that runs past its end");
        }
        sym += zeros;
    }
    Ok(pos)
}

/// The canonical code's codes longer than the direct table's bits.
struct LongCodes {
    /// Per length, its first code's value (longer codes take the smaller values).
    first: [u64; MAX_LEN + 1],
    /// Per length in use, the symbols in code order.
    syms: Vec<Vec<u32>>,
    /// The lengths above `TABLE_BITS` in use, shortest first.
    lens: Vec<usize>,
}

/// The canonical code of `lengths`: per length, its count and first value, and the symbols
/// by length then value; short codes into the direct `table` (entry = symbol << 8 | length,
/// length 0: longer than `TABLE_BITS`), the long ones returned.
fn canonical(
    lengths: &[u8],
    (first_sym, last_sym): (usize, usize),
    table: &mut Vec<u32>,
) -> Result<LongCodes, String> {
    let mut count = [0u64; MAX_LEN + 1];
    for &l in &lengths[first_sym..=last_sym] {
        count[l as usize] += 1;
    }
    count[0] = 0;
    let mut first = [0u64; MAX_LEN + 1];
    let mut c = 0u64;
    for l in (1..=MAX_LEN).rev() {
        first[l] = c;
        c = (c + count[l]) >> 1;
        if first[l] + count[l] > 1 << l {
            return bad("has a code too long for its length");
        }
    }
    let mut next = first;
    table.clear();
    table.resize(1 << TABLE_BITS, 0);
    let mut syms: Vec<Vec<u32>> = vec![Vec::new(); MAX_LEN + 1];
    for (s, &l) in lengths
        .iter()
        .enumerate()
        .take(last_sym + 1)
        .skip(first_sym)
    {
        let l = l as u32;
        if l == 0 {
            continue;
        }
        let code = next[l as usize];
        next[l as usize] += 1;
        if l <= TABLE_BITS {
            let from = (code << (TABLE_BITS - l)) as usize;
            table[from..from + (1 << (TABLE_BITS - l))].fill((s as u32) << 8 | l);
        } else {
            syms[l as usize].push(s as u32);
        }
    }
    let lens: Vec<usize> = (TABLE_BITS as usize + 1..=MAX_LEN)
        .filter(|&l| count[l] > 0)
        .collect();
    Ok(LongCodes { first, syms, lens })
}

/// The coded bits `range` of `bits` into `out`, which they must fill exactly; `repeat`, the
/// last symbol, repeats the sample before it as many times as the next byte says.
fn decode(
    bits: &[u8],
    range: std::ops::Range<u64>,
    table: &[u32],
    long: &LongCodes,
    repeat: u32,
    out: &mut [u16],
) -> Result<(), String> {
    let (mut pos, end) = (range.start, range.end);
    let mut o = 0usize;
    while pos < end {
        let w = peek(bits, pos);
        let e = table[(w >> (64 - TABLE_BITS)) as usize];
        let (sym, len) = if e & 0xff != 0 {
            (e >> 8, (e & 0xff) as u64)
        } else {
            // The shortest length whose first code the bits reach is the code's length.
            let Some(&l) = long.lens.iter().find(|&&l| w >> (64 - l) >= long.first[l]) else {
                return bad("holds an invalid code");
            };
            let i = (w >> (64 - l)) - long.first[l];
            match long.syms[l].get(i as usize) {
                Some(&s) => (s, l as u64),
                None => return bad("holds an invalid code"),
            }
        };
        pos += len;
        if sym == repeat {
            let n = (peek(bits, pos) >> 56) as usize;
            pos += 8;
            if o == 0 || o + n > out.len() {
                return bad("repeats past the block's samples");
            }
            let v = out[o - 1];
            out[o..o + n].fill(v);
            o += n;
        } else {
            if o >= out.len() || sym > u16::MAX as u32 {
                return bad("holds more samples than the block");
            }
            out[o] = sym as u16;
            o += 1;
        }
    }
    if pos != end || o != out.len() {
        return bad("does not end with the block's last sample");
    }
    Ok(())
}

/// The 64 bits of `bits` from bit `pos` on (most significant first); `bits` holds at least 9
/// bytes past `pos / 8`.
#[inline(always)]
fn peek(bits: &[u8], pos: u64) -> u64 {
    let i = (pos >> 3) as usize;
    let s = (pos & 7) as u32;
    let hi = u64::from_be_bytes(bits[i..i + 8].try_into().expect("8 bytes"));
    let lo = bits[i + 8] as u64;
    (hi << s) | ((lo << s) >> 8)
}

/// OpenEXR's inverse wavelet over an `nx` x `ny` plane of words `ox` apart in x and `oy` in y.
fn wavelet_decode(buf: &mut [u16], nx: usize, ny: usize, ox: usize, oy: usize, max: u16) {
    if max < 1 << 14 {
        wavelet_levels(buf, nx, ny, ox, oy, dec14);
    } else {
        wavelet_levels(buf, nx, ny, ox, oy, dec16);
    }
}

#[inline(always)]
fn wavelet_levels(
    buf: &mut [u16],
    nx: usize,
    ny: usize,
    ox: usize,
    oy: usize,
    dec: impl Fn(u16, u16) -> (u16, u16),
) {
    let n = nx.min(ny);
    let mut p = 1;
    while p <= n {
        p <<= 1;
    }
    p >>= 1;
    let mut p2 = p;
    p >>= 1;
    while p >= 1 {
        let (ox1, oy1, ox2, oy2) = (ox * p, oy * p, ox * p2, oy * p2);
        let ey = oy * (ny - p2);
        let mut py = 0;
        while py <= ey {
            let ex = py + ox * (nx - p2);
            let mut px = py;
            while px <= ex {
                let (p01, p10) = (px + ox1, px + oy1);
                let p11 = p10 + ox1;
                let (i00, i10) = dec(buf[px], buf[p10]);
                let (i01, i11) = dec(buf[p01], buf[p11]);
                (buf[px], buf[p01]) = dec(i00, i01);
                (buf[p10], buf[p11]) = dec(i10, i11);
                px += ox2;
            }
            // An odd column left over.
            if nx & p != 0 {
                let p10 = px + oy1;
                (buf[px], buf[p10]) = dec(buf[px], buf[p10]);
            }
            py += oy2;
        }
        // An odd line left over.
        if ny & p != 0 {
            let ex = py + ox * (nx - p2);
            let mut px = py;
            while px <= ex {
                let p01 = px + ox1;
                (buf[px], buf[p01]) = dec(buf[px], buf[p01]);
                px += ox2;
            }
        }
        p2 = p;
        p >>= 1;
    }
}

/// The 14-bit inverse step (values small enough that plain sums cannot overflow).
#[inline(always)]
fn dec14(l: u16, h: u16) -> (u16, u16) {
    let (ls, hs) = (l as i16 as i32, h as i16 as i32);
    let a = ls + (hs & 1) + (hs >> 1);
    (a as i16 as u16, (a - hs) as i16 as u16)
}

/// The 16-bit inverse step (modular arithmetic).
#[inline(always)]
fn dec16(l: u16, h: u16) -> (u16, u16) {
    const OFFSET: i32 = 1 << 15;
    let (m, d) = (l as i32, h as i32);
    let b = (m - (d >> 1)) & 0xffff;
    let a = (d + b - OFFSET) & 0xffff;
    (a as u16, b as u16)
}
