//! Size and memory limits, checked from a file's header before any pixel memory is spent.

use crate::alloc::human_bytes;
use crate::error::{Error, LimitKind, Result};
use std::cell::Cell;
use std::path::Path;

/// What a file's header says decoding it takes: read before any file of a command is
/// decoded, so the whole input (six faces, a chain's levels) is checked against the budget
/// at once ([`crate::io::claim`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Claim {
    /// Width in pixels (a face's, for a cube map).
    pub width: u64,
    /// Height in pixels.
    pub height: u64,
    /// Six faces with their mip levels (a KTX2, DDS, KTX or .env cube map).
    pub cube: bool,
    /// Bytes in use at the peak of decoding it: the file's bytes, the texels and, at worst,
    /// a decoder's buffer of the same size.
    pub decode_bytes: u64,
    /// Bytes its decoded texels keep (RGBA f32, with every mip level of a cube map).
    pub held_bytes: u64,
}

thread_local! {
    /// Set while [`crate::io::claim`] runs a decoder up to its size check: the check
    /// records what it was asked (`CLAIMED`) and stops the decoder there.
    static PROBING: Cell<bool> = const { Cell::new(false) };
    static CLAIMED: Cell<Option<(u64, u64, bool)>> = const { Cell::new(None) };
}

/// Runs `decode` with the size checks recording their sizes and stopping it: the header's
/// claim, if a check was reached, and what `decode` returned.
pub(crate) fn probing<T>(decode: impl FnOnce() -> T) -> (T, Option<(u64, u64, bool)>) {
    /// Ends the probe however `decode` ends (a panic too): a later decode on this thread
    /// must not stop at its size check.
    struct Ends;
    impl Drop for Ends {
        fn drop(&mut self) {
            PROBING.with(|p| p.set(false));
        }
    }
    PROBING.with(|p| p.set(true));
    CLAIMED.with(|c| c.set(None));
    let ends = Ends;
    let out = decode();
    drop(ends);
    (out, CLAIMED.with(|c| c.take()))
}

/// In a probe, records the size a decoder checks and stops it (an error no one sees).
fn probed(path: &Path, w: u64, h: u64, cube: bool) -> Result<()> {
    if !PROBING.with(|p| p.get()) {
        return Ok(());
    }
    CLAIMED.with(|c| c.set(Some((w, h, cube))));
    Err(Error::file(path, "size read from the header"))
}

/// Refuses images larger than this before any pixel memory is allocated.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// Most pixels in one image (width x height).
    pub max_pixels: u64,
    /// Longest edge in pixels.
    pub max_dimension: u32,
    /// Bytes a command may plan to use (default: half of what this process may use: the
    /// machine's memory, a container's limit or an address-space cap, whichever is least).
    pub max_memory: u64,
    /// Where reads are recorded and decoded inputs shared ([`super::Session`]; the default
    /// records nothing).
    pub session: super::Session,
}

/// Half the memory this process may have: the default memory budget. That is the machine's
/// physical memory, or less where a limit says so: a container's cgroup (`memory.max`) or an
/// address-space cap (`ulimit -v`, where an allocation past it aborts the process).
pub(crate) fn default_memory_budget() -> u64 {
    let mut most = 16u64 << 30;
    #[cfg(unix)]
    {
        // SAFETY: sysconf only reads system constants; getrlimit fills the struct it is given.
        let (pages, size, cap) = unsafe {
            let mut r: libc::rlimit = std::mem::zeroed();
            let cap = if libc::getrlimit(libc::RLIMIT_AS, &mut r) == 0
                && r.rlim_cur != libc::RLIM_INFINITY
            {
                Some(r.rlim_cur as u64)
            } else {
                None
            };
            (
                libc::sysconf(libc::_SC_PHYS_PAGES),
                libc::sysconf(libc::_SC_PAGESIZE),
                cap,
            )
        };
        if pages > 0 && size > 0 {
            most = (pages as u64).saturating_mul(size as u64);
        }
        if let Some(cap) = cap {
            most = most.min(cap);
        }
    }
    #[cfg(target_os = "linux")]
    if let Some(max) = std::fs::read_to_string("/sys/fs/cgroup/memory.max")
        .ok()
        .and_then(|t| t.trim().parse::<u64>().ok())
    {
        most = most.min(max);
    }
    most / 2
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_pixels: 32768 * 16384,
            max_dimension: 65536,
            max_memory: default_memory_budget(),
            session: Default::default(),
        }
    }
}

