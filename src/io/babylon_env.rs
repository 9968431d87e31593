//! Babylon.js `.env` prefiltered environments, written and read after Babylon's own
//! `environmentTextureTools` (`CreateEnvTextureAsync`, `GetEnvInfo`,
//! `CreateRadianceImageDataArrayBufferViews`, `_UploadLevelsAsync`).
//!
//! The file: 8 magic bytes, a JSON manifest ended by a NUL, then the images. The manifest
//! (version 2) holds `width` (level 0's face edge, a power of two), `imageType` ("image/png"),
//! `irradiance` (the diffuse light as Babylon's spherical polynomial, see
//! [`SphericalPolynomial`]) and `specular`: `mipmaps`, one `{length, position}` per face per
//! level (level-major, faces +X -X +Y -Y +Z -Z, positions counted from the byte after the NUL),
//! and `lodGenerationScale`. Babylon needs every level down to 1x1: 6 (log2(width) + 1) images.
//!
//! Each image is an 8-bit RGBA PNG in Babylon's RGBD encoding (its `toRGBD` shader): for linear
//! `c`, `D = clamp(floor(max(255 / max(c.r, c.g, c.b), 1)) / 255, 0, 1)`, stored as
//! `(pow(c D, 1 / 2.2), D)`, each channel rounded to 8 bits; read back as `pow(rgb, 2.2) / a`.
//! Values up to 255 are held (the brightest channel keeps 8 bits in (0.5, 1]); above it they
//! clamp. Babylon uploads the images with Y inverted, so a PNG's top row is the face's last row
//! (t = 1) in the OpenGL face convention every other container here uses: the writer flips each
//! face, the reader flips back.

#![warn(missing_docs)]

use super::guard::{caught, one_line};
use super::{Decoded, FileFormat, Limits, Meta};
use crate::cube::CubeMap;
use crate::error::{Error, Result};
use crate::image::{ColorSpace, Image};
use ::image::{codecs::png, ColorType, ExtendedColorType, ImageDecoder, ImageEncoder};
use glam::Vec4;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The 8 bytes every `.env` file starts with.
pub const MAGIC: [u8; 8] = [0x86, 0x16, 0x87, 0x96, 0xF6, 0xD6, 0x96, 0x36];
/// The largest value RGBD stores (D = 1/255).
pub const RGBD_MAX: f32 = super::hdr8::RGBD_MAX;
/// Babylon's default `lodGenerationScale` (also what it assumes when a file has none; the
/// roughness mapping's `filter::BABYLON_LOD_GENERATION_SCALE`, the same number).
pub const DEFAULT_LOD_GENERATION_SCALE: f64 = 0.8;
/// The manifest version written (Babylon reads 1 and 2).
pub const VERSION: u32 = 2;

use super::hdr8::HdrEncoding;

/// The manifest's irradiance polynomial, per channel [r, g, b], in its order: x, y, z, xx,
/// yy, zz, yz, zx, xy (computed above `io`, by `filter::sh_engines::SphericalPolynomial`).
pub type Polynomial = [[f64; 3]; 9];

/// The manifest's `irradiance` object: the polynomial's nine coefficients by name.
#[derive(Clone, Copy, Serialize, Deserialize)]
struct PolynomialJson {
    x: [f64; 3],
    y: [f64; 3],
    z: [f64; 3],
    xx: [f64; 3],
    yy: [f64; 3],
    zz: [f64; 3],
    yz: [f64; 3],
    zx: [f64; 3],
    xy: [f64; 3],
}

impl PolynomialJson {
    /// JSON has no NaN or infinity: those coefficients are written as 0.
    fn finite(p: &Polynomial) -> PolynomialJson {
        let f = |i: usize| p[i].map(|v| if v.is_finite() { v } else { 0.0 });
        PolynomialJson {
            x: f(0),
            y: f(1),
            z: f(2),
            xx: f(3),
            yy: f(4),
            zz: f(5),
            yz: f(6),
            zx: f(7),
            xy: f(8),
        }
    }

