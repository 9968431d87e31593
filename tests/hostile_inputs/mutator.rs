//! The mutator: seeded changes to a valid file's bytes, aimed at its header fields.

use crate::common::XorShift;

/// A header field the mutator may set to an extreme value: where, how many bytes (1, 2, 4 or
/// 8) and whether big-endian.
#[derive(Clone, Copy, Debug)]
pub struct Field {
    pub at: usize,
    pub len: usize,
    pub be: bool,
}

impl Field {
    pub fn le(at: usize, len: usize) -> Field {
        Field { at, len, be: false }
    }
    pub fn be(at: usize, len: usize) -> Field {
        Field { at, len, be: true }
    }
    pub fn get(&self, b: &[u8]) -> u64 {
        let mut v = 0u64;
        for i in 0..self.len {
            let byte = *b.get(self.at + i).unwrap_or(&0) as u64;
            v |= if self.be {
                byte << (8 * (self.len - 1 - i))
            } else {
                byte << (8 * i)
            };
        }
        v
    }
    pub fn set(&self, b: &mut [u8], v: u64) {
        for i in 0..self.len {
            let shift = if self.be {
                8 * (self.len - 1 - i)
            } else {
                8 * i
            };
            if let Some(byte) = b.get_mut(self.at + i) {
                *byte = (v >> shift) as u8;
            }
        }
    }
}

/// Values a size or count field is set to: the edges of its width, powers of two, and a
/// little off the true value.
pub fn extreme(rng: &mut XorShift, bits: u32, original: u64) -> u64 {
    let max = if bits >= 64 {
        u64::MAX
    } else {
        (1u64 << bits) - 1
    };
    let v = match rng.below(14) {
        0 => 0,
        1 => 1,
        2 => max,
        3 => max >> 1,
        4 => (max >> 1) + 1,
        5 => original.wrapping_add(1),
        6 => original.wrapping_sub(1),
        7 => original.wrapping_mul(2),
        8 => original << 8,
        9 => 1 << rng.below(bits as usize),
        10 => [16384, 16385, 65535, 65536, 46341, 32768][rng.below(6)],
        11 => original.wrapping_add(rng.below(64) as u64),
        12 => original / 2,
        _ => rng.next(),
    };
    v & max
}

/// Numbers a digit run in text becomes.
pub const NUMBERS: &[&str] = &[
    "0",
    "-1",
    "1e309",
    "-1e309",
    "nan",
    "inf",
    "-0.0",
    "1e-45",
    "4294967296",
    "18446744073709551616",
    "99999999999999999999999999",
    "2147483647",
    "65537",
    "16384",
    "1e38",
    "0x7fffffff",
    "3.4028236e38",
    "0.5",
];

/// Makes mutated copies of one valid file.
pub struct Mutator {
    rng: XorShift,
    fields: Vec<Field>,
    /// Treat the file as text: also cut, repeat and nest lines and brackets.
    pub text: bool,
    /// Run on half the mutated files, to get past checksums (PNG's CRCs).
    fix: Option<fn(&mut [u8])>,
    /// Where numbers in text start (a JSON manifest's sizes, places and lengths): a third of
    /// the changes make one of them extreme. Empty, no random number is drawn for it, so the
    /// campaigns without it make the same files as before.
    numbers: Vec<usize>,
}

impl Mutator {
    pub fn new(seed: u64, fields: Vec<Field>, text: bool) -> Mutator {
        Mutator {
            rng: XorShift(seed | 1),
            fields,
            text,
            fix: None,
            numbers: Vec::new(),
        }
    }

    pub fn numbers_at(mut self, numbers: Vec<usize>) -> Mutator {
        self.numbers = numbers;
        self
    }

    pub fn fixed_by(mut self, fix: fn(&mut [u8])) -> Mutator {
        self.fix = Some(fix);
        self
    }

    /// A place to change: mostly in the first 512 bytes, where the headers are.
    fn place(&mut self, len: usize) -> usize {
        let span = if self.rng.below(4) == 0 {
            len
        } else {
            len.min(512)
        };
        self.rng.below(span)
    }

