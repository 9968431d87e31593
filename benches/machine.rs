//! What the machine itself allows, for reading the scaling of the other benches: filling fresh
//! memory (the kernel zeroes each page at its first touch), streaming through memory already
//! touched, and arithmetic alone, each split over rayon's threads. Run it at 2 threads and at
//! many (`RAYON_NUM_THREADS=2 taskset -c 4,5 cargo bench --bench machine`, then without):
//! a job that moves as much memory as it computes cannot scale better than these do.

use rayon::prelude::*;
use std::time::Instant;

const MB: usize = 256;
const HUGE: usize = 2 << 20;
const RUNS: usize = 5;

fn best(mut f: impl FnMut() -> f64) -> f64 {
    (0..RUNS).map(|_| f()).fold(f64::MAX, f64::min)
}

/// Fresh anonymous memory, 2 MiB-aligned, backed by 2 MiB pages or refused them.
#[cfg(target_os = "linux")]
fn fresh_fill(bytes: usize, huge: bool) -> f64 {
    // SAFETY: a private anonymous mapping of our own, written only through the slice made
    // from it below, and unmapped whole before returning.
    unsafe {
        let len = bytes + HUGE;
        let p = libc::mmap(
            std::ptr::null_mut(),
            len,
            libc::PROT_READ | libc::PROT_WRITE,
            libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
            -1,
            0,
        );
        assert!(p != libc::MAP_FAILED, "mmap failed");
        let a = (p as usize).next_multiple_of(HUGE) as *mut u8;
        let advice = if huge {
            libc::MADV_HUGEPAGE
        } else {
            libc::MADV_NOHUGEPAGE
        };
        libc::madvise(a as *mut libc::c_void, bytes, advice);
        let buf = std::slice::from_raw_parts_mut(a, bytes);
        let t = Instant::now();
        buf.par_chunks_mut(HUGE).for_each(|c| c.fill(1));
        let e = t.elapsed().as_secs_f64();
        libc::munmap(p, len);
        e
    }
}

fn main() {
    let threads = rayon::current_num_threads();
    let bytes = MB << 20;
    println!("on {threads} threads, best of {RUNS}:");
    #[cfg(target_os = "linux")]
    for (huge, name) in [(true, "2 MiB"), (false, "4 KiB")] {
        let s = best(|| fresh_fill(bytes, huge));
        println!(
            "  fresh memory filled, {name} pages: {MB} MB in {:.1} ms ({:.1} GB/s)",
            s * 1e3,
            bytes as f64 / s / 1e9
        );
    }
    let a = vec![1.0f32; bytes / 4];
    let mut b = vec![0.0f32; bytes / 4];
    let s = best(|| {
        let t = Instant::now();
        b.par_chunks_mut(1 << 16)
            .zip(a.par_chunks(1 << 16))
            .for_each(|(o, i)| o.iter_mut().zip(i).for_each(|(o, i)| *o = i * 1.5 + 0.25));
        t.elapsed().as_secs_f64()
    });
    println!(
        "  streaming, {MB} MB read and {MB} MB written: {:.1} ms ({:.1} GB/s)",
        s * 1e3,
        2.0 * bytes as f64 / s / 1e9
    );
    let s = best(|| {
        let t = Instant::now();
        let r: f64 = (0..1u64 << 16)
            .into_par_iter()
            .map(|i| (0..200).fold(i as f64 * 1e-6, |x, _| (x * 1.000_000_1 + 0.3).sin()))
            .sum();
        std::hint::black_box(r);
        t.elapsed().as_secs_f64()
    });
    println!("  arithmetic alone (13 M sines): {:.1} ms", s * 1e3);
    std::hint::black_box((&a, &b));
}
