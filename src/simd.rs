//! Hot loops compiled a second time for x86-64's AVX2 and FMA and chosen at run time, so
//! one portable binary uses the wider instructions where the CPU has them (the HDR faces
//! job's row loops: 5-15% faster on the device's Xeon). Only where measured to help: the
//! panorama lookups wrapped the same way got slower. Results are the same bits either way:
//! Rust never fuses a multiply and an add or reorders float sums by itself, and `mul_add` is
//! exact on both (a CPU without FMA computes it in software: the exact window sums, which use
//! it, run many times slower there, but give the same bits).

/// A hot loop and its arguments. `run` must be `#[inline(always)]`: called directly from
/// each build of [`fast`], it is then compiled into both (a closure would not be: the
/// compiler leaves a large one out of line, built once without the wider instructions).
pub(crate) trait Kernel {
    type Output;
    fn run(self) -> Self::Output;
}

/// `kernel.run()`, compiled for AVX2 and FMA when this CPU has them. What `run` inlines gets
/// the wider instructions; calls through `dyn` do not (those dispatch themselves).
#[inline(always)]
pub(crate) fn fast<K: Kernel>(kernel: K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: the CPU has every feature `avx2` is compiled for (checked just above).
        return unsafe { avx2(kernel) };
    }
    kernel.run()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2,fma,bmi1,bmi2,lzcnt,popcnt,f16c,sse4.1,sse4.2")]
unsafe fn avx2<K: Kernel>(kernel: K) -> K::Output {
    kernel.run()
}

/// A tuple of arguments and an `#[inline(always)]` fn taking it, as a kernel.
macro_rules! kernel {
    ($name:ident $(<$($g:ident),*>)? ($args:ty) -> $out:ty = $f:path $(where $($w:tt)*)?) => {
        struct $name<'k $($(, $g)*)?>($args, std::marker::PhantomData<&'k ()>);
        impl<'k $($(, $g)*)?> $crate::simd::Kernel for $name<'k $($(, $g)*)?> $(where $($w)*)? {
            type Output = $out;
            #[inline(always)]
            fn run(self) -> $out {
                $f(self.0)
            }
        }
    };
}
pub(crate) use kernel;

/// Whether AVX2, FMA and their companions can run here and are wanted: for code that
/// dispatches itself to intrinsics.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn avx2_available() -> bool {
    has_avx2()
}

/// Whether AVX2 and its companions can run here (detected once; a load afterwards). The
/// environment variable CUBEFORGE_NO_AVX2 turns them off, to compare or to test both paths.
#[cfg(target_arch = "x86_64")]
fn has_avx2() -> bool {
    use std::sync::atomic::{AtomicU8, Ordering};
    static STATE: AtomicU8 = AtomicU8::new(0);
    match STATE.load(Ordering::Relaxed) {
        1 => true,
        2 => false,
        _ => {
            let yes = std::env::var_os("CUBEFORGE_NO_AVX2").is_none()
                && std::is_x86_feature_detected!("avx")
                && std::is_x86_feature_detected!("avx2")
                && std::is_x86_feature_detected!("fma")
                && std::is_x86_feature_detected!("bmi1")
                && std::is_x86_feature_detected!("bmi2")
                && std::is_x86_feature_detected!("lzcnt")
                && std::is_x86_feature_detected!("popcnt")
                && std::is_x86_feature_detected!("f16c")
                && std::is_x86_feature_detected!("sse4.2");
            STATE.store(if yes { 1 } else { 2 }, Ordering::Relaxed);
            yes
        }
    }
}
