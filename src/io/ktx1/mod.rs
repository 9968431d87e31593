//! KTX 1.1 cube maps, the container Filament's `cmgen` deploys image-based lighting in: a
//! prefiltered mip chain and, in the key/value data, the irradiance spherical harmonics
//! (key `sh`, see `filter::sh_engines::filament_sh`). Written and read by hand after the Khronos KTX 1.1
//! specification.
//!
//! File layout as written: the 64-byte header (little-endian, endianness 0x04030201), the
//! key/value pairs (`KTXwriter` first, then the caller's, each padded to 4 bytes), then for each
//! level, largest first: `imageSize` (the bytes of ONE face, as the specification asks of a
//! non-array cube map) and the six faces +X -X +Y -Y +Z -Z, rows top to bottom, each row padded
//! to 4 bytes (GL_UNPACK_ALIGNMENT 4). Padded rows make every face a multiple of 4 bytes, so
//! cubePadding and mipPadding are always empty. The same cube map always gives the same bytes.
//!
//! The reader takes little- and big-endian files, cube maps (six faces) and 2D textures (level
//! 0 read as an image), in the formats of [`Ktx1Format`]. Every header field, key/value entry and
//! level size is checked against the file's length with checked arithmetic, and the declared
//! size against [`Limits`], before any texel is allocated.

#![warn(missing_docs)]

use super::{Decoded, FileFormat, Limits, Meta};
use crate::cube::CubeMap;
use crate::error::{Error, Result};
use crate::image::ColorSpace;
use std::path::Path;

/// The 12 bytes every KTX 1 file starts with ("«KTX 11»\r\n\x1A\n").
pub const IDENTIFIER: [u8; 12] = [
    0xAB, 0x4B, 0x54, 0x58, 0x20, 0x31, 0x31, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A,
];

/// The endianness field as the writer's byte order stores it.
const ENDIANNESS: u32 = 0x0403_0201;
/// Identifier plus thirteen UInt32 fields.
const HEADER_LEN: usize = 64;
/// The formats read, as every refusal of another names them (one list, so they agree).
const READS: &str = "RGBA16F, RGB16F, RGBA32F, RGBA8 and R11F_G11F_B10F";

mod format;
mod sh;

pub use format::Ktx1Format;
use format::{GL_R11F_G11F_B10F, GL_RGB};
pub use sh::{parse_sh, sh_key_value};

/// Key of the writer's name, as libktx writes it.
pub const WRITER_KEY: &str = "KTXwriter";
/// Key of Filament's irradiance spherical harmonics (text, see `filter::sh_engines::filament_sh`).
pub const SH_KEY: &str = "sh";

/// One key/value pair. Values are bytes; text values are written NUL-terminated, as the
/// specification recommends (see [`KeyValue::text`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KeyValue {
    /// The key (UTF-8, no NUL).
    pub key: String,
    /// The value as stored.
    pub value: Vec<u8>,
}

impl KeyValue {
    /// A text value, stored with a terminating NUL.
    pub fn text(key: &str, value: &str) -> KeyValue {
        let mut v = value.as_bytes().to_vec();
        v.push(0);
        KeyValue {
            key: key.to_string(),
            value: v,
        }
    }

    /// The value as text, without a terminating NUL; None when it is not UTF-8.
    pub fn as_text(&self) -> Option<&str> {
        let v = self.value.strip_suffix(&[0]).unwrap_or(&self.value);
        std::str::from_utf8(v).ok()
    }
}

