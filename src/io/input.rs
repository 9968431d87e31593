//! Reading input files: regular files only (never a FIFO or a device), large ones in
//! parallel pieces; standard input up to the memory budget; the decoder picked by content;
//! and what a file's header claims, read before any file of a command is decoded.

use super::{
    babylon_env, dds, exr, human_bytes, ktx1, ktx2, limits, raster, rgbe, Claim, Decoded,
    FileFormat, Limits, Meta, ReadOptions,
};
use crate::error::{Error, LimitKind, Result};
use std::path::Path;

/// Reads a whole file, refusing anything that is not a regular file first: a FIFO would block
/// forever and a device (`/dev/zero`) read without end. A large file is read in pieces in
/// parallel, each byte once: copying a 100 MB panorama into fresh memory, a page fault every
/// 4 KiB, took a tenth of a second on one thread.
pub(crate) fn read_file(path: &Path) -> Result<Vec<u8>> {
    regular_file(path)?;
    let fail = |e| Error::io(path, e);
    #[cfg(unix)]
    {
        use rayon::prelude::*;
        use std::io::{Read, Seek};
        use std::os::unix::fs::FileExt;
        // Pieces of one 2 MiB page each (the buffer's pages, not the file's): a page the
        // kernel backs with a 2 MiB page is zeroed whole at its first touch, and two threads
        // filling halves of one would wait on each other.
        const PIECE: usize = 2 << 20;
        const PARALLEL_FROM: u64 = 16 << 20;
        let mut file = std::fs::File::open(path).map_err(fail)?;
        let len = file.metadata().map_err(fail)?.len();
        if len >= PARALLEL_FROM && rayon::current_num_threads() > 1 {
            let len = usize::try_from(len).map_err(|_| {
                Error::file(path, "is too large to read into memory on this machine")
            })?;
            // Fresh zeroed pages (2 MiB ones), first touched by the reads.
            let mut bytes: Vec<u8> = crate::alloc::zeroed(len);
            let base = bytes.as_ptr() as usize;
            let head = (base.next_multiple_of(PIECE) - base).min(len);
            let (first, rest) = bytes.split_at_mut(head);
            let read_at = |piece: &mut [u8], at: usize| file.read_exact_at(piece, at as u64);
            let (a, b) = rayon::join(
                || read_at(first, 0),
                || {
                    rest.par_chunks_mut(PIECE)
                        .enumerate()
                        .try_for_each(|(i, piece)| read_at(piece, head + i * PIECE))
                },
            );
            a.and(b).map_err(fail)?;
            // What a file still being written gained since.
            file.seek(std::io::SeekFrom::Start(len as u64))
                .and_then(|_| file.read_to_end(&mut bytes))
                .map_err(fail)?;
            return Ok(bytes);
        }
    }
    std::fs::read(path).map_err(fail)
}

/// Fails unless `path` names a regular file (links followed), without opening it; its
/// metadata when it does.
pub(crate) fn regular_file(path: &Path) -> Result<std::fs::Metadata> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.is_file() {
        Ok(meta)
    } else if meta.is_dir() {
        Err(Error::file(path, "is a folder, not a file"))
    } else {
        Err(Error::file(
            path,
            "not a regular file (a pipe, socket or device): give a file",
        ))
    }
}

/// The bytes of a file, or of standard input for the path `-` (up to the memory budget),
/// with the name errors should give.
pub(super) fn read_input<'a>(path: &'a Path, limits: &Limits) -> Result<(Vec<u8>, &'a Path)> {
    if path != Path::new("-") {
        limits.session.note(path);
        return Ok((read_file(path)?, path));
    }
    use std::io::Read;
    let name = Path::new("standard input");
    let mut bytes = Vec::new();
    std::io::stdin()
        .lock()
        .take(limits.max_memory.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(name, e))?;
    if bytes.len() as u64 > limits.max_memory {
        return Err(Error::limit(
            Some(name),
            LimitKind::Memory,
            format!(
                "more than the memory budget of {}",
                human_bytes(limits.max_memory)
            ),
        ));
    }
    Ok((bytes, name))
}

/// `read_raw`, but an OpenEXR file is sanitized (as `read` does) while it decodes when
/// `sanitize` is set.
pub(super) fn read_with(
    path: &Path,
    opts: &ReadOptions,
    sanitize: bool,
) -> Result<(Decoded, Meta)> {
    let (bytes, path) = read_input(path, &opts.limits)?;
    decode_bytes(&bytes, path, opts, sanitize)
}

