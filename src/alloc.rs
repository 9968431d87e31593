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
    let v: Vec<T> = match std::alloc::Layout::array::<T>(n) {
        Ok(layout) if layout.size() > 0 => {
            // SAFETY: a zeroed allocation of `n` T (all-zero bytes are a valid T) with the
            // layout Vec<T> itself uses, handed to Vec to own and free.
            unsafe {
                let p = std::alloc::alloc_zeroed(layout) as *mut T;
                if p.is_null() {
                    panic!(
                        "out of memory: cannot allocate {}",
                        crate::io::human_bytes(layout.size() as u64)
                    );
                }
                Vec::from_raw_parts(p, n, n)
            }
        }
        Ok(_) => Vec::new(),
        Err(_) => panic!("out of memory: {n} values are too many to address"),
    };
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let bytes = std::mem::size_of_val(v.as_slice());
        if bytes >= HUGE_FROM {
            let start = v.as_ptr() as usize;
            let first = start.next_multiple_of(HUGE);
            let end = (start + bytes) / HUGE * HUGE;
            if end > first {
                // SAFETY: advice on whole pages inside this vector's own allocation; it
                // changes how the kernel backs them, never their contents (all zero).
                unsafe {
                    libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE);
                }
            }
        }
    }
    v
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
    }
}