impl Limits {
    /// Checks a declared size (from a header) against the limit.
    pub fn check(&self, path: &Path, w: u64, h: u64) -> Result<()> {
        self.check_image(path, w, h)?;
        probed(path, w, h, false)
    }

    fn check_image(&self, path: &Path, w: u64, h: u64) -> Result<()> {
        self.check_pixels(path, w, h)?;
        // The RGBA f32 image and, at worst, a decoder's buffer of the same size.
        let needs = w.saturating_mul(h).saturating_mul(32);
        self.check_decode_memory(path, format_args!("image claims {w}x{h} pixels"), needs)
    }

    /// The size limits alone: a file decoded in bands never holds its whole image, so its
    /// reader checks the memory its bands take instead ([`Limits::check_memory`]).
    pub(crate) fn check_pixels(&self, path: &Path, w: u64, h: u64) -> Result<()> {
        if w == 0 || h == 0 {
            return Err(Error::file(path, format!("image is empty ({w}x{h})")));
        }
        if w > self.max_dimension as u64
            || h > self.max_dimension as u64
            || w.saturating_mul(h) > self.max_pixels
        {
            return Err(Error::limit(
                Some(path),
                LimitKind::Pixels,
                format!(
                    "image claims {w}x{h} pixels, over the limit of {} pixels ({} per side)",
                    self.max_pixels, self.max_dimension
                ),
            ));
        }
        Ok(())
    }

    /// Refuses a file whose claimed size (`claim`) needs more than the memory budget to decode.
    fn check_decode_memory(
        &self,
        path: &Path,
        claim: std::fmt::Arguments,
        needs: u64,
    ) -> Result<()> {
        if needs > self.max_memory {
            return Err(Error::limit(
                Some(path),
                LimitKind::Memory,
                format!(
                    "{claim}, about {} of memory to decode, over the budget of {}",
                    human_bytes(needs),
                    human_bytes(self.max_memory)
                ),
            ));
        }
        Ok(())
    }

    /// Refuses a plan that needs more than the memory budget, naming what needs it.
    pub fn check_memory(&self, what: impl std::fmt::Display, bytes: u64) -> Result<()> {
        self.check_memory_for(None, what, bytes)
    }

    /// [`Self::check_memory`] of work on `file`, which the refusal names: a job's plan is
    /// mostly its input's, and a header that claims a huge image must be findable.
    pub fn check_memory_for(
        &self,
        file: Option<&Path>,
        what: impl std::fmt::Display,
        bytes: u64,
    ) -> Result<()> {
        if bytes > self.max_memory {
            let default = if self.max_memory == default_memory_budget() {
                " (the default: half of what this process may use)"
            } else {
                ""
            };
            return Err(Error::limit(
                file,
                LimitKind::Memory,
                format!(
                    "{what} needs about {} of memory, over the budget of {}{default}",
                    human_bytes(bytes),
                    human_bytes(self.max_memory)
                ),
            ));
        }
        Ok(())
    }
}

impl Limits {
    /// Checks a cube map's declared face size: all six faces count against the pixel limit.
    pub(crate) fn check_cube(&self, path: &Path, w: u64, h: u64) -> Result<()> {
        self.check_image(path, w, h)?;
        if w.saturating_mul(h).saturating_mul(6) > self.max_pixels {
            return Err(Error::limit(
                Some(path),
                LimitKind::Pixels,
                format!(
                    "cube map claims six {w}x{h} faces, over the limit of {} pixels",
                    self.max_pixels
                ),
            ));
        }
        // Six faces and their mips (4/3) as RGBA f32, and the file's own texels at worst.
        let needs = w.saturating_mul(h).saturating_mul(6 * 32 * 4 / 3);
        self.check_decode_memory(
            path,
            format_args!("cube map claims six {w}x{h} faces"),
            needs,
        )?;
        probed(path, w, h, true)
    }
}