    fn coefficients(&self) -> Polynomial {
        let p = self;
        [p.x, p.y, p.z, p.xx, p.yy, p.zz, p.yz, p.zx, p.xy]
    }
}

/// One image's place in the file: bytes from the end of the manifest.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
struct ImageSpan {
    length: u64,
    position: u64,
}

#[derive(Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
struct Specular {
    mipmaps: Vec<ImageSpan>,
    #[serde(skip_serializing_if = "Option::is_none")]
    lod_generation_scale: Option<f64>,
}

#[derive(Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
struct Manifest {
    version: u32,
    width: u64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    image_type: Option<String>,
    #[serde(default)]
    irradiance: Option<serde_json::Value>,
    specular: Option<Specular>,
}

/// One linear texel in RGBD, as Babylon's `toRGBD` and its 8-bit dump make it.
fn rgbd(c: Vec4) -> [u8; 4] {
    HdrEncoding::Rgbd.encode(c)
}

/// One RGBD texel back to linear.
fn from_rgbd(t: &[u8]) -> Vec4 {
    HdrEncoding::Rgbd.decode([t[0], t[1], t[2], t[3]])
}

/// A face as a PNG of its RGBD texels, rows flipped (Babylon's Y-inverted upload).
fn face_png(face: &Image) -> std::result::Result<Vec<u8>, String> {
    let (w, h) = (face.width, face.height);
    let mut data = Vec::with_capacity(w * h * 4);
    for y in (0..h).rev() {
        for p in &face.pixels[y * w..(y + 1) * w] {
            data.extend_from_slice(&rgbd(*p));
        }
    }
    let mut out = Vec::new();
    png::PngEncoder::new(&mut out)
        .write_image(&data, w as u32, h as u32, ExtendedColorType::Rgba8)
        .map_err(|e| e.to_string())?;
    Ok(out)
}

/// Encodes `cube` as a Babylon `.env`: every level as RGBD PNGs, `irradiance` (None: the
/// manifest says null, and Babylon lights diffuse surfaces with nothing), and
/// `lod_generation_scale` (Babylon's default is [`DEFAULT_LOD_GENERATION_SCALE`]). The face
/// edge must be a power of two and the chain complete down to 1x1, as Babylon requires.
pub fn encode(
    cube: &CubeMap,
    irradiance: Option<&Polynomial>,
    lod_generation_scale: f64,
) -> std::result::Result<Vec<u8>, String> {
    let n = cube.size();
    if !n.is_power_of_two() {
        return Err(format!(
            "Babylon .env needs a power-of-two face size, not {n} (give {})",
            crate::error::param("size")
        ));
    }
    let levels = CubeMap::full_chain_len(n);
    if cube.levels.len() != levels {
        return Err(format!(
            "Babylon .env needs every mip level down to 1x1 ({levels} for {n}x{n} faces), but the cube map has {}",
            cube.levels.len()
        ));
    }
    let images: Vec<std::result::Result<Vec<u8>, String>> = {
        use rayon::prelude::*;
        let faces: Vec<&Image> = cube.levels.iter().flat_map(|l| l.iter()).collect();
        faces.par_iter().map(|f| face_png(f)).collect()
    };
    let images = images
        .into_iter()
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let mut position = 0u64;
    let mipmaps = images
        .iter()
        .map(|b| {
            let span = ImageSpan {
                length: b.len() as u64,
                position,
            };
            position += b.len() as u64;
            span
        })
        .collect();
    let manifest = Manifest {
        version: VERSION,
        width: n as u64,
        image_type: Some("image/png".into()),
        irradiance: Some(
            irradiance
                .map(|p| serde_json::to_value(PolynomialJson::finite(p)))
                .transpose()
                .map_err(|e| e.to_string())?
                .unwrap_or(serde_json::Value::Null),
        ),
        specular: Some(Specular {
            mipmaps,
            lod_generation_scale: Some(if lod_generation_scale.is_finite() {
                lod_generation_scale
            } else {
                DEFAULT_LOD_GENERATION_SCALE
            }),
        }),
    };
    let json = serde_json::to_vec(&manifest).map_err(|e| e.to_string())?;
    let mut out = Vec::with_capacity(MAGIC.len() + json.len() + 1 + position as usize);
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&json);
    out.push(0);
    for b in images {
        out.extend_from_slice(&b);
    }
    Ok(out)
}