    pub fn mutate(&mut self, src: &[u8]) -> Vec<u8> {
        let mut b = src.to_vec();
        // Text breaks sooner: fewer changes get further into its parser.
        let changes = 1 + self.rng.below(if self.text { 2 } else { 4 });
        for _ in 0..changes {
            if b.is_empty() {
                b.push(0);
            }
            if !self.numbers.is_empty() && self.rng.below(3) == 0 {
                let at = *self.rng.pick(&self.numbers);
                self.aimed_number(&mut b, at);
                continue;
            }
            let at = self.place(b.len());
            match self.rng.below(if self.text { 14 } else { 10 }) {
                0 => b[at] ^= 1 << self.rng.below(8),
                1 => b[at] = self.rng.next() as u8,
                2 => b[at] = *self.rng.pick(&[0, 0xff, 0x7f, 0x80]),
                3 | 4 if !self.fields.is_empty() => {
                    let f = *self.rng.pick(&self.fields);
                    let v = extreme(&mut self.rng, 8 * f.len as u32, f.get(&b));
                    f.set(&mut b, v);
                }
                3..=5 => {
                    let len = *self.rng.pick(&[2, 4, 8]);
                    let f = Field {
                        at,
                        len,
                        be: self.rng.below(2) == 0,
                    };
                    let v = extreme(&mut self.rng, 8 * len as u32, f.get(&b));
                    f.set(&mut b, v);
                }
                6 => {
                    // Cut a span.
                    let n = (1 + self.rng.below(64)).min(b.len() - at);
                    b.drain(at..at + n);
                }
                7 => {
                    // Repeat a span (a chunk or a segment twice).
                    let n = (1 + self.rng.below(256)).min(b.len() - at);
                    let span = b[at..at + n].to_vec();
                    let to = self.place(b.len());
                    b.splice(to..to, span);
                }
                8 => {
                    let n = 1 + self.rng.below(16);
                    let junk: Vec<u8> = (0..n).map(|_| self.rng.next() as u8).collect();
                    b.splice(at..at, junk);
                }
                9 => self.number(&mut b, at),
                10 => self.number(&mut b, at),
                11 => {
                    // Cut or repeat a line.
                    let start = b[..at]
                        .iter()
                        .rposition(|&c| c == b'\n')
                        .map_or(0, |i| i + 1);
                    let end = b[at..]
                        .iter()
                        .position(|&c| c == b'\n')
                        .map_or(b.len(), |i| at + i + 1);
                    if self.rng.below(2) == 0 {
                        b.drain(start..end);
                    } else {
                        let line = b[start..end].to_vec();
                        b.splice(start..start, line);
                    }
                }
                12 => {
                    // Deep nesting: arrays or tables within each other.
                    let depth = *self.rng.pick(&[64, 200, 1000, 20_000]);
                    let (open, close): (&[u8], &[u8]) = match self.rng.below(3) {
                        0 => (b"[", b"]"),
                        1 => (b"{a=", b"}"),
                        _ => (b"{\"a\":", b"}"),
                    };
                    let mut s = Vec::new();
                    for _ in 0..depth {
                        s.extend_from_slice(open);
                    }
                    s.push(b'1');
                    if self.rng.below(2) == 0 {
                        for _ in 0..depth {
                            s.extend_from_slice(close);
                        }
                    }
                    b.splice(at..at, s);
                }
                _ => {
                    // A quote, bracket or separator where it does not belong.
                    let c = *self.rng.pick(b"\"'[]{}=,.\n#\\");
                    b.insert(at, c);
                }
            }
        }
        if self.rng.below(12) == 0 && !b.is_empty() {
            let keep = self.rng.below(b.len());
            b.truncate(keep);
        }
        if let Some(fix) = self.fix.filter(|_| self.rng.below(2) == 0) {
            fix(&mut b);
        }
        b
    }

    /// Replaces the number at or after `at` with an extreme one: near its value (one off,
    /// doubled, halved: a span that overlaps its neighbour) or a width's edge, half the time,
    /// else one of [`NUMBERS`].
    fn aimed_number(&mut self, b: &mut Vec<u8>, at: usize) {
        if self.rng.below(2) == 0 || at >= b.len() {
            return self.number(b, at.min(b.len()));
        }
        let Some(start) = b[at..].iter().position(u8::is_ascii_digit).map(|i| at + i) else {
            return;
        };
        let end = b[start..]
            .iter()
            .position(|c| !c.is_ascii_digit())
            .map_or(b.len(), |i| start + i);
        let original = std::str::from_utf8(&b[start..end])
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(0);
        let bits = *self.rng.pick(&[8, 32, 64]);
        let v = extreme(&mut self.rng, bits, original).to_string();
        b.splice(start..end, v.into_bytes());
    }

    /// Replaces the digit run at or after `at` with an extreme number.
    fn number(&mut self, b: &mut Vec<u8>, at: usize) {
        let Some(start) = b[at..].iter().position(u8::is_ascii_digit).map(|i| at + i) else {
            return;
        };
        let end = b[start..]
            .iter()
            .position(|c| !(c.is_ascii_digit() || *c == b'.'))
            .map_or(b.len(), |i| start + i);
        let n = self.rng.pick(NUMBERS).as_bytes().to_vec();
        b.splice(start..end, n);
    }
}
