//! Hostile files at every front door: seeded mutations (bit flips, overwritten bytes, header
//! fields set to extreme values, numbers in text made huge, spans cut, repeated or inserted,
//! truncation) of small valid files that cubeforge's own encoders make here, and of the real
//! fixtures (../shared/fixtures/real, skipped when absent), read through `cubeforge::internals::io::read`
//! with a small budget. Each must read or fail with a one-line error naming the file: never a
//! panic, an abort, or an allocation beyond the budget. The text front doors (control recipes,
//! material files, a control map's sidecar, a DDS chain's levels.json) get the same.
//!
//! The machinery (the mutator, the campaign loop, the front door) is in `hostile_inputs/`
//! beside the campaigns: images (PNG, JPEG, TGA, HDR, EXR, KTX2, DDS), engine containers
//! (KTX 1, Babylon .env), text, tiny files claiming huge sizes, the streamed paths (`info`,
//! `ibl` and `prefilter` of OpenEXR and .hdr panoramas folded in bands, and UltraHDR) and,
//! `#[ignore]`d, 16K panoramas in a megabyte (`big.rs`). The command line's half (batch
//! manifests, the jobs under `ulimit -v`) is `tests/tools/hostile_sweep.py`.
//!
//! The same seeds give the same files on every run. `HOSTILE_ROUNDS=n` runs n times as many
//! mutations (a long campaign), `HOSTILE_EXTRA=DIR` adds the files in DIR to it (say, progressive
//! JPEGs from another program; never commit them), `HOSTILE_KEEP=DIR` writes each source's
//! slowest mutation there, `HOSTILE_VERBOSE=1` prints every refusal, and every source prints
//! its slowest mutation (for finding slow inputs by hand; no test here depends on time).

#[path = "hostile_inputs/big.rs"]
mod big;
#[path = "hostile_inputs/claims.rs"]
mod claims;
#[path = "common/mod.rs"]
mod common;
#[path = "hostile_inputs/engine.rs"]
mod engine;
#[path = "hostile_inputs/harness.rs"]
mod harness;
#[path = "hostile_inputs/images.rs"]
mod images;
#[path = "hostile_inputs/mutator.rs"]
mod mutator;
#[path = "hostile_inputs/streamed.rs"]
mod streamed;
#[path = "hostile_inputs/text.rs"]
mod text;

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Single allocations over this are refused, which aborts the test binary (a failure that
/// cannot go unnoticed) instead of taking the machine's memory: with [`harness::limits`] no reader
/// needs a tenth of it, so one that asks has trusted a size it should have checked.
const ALLOC_CAP: usize = 1 << 30;

/// The largest single allocation any test here made.
pub static LARGEST: AtomicUsize = AtomicUsize::new(0);

struct Capped;

impl Capped {
    fn admit(size: usize) -> bool {
        LARGEST.fetch_max(size, Ordering::Relaxed);
        if size > ALLOC_CAP {
            // No formatting (it could allocate): the size in hex, written by hand.
            let mut msg = *b"hostile_inputs: refused an allocation of 0x0000000000000000 bytes\n";
            let at = msg.iter().position(|&c| c == b'x').unwrap() + 1;
            for i in 0..16 {
                msg[at + i] = b"0123456789abcdef"[(size >> (60 - 4 * i)) & 15];
            }
            use std::io::Write;
            let _ = std::io::stderr().write_all(&msg);
            return false;
        }
        true
    }
}

// SAFETY: every call is passed on to the system allocator unchanged, or refused with null.
unsafe impl GlobalAlloc for Capped {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !Self::admit(layout.size()) {
            return std::ptr::null_mut();
        }
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !Self::admit(layout.size()) {
            return std::ptr::null_mut();
        }
        System.alloc_zeroed(layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if !Self::admit(new_size) {
            return std::ptr::null_mut();
        }
        System.realloc(ptr, layout, new_size)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
}

#[global_allocator]
static ALLOCATOR: Capped = Capped;