/// A `.env` file as read.
#[derive(Clone, Debug)]
pub struct BabylonEnv {
    /// The specular chain, every level, decoded from RGBD to linear.
    pub cube: CubeMap,
    /// The manifest's version (1 or 2).
    pub version: u32,
    /// The irradiance polynomial, when the manifest has one.
    pub irradiance: Option<Polynomial>,
    /// `lodGenerationScale` (0.8 when absent, as Babylon reads it).
    pub lod_generation_scale: f64,
    /// Edge of the optional irradiance cube map's faces, which is not decoded.
    pub irradiance_texture_size: Option<u64>,
}

/// The manifest of a `.env` file (checked: its version and image type) and the bytes after
/// it.
fn manifest<'a>(bytes: &'a [u8], path: &Path) -> Result<(Manifest, &'a [u8])> {
    let err = |msg: String| Error::file(path, msg);
    if !bytes.starts_with(&MAGIC) {
        return Err(err(
            "not a Babylon .env file (its magic bytes are missing)".into()
        ));
    }
    let nul = bytes[MAGIC.len()..]
        .iter()
        .position(|&b| b == 0)
        .ok_or_else(|| err("truncated .env file: its manifest has no terminating NUL".into()))?;
    let json = &bytes[MAGIC.len()..MAGIC.len() + nul];
    let data = &bytes[MAGIC.len() + nul + 1..];
    let manifest: Manifest = serde_json::from_slice(json).map_err(|e| {
        err(format!(
            "invalid .env manifest: {}",
            one_line(&e.to_string())
        ))
    })?;
    if !(1..=VERSION).contains(&manifest.version) {
        return Err(Error::unsupported(
            path,
            format!(
                "Babylon .env version {} is not supported (cubeforge reads versions 1 and 2)",
                manifest.version
            ),
        ));
    }
    let image_type = manifest.image_type.as_deref().unwrap_or("image/png");
    if image_type != "image/png" {
        return Err(Error::unsupported(
            path,
            format!("a .env of {image_type} images is not supported: cubeforge reads image/png"),
        ));
    }
    Ok((manifest, data))
}

/// Reads a `.env` file: the manifest, every specular level (checked in size and place before
/// any PNG is decoded, each PNG checked against the size its level needs).
pub fn read(bytes: &[u8], path: &Path, limits: &Limits) -> Result<BabylonEnv> {
    let err = |msg: String| Error::file(path, msg);
    let (manifest, data) = manifest(bytes, path)?;
    let n = manifest.width;
    limits.check_cube(path, n, n)?;
    if !n.is_power_of_two() {
        return Err(err(format!(
            "invalid .env manifest: width {n} is not a power of two"
        )));
    }
    let n = n as usize; // within the limits
    let levels = CubeMap::full_chain_len(n);
    let specular = manifest
        .specular
        .ok_or_else(|| err("invalid .env manifest: it has no specular images".into()))?;
    if specular.mipmaps.len() != 6 * levels {
        return Err(err(format!(
            "invalid .env manifest: {} specular images, but {n}x{n} faces need 6 x {levels}",
            specular.mipmaps.len()
        )));
    }
    for (i, s) in specular.mipmaps.iter().enumerate() {
        if s.position
            .checked_add(s.length)
            .is_none_or(|end| end > data.len() as u64)
        {
            return Err(err(format!(
                "truncated .env file: image {i} (level {}, face {}) needs bytes {} to {} after the manifest, but there are {}",
                i / 6,
                i % 6,
                s.position,
                s.position.saturating_add(s.length),
                data.len()
            )));
        }
    }
    let face = |i: usize| -> Result<Image> {
        let s = specular.mipmaps[i];
        let size = (n >> (i / 6)).max(1);
        let png = &data[s.position as usize..(s.position + s.length) as usize];
        decode_face(png, size).map_err(|e| {
            err(format!(
                "level {}, face {}: {e}",
                i / 6,
                crate::cube::FACE_NAMES[i % 6]
            ))
        })
    };
    let faces: Vec<Result<Image>> = {
        use rayon::prelude::*;
        (0..6 * levels).into_par_iter().map(face).collect()
    };
    let mut faces = faces.into_iter();
    let mut cube_levels = Vec::with_capacity(levels);
    for _ in 0..levels {
        let level: Vec<Image> = faces.by_ref().take(6).collect::<Result<_>>()?;
        cube_levels.push(level.try_into().expect("six faces"));
    }
    let irradiance_json = manifest.irradiance.unwrap_or(serde_json::Value::Null);
    let irradiance_texture_size = irradiance_json
        .get("irradianceTexture")
        .and_then(|t| t.get("size"))
        .and_then(|s| s.as_u64());
    let irradiance = serde_json::from_value::<PolynomialJson>(irradiance_json)
        .ok()
        .map(|p| p.coefficients());
    Ok(BabylonEnv {
        cube: CubeMap {
            levels: cube_levels,
        },
        version: manifest.version,
        irradiance,
        lod_generation_scale: specular
            .lod_generation_scale
            .filter(|&s| s != 0.0)
            .unwrap_or(DEFAULT_LOD_GENERATION_SCALE),
        irradiance_texture_size,
    })
}