/// Encodes every level of `cube` as a KTX 1 cube map in `format`, with a `KTXwriter` entry
/// (unless `key_values` has one) and then `key_values` in their order. Fails only for sizes a
/// KTX 1 header cannot state (a face of more than 4 GiB).
pub fn encode(
    cube: &CubeMap,
    format: Ktx1Format,
    key_values: &[KeyValue],
) -> std::result::Result<Vec<u8>, String> {
    let n = cube.size();
    let too_large = || format!("faces of {n}x{n} pixels are too large for KTX 1");
    let edge = u32::try_from(n).map_err(|_| too_large())?;
    let face_len = |size: usize| format.row_bytes(size) * size;
    u32::try_from(face_len(n)).map_err(|_| too_large())?;
    let levels = u32::try_from(cube.levels.len()).map_err(|_| "too many mip levels for KTX 1")?;

    let mut kv: Vec<KeyValue> = Vec::new();
    if !key_values.iter().any(|e| e.key == WRITER_KEY) {
        let writer = format!("cubeforge {}", env!("CARGO_PKG_VERSION"));
        kv.push(KeyValue::text(WRITER_KEY, &writer));
    }
    kv.extend_from_slice(key_values);
    let mut kvd = Vec::new();
    for e in &kv {
        let len = e.key.len() + 1 + e.value.len();
        let len32 = u32::try_from(len).map_err(|_| format!("key/value {} is too long", e.key))?;
        kvd.extend_from_slice(&len32.to_le_bytes());
        kvd.extend_from_slice(e.key.as_bytes());
        kvd.push(0);
        kvd.extend_from_slice(&e.value);
        kvd.resize(kvd.len().div_ceil(4) * 4, 0); // valuePadding
    }
    let kvd_len = u32::try_from(kvd.len()).map_err(|_| "key/value data too long for KTX 1")?;

    let total = HEADER_LEN
        + kvd.len()
        + cube
            .levels
            .iter()
            .map(|faces| 4 + 6 * face_len(faces[0].width))
            .sum::<usize>();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(&IDENTIFIER);
    let gl = format.gl();
    for v in [
        ENDIANNESS,
        gl.gl_type,
        gl.type_size,
        gl.format,
        gl.internal,
        gl.base_internal,
        edge, // pixelWidth
        edge, // pixelHeight
        0,    // pixelDepth
        0,    // numberOfArrayElements: not an array
        6,    // numberOfFaces
        levels,
        kvd_len,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&kvd);
    for faces in &cube.levels {
        // A non-array cube map's imageSize is the bytes of one face.
        out.extend_from_slice(&(face_len(faces[0].width) as u32).to_le_bytes());
        for face in faces {
            format.encode_face(face, &mut out)?;
        }
    }
    debug_assert_eq!(out.len(), total);
    Ok(out)
}

/// A KTX 1 file as read: its texels, format and key/value pairs.
#[derive(Clone, Debug)]
pub struct Ktx1 {
    /// Every level of a cube map, or level 0 of a 2D texture as a one-face image.
    pub texture: Decoded,
    /// The texel format.
    pub format: Ktx1Format,
    /// The levels the file holds.
    pub levels: usize,
    /// Every key/value pair, in file order, values as stored.
    pub key_values: Vec<KeyValue>,
}

impl Ktx1 {
    /// The value of `key`, if present.
    pub fn value(&self, key: &str) -> Option<&[u8]> {
        self.key_values
            .iter()
            .find(|e| e.key == key)
            .map(|e| &e.value[..])
    }

    /// Filament's spherical harmonics (key `sh`), when present and well formed.
    pub fn sh(&self) -> Option<[[f64; 3]; 9]> {
        parse_sh(self.value(SH_KEY)?)
    }
}

/// The 32-bit word at `at`, in the file's byte order.
fn word_at(bytes: &[u8], at: usize, big: bool) -> u32 {
    let b: [u8; 4] = bytes[at..at + 4].try_into().unwrap_or_default();
    if big {
        u32::from_be_bytes(b)
    } else {
        u32::from_le_bytes(b)
    }
}

/// The `kvd_len` bytes of key/value pairs after the header, each checked against the block
/// they sit in, and where they end.
fn key_values(
    bytes: &[u8],
    kvd_len: u32,
    big: bool,
    path: &Path,
) -> Result<(Vec<KeyValue>, usize)> {
    let err = |msg: String| Error::file(path, msg);
    let file_len = bytes.len();
    let kvd_end = HEADER_LEN
        .checked_add(kvd_len as usize)
        .filter(|&e| e <= file_len)
        .ok_or_else(|| {
            err(format!(
                "truncated KTX file: its key/value data ({kvd_len} bytes) does not fit in the file ({file_len} bytes)"
            ))
        })?;
    let word = |at: usize| word_at(bytes, at, big);
    let mut key_values = Vec::new();
    let mut at = HEADER_LEN;
    while at < kvd_end {
        if kvd_end - at < 4 {
            return Err(err(
                "invalid key/value data: an entry's size is cut off".into()
            ));
        }
        let len = word(at) as usize;
        let body = at + 4;
        if len > kvd_end - body {
            return Err(err(format!(
                "invalid key/value data: an entry of {len} bytes at byte {at} runs past the key/value data"
            )));
        }
        let kv = &bytes[body..body + len];
        let nul = kv.iter().position(|&b| b == 0).ok_or_else(|| {
            err(format!(
                "invalid key/value data: the key at byte {body} has no terminating NUL"
            ))
        })?;
        key_values.push(KeyValue {
            key: String::from_utf8_lossy(&kv[..nul]).into_owned(),
            value: kv[nul + 1..].to_vec(),
        });
        at = (body + len).div_ceil(4) * 4;
    }
    Ok((key_values, kvd_end))
}

