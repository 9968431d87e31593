//! Large zeroed buffers, backed by 2 MiB pages where the kernel has them. A process that
//! converts a 4K panorama touches some 300 MB of fresh memory, and the kernel zeroes every page
//! at its first touch: on the 16-core Xeon this project measures on, 1.1-1.7 GB/s with 4 KiB
//! pages against 4-5 GB/s with 2 MiB ones (one thread; 8-10 against 31-34 GB/s on 16), a
//! tenth of a 2-core conversion's time.

/// Buffers from this size up get the advice (smaller ones hold few whole 2 MiB pages).
const HUGE_FROM: usize = 8 << 20;

/// Types whose all-zero bytes are a valid value.
///
/// # Safety
/// Only for types where that holds.
pub(crate) unsafe trait Zeroable: Copy {}
// SAFETY: plain numbers and vectors of them; zero bytes are 0 (0.0 for floats).
unsafe impl Zeroable for u8 {}
// SAFETY: as above.
unsafe impl Zeroable for glam::Vec4 {}

/// `n` zeroed values. Fresh memory comes zeroed from the kernel, so nothing is written here
/// (memory the allocator reuses it clears); each fresh page is first touched by whoever fills
/// it.
///
/// A failed allocation is a panic with the size, not the allocator's abort, so the command
/// ends with one line.
pub(crate) fn zeroed<T: Zeroable>(n: usize) -> Vec<T> {
    let v = raw::<T>(n, true);
    // SAFETY: the allocation is zeroed, and all-zero bytes are a valid T.
    unsafe { assume_init(v) }
}

/// `n` values left for the caller to write, on 2 MiB pages as `zeroed`'s. For buffers filled
/// in parallel right after: memory the allocator reuses (a decoded file's, say) is not cleared
/// here, on one thread, but by the fillers (on the device, six 16 MB faces cleared serially
/// took 7 ms of a 4K conversion's 20 ms render at 16 threads).
pub(crate) fn uninit<T>(n: usize) -> Vec<std::mem::MaybeUninit<T>> {
    raw::<T>(n, false)
}

/// The values of a vector whose every element has been written.
///
/// # Safety
/// Every element of `v` must be initialised.
pub(crate) unsafe fn assume_init<T>(v: Vec<std::mem::MaybeUninit<T>>) -> Vec<T> {
    let mut v = std::mem::ManuallyDrop::new(v);
    // SAFETY: MaybeUninit<T> has T's size and alignment, so the allocation's layout is the
    // one Vec<T> expects; the caller vouches for the contents.
    unsafe { Vec::from_raw_parts(v.as_mut_ptr() as *mut T, v.len(), v.capacity()) }
}

fn raw<T>(n: usize, zero: bool) -> Vec<std::mem::MaybeUninit<T>> {
    use std::mem::MaybeUninit;
    let v: Vec<MaybeUninit<T>> = match std::alloc::Layout::array::<T>(n) {
        Ok(layout) if layout.size() > 0 => {
            // SAFETY: an allocation of `n` MaybeUninit<T> (any bytes are a valid one) with
            // the layout Vec itself uses, handed to Vec to own and free.
            unsafe {
                let p = if zero {
                    std::alloc::alloc_zeroed(layout)
                } else {
                    std::alloc::alloc(layout)
                } as *mut MaybeUninit<T>;
                if p.is_null() {
                    panic!(
                        "out of memory: cannot allocate {}",
                        human_bytes(layout.size() as u64)
                    );
                }
                Vec::from_raw_parts(p, n, n)
            }
        }
        Ok(_) => (0..n).map(|_| MaybeUninit::uninit()).collect(),
        Err(_) => panic!("out of memory: {n} values are too many to address"),
    };
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let bytes = n * std::mem::size_of::<T>();
        if bytes >= HUGE_FROM {
            let start = v.as_ptr() as usize;
            let first = start.next_multiple_of(HUGE);
            let end = (start + bytes) / HUGE * HUGE;
            if end > first {
                // SAFETY: advice on whole pages inside this vector's own allocation; it
                // changes how the kernel backs them, never their contents.
                unsafe {
                    libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE);
                }
            }
        }
    }
    v
}

/// Bytes as people read them (3.2 GiB, 512 MiB).
pub(crate) fn human_bytes(b: u64) -> String {
    if b >= 1 << 30 {
        format!("{:.1} GiB", b as f64 / (1u64 << 30) as f64)
    } else {
        format!("{:.0} MiB", (b as f64 / (1u64 << 20) as f64).ceil())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zeroed_buffers_are_zero() {
        for n in [0, 1, 1000, (HUGE_FROM + 12345) / 16] {
            let v: Vec<glam::Vec4> = zeroed(n);
            assert_eq!(v.len(), n);
            assert!(v.iter().all(|p| *p == glam::Vec4::ZERO));
        }
        let b: Vec<u8> = zeroed(HUGE_FROM * 2 + 7);
        assert!(b.iter().all(|&x| x == 0));
        let u = uninit::<glam::Vec4>(HUGE_FROM / 16 + 3);
        assert_eq!(u.len(), HUGE_FROM / 16 + 3);
        // Zero-sized types and empty buffers allocate nothing.
        assert_eq!(uninit::<()>(5).len(), 5);
        assert!(uninit::<u8>(0).is_empty());
    }
}