/// One RGBD PNG of `size` x `size` back to linear texels, rows flipped back.
fn decode_face(png_bytes: &[u8], size: usize) -> std::result::Result<Image, String> {
    let e = |e: ::image::ImageError| one_line(&e.to_string());
    let decoded = caught(|| -> std::result::Result<Vec<u8>, String> {
        let mut d = png::PngDecoder::new(std::io::Cursor::new(png_bytes)).map_err(e)?;
        let (w, h) = d.dimensions();
        if (w as usize, h as usize) != (size, size) {
            return Err(format!(
                "the PNG is {w}x{h}, but this level's faces are {size}x{size}"
            ));
        }
        if d.color_type() != ColorType::Rgba8 {
            return Err(format!(
                "the PNG is {}, but RGBD images are 8-bit RGBA",
                super::raster::pixel_format_name(d.color_type(), super::FileFormat::Png)
            ));
        }
        let mut limits = ::image::Limits::default();
        limits.max_alloc = Some((size * size * 8).max(1 << 20) as u64);
        d.set_limits(limits).map_err(e)?;
        let mut buf = vec![0u8; size * size * 4];
        d.read_image(&mut buf).map_err(e)?;
        Ok(buf)
    })??;
    let mut pixels = Vec::with_capacity(size * size);
    for y in (0..size).rev() {
        pixels.extend(
            decoded[y * size * 4..(y + 1) * size * 4]
                .chunks_exact(4)
                .map(from_rgbd),
        );
    }
    Ok(Image {
        width: size,
        height: size,
        pixels,
    })
}