/// Every level's place from `at` on (its start, width, height and face stride), checked
/// before anything is allocated (a cube's six faces, a 2D texture's one, per level).
fn level_spans(
    bytes: &[u8],
    mut at: usize,
    big: bool,
    format: Ktx1Format,
    faces: usize,
    (width, height, level_count): (usize, usize, usize),
    path: &Path,
) -> Result<Vec<(usize, usize, usize, usize)>> {
    let err = |msg: String| Error::file(path, msg);
    let word = |at: usize| word_at(bytes, at, big);
    let (file_len, cube) = (bytes.len(), faces == 6);
    let mut spans = Vec::with_capacity(level_count);
    for l in 0..level_count {
        let (w, h) = ((width >> l).max(1), (height >> l).max(1));
        let face_len = format.row_bytes(w) * h;
        if file_len.saturating_sub(at) < 4 {
            return Err(err(format!(
                "truncated KTX file: level {l}'s imageSize is missing (the file has {file_len} bytes)"
            )));
        }
        let image_size = word(at) as usize;
        // A cube's imageSize is one face; a 2D texture's its one image: the same bytes.
        let expected = face_len;
        if image_size != expected {
            let holds = if cube { "one face of" } else { "an image of" };
            return Err(err(format!(
                "invalid level {l}: imageSize is {image_size}, but {holds} {w}x{h} {} texels takes {expected}",
                format.name()
            )));
        }
        let start = at + 4;
        let stride = face_len.div_ceil(4) * 4; // cubePadding
        let level_end = start + faces * stride;
        if level_end > file_len {
            return Err(err(format!(
                "truncated KTX file: level {l} needs bytes {start} to {level_end}, but the file has {file_len}"
            )));
        }
        spans.push((start, w, h, stride));
        at = level_end.div_ceil(4) * 4; // mipPadding
    }
    Ok(spans)
}

/// The texel format the header's GL fields name, refused when cubeforge cannot read it or
/// the fields disagree (cmgen's R11F_G11F_B10F files taken as they are).
fn gl_format_of(
    path: &Path,
    gl_type: u32,
    type_size: u32,
    gl_format: u32,
    internal: u32,
) -> Result<Ktx1Format> {
    let err = |msg: String| Error::file(path, msg);
    if gl_type == 0 {
        return Err(Error::unsupported(
            path,
            format!("compressed KTX (glInternalFormat {internal:#06x}) is not supported: cubeforge reads {READS} KTX files"),
        ));
    }
    let format = Ktx1Format::from_gl(internal, gl_type).ok_or_else(|| {
        Error::unsupported(
            path,
            format!("unsupported KTX format (glInternalFormat {internal:#06x}, glType {gl_type:#06x}): cubeforge reads {READS}"),
        )
    })?;
    let gl = format.gl();
    // cmgen's R11F_G11F_B10F files say glTypeSize 1 and glFormat GL_R11F_G11F_B10F.
    let cmgen = format == Ktx1Format::Rg11b10
        && (type_size == 1 || type_size == 4)
        && (gl_format == GL_RGB || gl_format == GL_R11F_G11F_B10F);
    if !cmgen && (type_size != gl.type_size || gl_format != gl.format) {
        return Err(err(format!(
            "invalid header: {} needs glTypeSize {} and glFormat {:#06x}, but the file says {type_size} and {gl_format:#06x}",
            format.name(),
            gl.type_size,
            gl.format
        )));
    }
    Ok(format)
}

/// The texels of `spans` decoded (byte-swapped first from a big-endian file): a cube map's
/// every level, or a 2D texture's level 0.
fn texture(
    bytes: &[u8],
    spans: &[(usize, usize, usize, usize)],
    format: Ktx1Format,
    big: bool,
    cube: bool,
    path: &Path,
) -> Result<Decoded> {
    let err = |msg: String| Error::file(path, msg);
    let swap = big && format.gl().type_size > 1;
    let face = |&(start, w, h, stride): &(usize, usize, usize, usize), f: usize| {
        let b = &bytes[start + f * stride..start + f * stride + format.row_bytes(w) * h];
        if swap {
            let ts = format.gl().type_size as usize;
            let mut le = b.to_vec();
            le.chunks_exact_mut(ts).for_each(|c| c.reverse());
            format.decode_face(&le, w, h)
        } else {
            format.decode_face(b, w, h)
        }
        .map_err(err)
    };
    Ok(if cube {
        Decoded::Cube(CubeMap {
            levels: spans
                .iter()
                .map(|s| crate::cube::try_faces(|f| face(s, f)))
                .collect::<Result<_>>()?,
        })
    } else {
        Decoded::Image(face(&spans[0], 0)?)
    })
}

