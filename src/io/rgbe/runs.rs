//! The run-length form of one channel, and the byte scans it is made of. The scans are the
//! encoder's hot loop, hence their SSE2 and word-at-a-time paths (tested against plain loops).

/// Appends one channel of a scanline in the run-length form: runs of 4 to 127 equal bytes as
/// (128 + n, byte), everything else as literals of up to 128 bytes (n, bytes...).
pub(super) fn run_length(data: &[u8], out: &mut Vec<u8>) {
    let n = data.len();
    let mut i = 0;
    while i < n {
        // Literals up to the next run of four (or the end), at most 128 at a time.
        let run_start = next_run(data, i).unwrap_or(n);
        while i < run_start {
            let k = (run_start - i).min(128);
            out.push(k as u8);
            out.extend_from_slice(&data[i..i + k]);
            i += k;
        }
        if run_start < n {
            let byte = data[run_start];
            let len = equal_bytes(data, run_start, n.min(run_start + 127));
            out.extend_from_slice(&[128 + len as u8, byte]);
            i = run_start + len;
        }
    }
}

/// How many bytes from `start` (before `end`) equal the byte at `start`: sixteen at a time
/// with SSE2 on x86-64.
#[inline]
pub(super) fn equal_bytes(data: &[u8], start: usize, end: usize) -> usize {
    let byte = data[start];
    let mut i = start;
    #[cfg(target_arch = "x86_64")]
    while i + 16 <= end {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of x86-64; the load ends at i + 16 <= end <= data.len().
        let same = unsafe {
            let v = _mm_loadu_si128(data.as_ptr().add(i) as *const __m128i);
            _mm_movemask_epi8(_mm_cmpeq_epi8(v, _mm_set1_epi8(byte as i8))) as u32
        };
        if same != 0xffff {
            return i + (!same).trailing_zeros() as usize - start;
        }
        i += 16;
    }
    while i < end && data[i] == byte {
        i += 1;
    }
    i - start
}

/// The first position at or after `from` where four equal bytes start. Sixteen at a time
/// with SSE2 on x86-64; elsewhere (and for the last bytes) eight positions are
/// compared with their successors at once (a word and the word one byte on: a zero byte of
/// their xor marks an equal pair), six starts tested per word.
pub(super) fn next_run(data: &[u8], from: usize) -> Option<usize> {
    const LOW7: u64 = 0x7f7f_7f7f_7f7f_7f7f;
    let n = data.len();
    let word = |at: usize| u64::from_le_bytes(data[at..at + 8].try_into().expect("8 bytes"));
    let mut j = from;
    // Sixteen starts at once with SSE2: each byte against the next three.
    #[cfg(target_arch = "x86_64")]
    while j + 19 <= n {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of x86-64; the four 16-byte loads end at j + 19 <= n.
        let starts = unsafe {
            let at = |k: usize| _mm_loadu_si128(data.as_ptr().add(j + k) as *const __m128i);
            let a = at(0);
            let eq = |k: usize| _mm_cmpeq_epi8(a, at(k));
            _mm_movemask_epi8(_mm_and_si128(_mm_and_si128(eq(1), eq(2)), eq(3))) as u32
        };
        if starts != 0 {
            return Some(j + starts.trailing_zeros() as usize);
        }
        j += 16;
    }
    while j + 9 <= n {
        let t = word(j) ^ word(j + 1);
        // High bit of each byte set exactly where that byte of t is zero.
        let equal = !(((t & LOW7) + LOW7) | t | LOW7);
        let starts = equal & (equal >> 8) & (equal >> 16) & 0x0000_8080_8080_8080;
        if starts != 0 {
            return Some(j + starts.trailing_zeros() as usize / 8);
        }
        j += 6;
    }
    (j..n.saturating_sub(3)).find(|&p| {
        let v = data[p];
        data[p + 1] == v && data[p + 2] == v && data[p + 3] == v
    })
}