/// What decoding `path` will take, from its header alone (None for standard input, which
/// can be read only once): a command checks its whole input against the budget before it
/// decodes any of it. A file that is not one cubeforge reads gets its error here, before any
/// work.
pub fn claim(path: &Path, opts: &ReadOptions) -> Result<Option<Claim>> {
    if path == Path::new("-") {
        return Ok(None);
    }
    let len = regular_file(path)?.len();
    opts.limits.session.note(path);
    // Every header cubeforge reads fits in its first MiB; one that does not (a JPEG's size
    // after large metadata) is read whole.
    const HEAD: u64 = 1 << 20;
    let probe = |bytes: &[u8]| limits::probing(|| decode_bytes(bytes, path, opts, false));
    let head = if len > HEAD {
        use std::io::Read;
        let mut head = Vec::with_capacity(HEAD as usize);
        std::fs::File::open(path)
            .and_then(|f| f.take(HEAD).read_to_end(&mut head))
            .map_err(|e| Error::io(path, e))?;
        head
    } else {
        read_file(path)?
    };
    let (mut out, mut claimed) = probe(&head);
    if claimed.is_none() && out.is_err() && len > HEAD {
        drop(head);
        (out, claimed) = probe(&read_file(path)?);
    }
    let (w, h, cube) = match (claimed, out) {
        (Some(c), _) => c,
        // A decoder that never checked a size decoded the whole (small) file.
        (None, Ok((Decoded::Image(img), _))) => (img.width as u64, img.height as u64, false),
        (None, Ok((Decoded::Cube(c), _))) => (c.size() as u64, c.size() as u64, true),
        (None, Err(e)) => return Err(e),
    };
    let texels = w.saturating_mul(h).saturating_mul(if cube { 8 } else { 1 });
    Ok(Some(Claim {
        width: w,
        height: h,
        cube,
        decode_bytes: len.saturating_add(texels.saturating_mul(32)),
        held_bytes: texels.saturating_mul(16),
    }))
}

/// Decodes a file's bytes by their content (its name only where the content cannot say).
fn decode_bytes(
    bytes: &[u8],
    path: &Path,
    opts: &ReadOptions,
    sanitize: bool,
) -> Result<(Decoded, Meta)> {
    if bytes.is_empty() {
        return Err(Error::file(path, "file is empty"));
    }
    let by_name = FileFormat::from_extension(path);
    let format = match (FileFormat::from_magic(bytes), by_name) {
        (Some(m), Some(n)) if m != n && !(m == FileFormat::Jpeg && n == FileFormat::Jpeg) => {
            return Err(Error::file(
                path,
                format!(
                    "the file holds {} data but its name says {}: rename it or re-export it",
                    m.name(),
                    n.name()
                ),
            ))
        }
        (Some(m), _) => m,
        (None, Some(FileFormat::Tga)) => FileFormat::Tga,
        (None, Some(n)) => {
            return Err(Error::file(
                path,
                format!("not a valid {} file (its signature is missing)", n.name()),
            ))
        }
        (None, None) => return Err(Error::unsupported(
            path,
            "not a recognised image file (cubeforge reads PNG, JPEG, TGA, HDR, EXR, KTX2, DDS, KTX and Babylon env)",
        )),
    };
    let encoding = match format {
        FileFormat::Ktx2 => opts
            .hdr_encoding
            .or_else(|| super::hdr8::ktx2_encoding(bytes)),
        FileFormat::Png => match opts.hdr_encoding {
            Some(e) => Some(e),
            None => super::hdr8::png_encoding(bytes).map_err(|msg| Error::file(path, msg))?,
        },
        _ => opts.hdr_encoding,
    };
    // RGBM/RGBD: the bytes as stored (linear), undone above io, as is an edge fixup.
    let raw = ReadOptions {
        linear: true,
        hdr_encoding: None,
        ..*opts
    };
    let stored = if encoding.is_some() { &raw } else { opts };
    let (decoded, mut meta) = decode_format(bytes, format, path, stored, sanitize)?;
    meta.undo.hdr_encoding = encoding.map(|e| (e, opts.hdr_encoding.is_some()));
    if let (FileFormat::Ktx2, Decoded::Cube(_)) = (format, &decoded) {
        meta.undo.edge_fixup = super::ktx2::metadata(bytes)
            .iter()
            .find(|(k, _)| k == super::ktx2::EDGE_FIXUP_KEY)
            .and_then(|(_, v)| crate::cube::EdgeFixup::from_name(v));
    }
    Ok((decoded, meta))
}

/// Decodes bytes known to be `format`.
fn decode_format(
    bytes: &[u8],
    format: FileFormat,
    path: &Path,
    opts: &ReadOptions,
    sanitize: bool,
) -> Result<(Decoded, Meta)> {
    match format {
        FileFormat::Exr => exr::decode_with(bytes, path, opts, sanitize),
        FileFormat::Ktx2 => ktx2::decode(bytes, path, &opts.limits),
        FileFormat::Dds => dds::decode(bytes, path, &opts.limits),
        FileFormat::Ktx1 => ktx1::decode(bytes, path, &opts.limits),
        FileFormat::Env => babylon_env::decode(bytes, path, &opts.limits),
        FileFormat::Hdr => match rgbe::decode(bytes, path, opts) {
            Some(result) => result.map(|(img, meta)| (Decoded::Image(img), meta)),
            None => raster::decode(bytes, FileFormat::Hdr, path, opts),
        },
        FileFormat::Jpeg if super::ultrahdr::has_gain_map(bytes) => {
            super::ultrahdr::decode(bytes, path, opts)
        }
        f => raster::decode(bytes, f, path, opts),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file large enough to be read in parallel pieces comes back byte for byte, its
    /// last piece partial.
    #[test]
    fn large_files_read_whole() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.bin");
        let n = (17 << 20) + 12345;
        let bytes: Vec<u8> = (0..n).map(|i| (i * 7 + i / 4099) as u8).collect();
        std::fs::write(&path, &bytes).unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        assert!(pool.install(|| read_file(&path).unwrap()) == bytes);
        assert!(read_file(dir.path()).is_err());
    }
}