/// Reads a KTX 1 cube map (every level) or 2D texture (level 0) with its key/value pairs.
pub fn read(bytes: &[u8], path: &Path, limits: &Limits) -> Result<Ktx1> {
    let err = |msg: String| Error::file(path, msg);
    let file_len = bytes.len();
    if !bytes.starts_with(&IDENTIFIER) && !IDENTIFIER.starts_with(bytes) {
        return Err(err("not a KTX 1 file (its identifier is missing)".into()));
    }
    if file_len < HEADER_LEN {
        return Err(err(format!(
            "truncated KTX file: {file_len} bytes, shorter than the {HEADER_LEN}-byte header"
        )));
    }
    let big = match u32::from_le_bytes(bytes[12..16].try_into().unwrap_or_default()) {
        ENDIANNESS => false,
        0x0102_0304 => true,
        e => {
            return Err(err(format!(
                "invalid header: endianness is {e:#010x}, neither 0x04030201 nor 0x01020304"
            )))
        }
    };
    let word = |at: usize| word_at(bytes, at, big);
    let field = |i: usize| word(16 + 4 * i);
    let (gl_type, type_size, gl_format, internal) = (field(0), field(1), field(2), field(3));
    let (width, height, depth) = (field(5), field(6), field(7));
    let (array, faces, level_field, kvd_len) = (field(8), field(9), field(10), field(11));

    let format = gl_format_of(path, gl_type, type_size, gl_format, internal)?;
    if array != 0 {
        return Err(err(format!(
            "texture arrays are not supported (numberOfArrayElements {array})"
        )));
    }
    if depth != 0 {
        return Err(err(format!(
            "a 3D texture (pixelDepth {depth}) is not supported: cubeforge reads 2D textures and cube maps"
        )));
    }
    let cube = match faces {
        6 => true,
        1 => false,
        _ => {
            return Err(err(format!(
                "invalid header: numberOfFaces is {faces}, but a 2D texture has 1 and a cube map 6"
            )))
        }
    };
    if height == 0 {
        return Err(err(
            "a 1D texture (pixelHeight 0) is not supported: cubeforge reads 2D textures and cube maps".into(),
        ));
    }
    if cube {
        limits.check_cube(path, width as u64, height as u64)?;
        if width != height {
            return Err(err(format!(
                "invalid cube map: faces must be square, but they are {width}x{height}"
            )));
        }
    } else {
        limits.check(path, width as u64, height as u64)?;
    }
    let (width, height) = (width as usize, height as usize);
    let max_levels = CubeMap::full_chain_len(width.max(height));
    // 0 asks the loader to make the mips: the file then holds level 0 only.
    let level_count = (level_field as usize).max(1);
    if level_count > max_levels {
        return Err(err(format!(
            "invalid header: numberOfMipmapLevels is {level_field}, but a {width}x{height} texture has at most {max_levels} levels"
        )));
    }

    let (key_values, kvd_end) = key_values(bytes, kvd_len, big, path)?;

    let spans = level_spans(
        bytes,
        kvd_end,
        big,
        format,
        faces as usize,
        (width, height, level_count),
        path,
    )?;

    let texture = texture(bytes, &spans, format, big, cube, path)?;
    Ok(Ktx1 {
        texture,
        format,
        levels: level_count,
        key_values,
    })
}

/// Reads a KTX 1 file for [`super::read`]: a cube map with its levels, or a 2D texture's level 0.
pub(crate) fn decode(bytes: &[u8], path: &Path, limits: &Limits) -> Result<(Decoded, Meta)> {
    let k = read(bytes, path, limits)?;
    let meta = Meta {
        file_format: FileFormat::Ktx1,
        pixel_format: k.format.name().into(),
        color_space: if k.format == Ktx1Format::Rgba8Srgb {
            ColorSpace::Srgb
        } else {
            ColorSpace::Linear
        },
        hdr: k.format.is_float(),
        replaced_values: 0,
        stored_levels: k.levels,
        declared: None,
        undo: Default::default(),
        part: None,
    };
    Ok((k.texture, meta))
}

#[cfg(test)]
mod tests;