/// Reads a `.env` for [`super::read`]: the specular chain as a cube map.
pub(crate) fn decode(bytes: &[u8], path: &Path, limits: &Limits) -> Result<(Decoded, Meta)> {
    let env = read(bytes, path, limits)?;
    let levels = env.cube.levels.len();
    let meta = Meta {
        file_format: FileFormat::Env,
        pixel_format: "RGBD8 (PNG)".into(),
        color_space: ColorSpace::Linear,
        hdr: true,
        replaced_values: 0,
        stored_levels: levels,
        declared: None,
        undo: Default::default(),
        part: None,
    };
    Ok((Decoded::Cube(env.cube), meta))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn rgbd_follows_babylon_and_round_trips() {
        // Up to 1: D = 1, rgb = c^(1/2.2).
        assert_eq!(rgbd(Vec4::new(1.0, 0.0, 0.5, 1.0)), [255, 0, 186, 255]);
        // 10: D = floor(25.5) / 255 = 25/255; 10 * 25/255 = 0.98.
        let t = rgbd(Vec4::new(10.0, 1.0, 0.0, 1.0));
        assert_eq!(t[3], 25);
        // Relative error under 1% for the brightest channel across the range.
        for v in [1e-3f32, 0.02, 0.3, 0.99, 1.5, 7.0, 64.0, 200.0, 255.0] {
            let back = from_rgbd(&rgbd(Vec4::new(v, v * 0.5, v * 0.25, 1.0)));
            assert!((back.x - v).abs() <= 0.01 * v + 0.002, "{v} -> {}", back.x);
        }
        // Above 255 it clamps.
        assert!((from_rgbd(&rgbd(Vec4::splat(1000.0))).x - 255.0).abs() < 1.0);
    }

    use crate::filter::sh_engines::SphericalPolynomial;

    #[test]
    fn lod_generation_scale_is_the_roughness_mappings() {
        assert_eq!(
            DEFAULT_LOD_GENERATION_SCALE,
            crate::filter::BABYLON_LOD_GENERATION_SCALE
        );
    }

    #[test]
    fn polynomial_reproduces_analytic_irradiance() {
        // L(d) = 1 + z + 0.5 x y: E(n)/pi = 1 + (2/3) nz + (1/4)(0.5 nx ny).
        let cube = CubeMap::from_fn(32, |d| {
            Vec4::new(1.0 + d.z + 0.5 * d.x * d.y, 1.0, 0.0, 1.0)
        });
        let sh = crate::filter::sh::project(&cube);
        let p = SphericalPolynomial::from_radiance_sh(&sh);
        let mut worst = 0.0f64;
        for n in [
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(1.0, 1.0, 1.0).normalize(),
        ] {
            let exact = 1.0 + 2.0 / 3.0 * n.z as f64 + 0.125 * (n.x * n.y) as f64;
            worst = worst.max((p.irradiance_over_pi(n)[0] - exact).abs());
            assert!((p.irradiance_over_pi(n)[1] - 1.0).abs() < 1e-3);
        }
        assert!(worst < 2e-3, "worst {worst}");
        // Babylon's polynomial itself is the harmonics convolved once more: 1 + (4/9) nz.
        assert!((p.evaluate(Vec3::Z)[0] - (1.0 + 4.0 / 9.0)).abs() < 2e-3);
    }

    #[test]
    fn round_trip_every_level() {
        let cube = CubeMap::from_fn(8, |d| {
            Vec4::new(d.x.abs() * 40.0, d.y * 0.5 + 0.5, 0.01, 1.0)
        })
        .with_box_mips(None);
        let p = SphericalPolynomial::from_radiance_sh(&crate::filter::sh::project(&cube));
        let bytes = encode(&cube, Some(&p.coefficients()), 0.8).unwrap();
        let env = read(&bytes, Path::new("t.env"), &Limits::default()).unwrap();
        assert_eq!(env.cube.levels.len(), 4);
        // serde_json parses floats to within an ulp or so.
        let back = serde_json::to_value(PolynomialJson::finite(&env.irradiance.unwrap())).unwrap();
        let want = serde_json::to_value(p).unwrap();
        for (k, v) in want.as_object().unwrap() {
            for c in 0..3 {
                let (a, b) = (v[c].as_f64().unwrap(), back[k][c].as_f64().unwrap());
                assert!((a - b).abs() <= 1e-12 * a.abs().max(1e-12), "{k}");
            }
        }
        for (la, lb) in cube.levels.iter().zip(&env.cube.levels) {
            for (fa, fb) in la.iter().zip(lb) {
                for (a, b) in fa.pixels.iter().zip(&fb.pixels) {
                    let tol = 0.01 * a.truncate().max_element() + 0.002;
                    assert!(
                        (a.truncate() - b.truncate()).abs().max_element() <= tol,
                        "{a} {b}"
                    );
                }
            }
        }
        assert!(encode(&cube.clone().with_box_mips(Some(2)), None, 0.8).is_err());
    }
}
