//! The targets whose engines filter a panorama themselves (Godot, Unity, Unreal, three.js):
//! the panorama each imports, in its container, with the import settings or loader lines.

use super::engines::{file_name, Context};
use super::{Delivery, Engine};
use crate::error::Result;
use crate::image::Image;
use crate::io::{self, FileFormat, GpuFormat};
use crate::tonemap::Tonemap;
use std::path::PathBuf;

/// Engines that import a panorama and prefilter it themselves.
pub fn filters_itself(engine: Engine) -> bool {
    matches!(
        engine,
        Engine::Godot | Engine::Unity | Engine::Unreal | Engine::Three
    )
}

/// The panorama an engine that filters for itself imports, with the import settings to pick.
pub fn panorama(engine: Engine, ctx: &Context, size: Option<usize>) -> Result<Delivery> {
    use crate::layout::Kind;
    if engine == Engine::Three {
        return three(ctx, size);
    }
    let (format, snippet) = match engine {
        Engine::Godot => (
            FileFormat::Exr,
            "Godot 4: WorldEnvironment > Environment > Sky > PanoramaSkyMaterial, panorama = {f}\n\
             (Sky: Radiance Size 256 or more, Process Mode Automatic or High Quality Incremental).\n\
             The panorama's centre faces world +Z (behind the default camera, which looks along -Z).",
        ),
        Engine::Unity => (
            FileFormat::Exr,
            "Unity: import {f} with Texture Shape = Cube, Mapping = Latitude-Longitude Layout\n\
             (Cylindrical), Convolution Type = Specular (Glossy Reflection); use it as the skybox\n\
             (Skybox/Cubemap material) or a Reflection Probe's custom cubemap.",
        ),
        _ => (
            FileFormat::Hdr,
            "Unreal: import {f}: a long-lat .hdr becomes a TextureCube; set it as the Sky Light's\n\
             Cubemap (Source Type: SLS Specified Cubemap) and in an HDRI Backdrop. The panorama's\n\
             centre faces world -Y.",
        ),
    };
    let face = size
        .unwrap_or_else(|| ctx.loaded.face_size())
        .clamp(1, 8192);
    let img = crate::convert::to_image(ctx.loaded, Kind::Equirect, face, &ctx.resampler());
    if let (Engine::Godot, Some(format)) = (engine, ctx.opts.encoding.gpu_format) {
        return godot_ktx2(ctx, img, format);
    }
    let path = ctx.path(&format!(".{}", format.extension()));
    let write = io::WriteOptions {
        exr_float: ctx.opts.encoding.exr_float,
        ..Default::default()
    };
    let bytes = crate::output::encode_image_as(format, &path, &img, &write)?;
    let clamped = io::clamp_warning_with(&path, format, &write, [&img]);
    let snippet = snippet.replace("{f}", &file_name(&path));
    Ok(Delivery::new(vec![(path, bytes)], snippet, clamped))
}

/// The panorama as a 2D KTX2 texture in `format` with its solid-angle-weighted mips (block
/// formats cannot be mipmapped by the engine): its path, bytes, level count, the clamp warning
/// and the PSNR of a lossy format. `bottom_up` stores each level's rows bottom first, marked
/// `KTXorientation` "ru", for engines that upload rows as stored into GL's bottom-up texture
/// space (three.js: a compressed texture is never flipped).
fn panorama_ktx2(
    ctx: &Context,
    img: Image,
    format: GpuFormat,
    bottom_up: bool,
) -> Result<PanoramaKtx2> {
    let path = ctx.path(".ktx2");
    let mut levels = vec![img];
    while let Some(last) = levels.last().filter(|l| l.height > 1) {
        let weights = crate::layout::equirect::row_weights(last.width, last.height);
        let next = last.downsample_2x_rows(&weights, glam::Vec4::INFINITY);
        levels.push(next);
    }
    let encoded = if bottom_up {
        let flipped: Vec<Image> = levels.iter().map(Image::flipped_rows).collect();
        let ru: &[(&str, &[u8])] = &[(io::ktx2::ORIENTATION_KEY, b"ru")];
        io::ktx2::encode_2d_with(&flipped, format, ctx.opts.encoding.zstd, ru)
    } else {
        io::ktx2::encode_2d_with(&levels, format, ctx.opts.encoding.zstd, &[])
    };
    let bytes = encoded.map_err(|e| crate::Error::file(&path, e))?;
    let write = io::WriteOptions {
        gpu_format: format,
        ..Default::default()
    };
    let clamped = io::clamp_warning_with(&path, FileFormat::Ktx2, &write, [&levels[0]]);
    let psnr = format
        .is_lossy()
        .then(|| io::container_psnr(&bytes, format, &[&levels[0]]))
        .flatten();
    Ok(PanoramaKtx2 {
        path,
        bytes,
        levels: levels.len(),
        clamped,
        psnr,
    })
}

/// What [`panorama_ktx2`] made.
struct PanoramaKtx2 {
    path: PathBuf,
    bytes: Vec<u8>,
    levels: usize,
    clamped: Option<String>,
    psnr: Option<f64>,
}

/// Godot with a GPU format (mobile builds: ASTC HDR 4x4): the panorama as a 2D KTX2 texture
/// with its mips, which Godot's KTX loader uploads as stored.
fn godot_ktx2(ctx: &Context, img: Image, format: GpuFormat) -> Result<Delivery> {
    let k = panorama_ktx2(ctx, img, format, false)?;
    let snippet = format!(
        "Godot 4: WorldEnvironment > Environment > Sky > PanoramaSkyMaterial, panorama = {f}\n\
         ({levels} levels of {name}, read by Godot's KTX loader and uploaded as stored; a device \
         without the format cannot show it).\n\
         The panorama's centre faces world +Z (behind the default camera, which looks along -Z).",
        f = file_name(&k.path),
        levels = k.levels,
        name = format.name(),
    );
    let mut delivery = Delivery::new(vec![(k.path, k.bytes)], snippet, k.clamped);
    delivery.psnr = k.psnr;
    Ok(delivery)
}

/// three.js: `NAME.jpg`, UltraHDR with its gain map fitted to `UltraHDRLoader`'s arithmetic,
/// and `NAME.hdr` for older three.js; 4 faces wide, the face a power of two (256 to 4096, from
/// the input's or `size`), which PMREM takes whole.
fn three(ctx: &Context, size: Option<usize>) -> Result<Delivery> {
    use crate::io::ultrahdr::Reader;
    let face = size
        .unwrap_or_else(|| ctx.loaded.face_size().next_power_of_two())
        .clamp(256, 4096);
    let face = 1 << face.ilog2();
    let img = crate::convert::to_image(
        ctx.loaded,
        crate::layout::Kind::Equirect,
        face,
        &ctx.resampler(),
    );
    let (jpg, hdr) = (ctx.path(".jpg"), ctx.path(".hdr"));
    let (bytes, stats) = crate::output::ultrahdr_encode(&img, Tonemap::Aces, Reader::Three, true)
        .map_err(|e| crate::error::Error::file(&jpg, e))?;
    let fallback =
        crate::output::encode_image_as(FileFormat::Hdr, &hdr, &img, &io::WriteOptions::default())?;
    // UASTC HDR: the same panorama with its mips, which KTX2Loader transcodes per device.
    let ktx2 = match ctx.opts.encoding.gpu_format {
        Some(format) => Some(panorama_ktx2(ctx, img, format, true)?),
        None => None,
    };
    let ktx2_lines = ktx2.as_ref().map_or(String::new(), |k| {
        format!(
            "\n         Or {f} ({levels} levels of UASTC HDR 4x4: ASTC HDR where the GPU has it, \
             BC6H or half floats elsewhere):\n\
             import {{ KTX2Loader }} from 'three/addons/loaders/KTX2Loader.js';\n\
             new KTX2Loader().setTranscoderPath('three/examples/jsm/libs/basis/')\n\
               .detectSupport(renderer).load('{f}', (texture) => {{\n\
                 texture.mapping = THREE.EquirectangularReflectionMapping;\n\
                 // Its mips are the panorama's own: as a background, filter level 0 alone\n\
                 // (three draws a one-level cube from it, black through a mip-map filter).\n\
                 texture.minFilter = THREE.LinearFilter;\n\
                 scene.environment = texture;\n\
                 scene.background = texture;\n\
               }});",
            f = file_name(&k.path),
            levels = k.levels,
        )
    });
    let snippet = format!(
        "{}
three.js (r17x and later): the panorama lights and backs the scene; PMREM filters it.
         import {{ UltraHDRLoader }} from 'three/addons/loaders/UltraHDRLoader.js';
         new UltraHDRLoader().load('{j}', (texture) => {{
           texture.mapping = THREE.EquirectangularReflectionMapping;
           scene.environment = texture;
           scene.background = texture;
         }});
         Without UltraHDR: HDRLoader (RGBELoader before r179) with '{h}', the same lines.{ktx2_lines}\n\
         The panorama's centre faces world +Z (behind the default camera, which looks along -Z).",
        stats.summary(),
        j = file_name(&jpg),
        h = file_name(&hdr),
    );
    let mut files = vec![(jpg, bytes), (hdr, fallback)];
    let (mut clamped, mut psnr) = (None, None);
    if let Some(k) = ktx2 {
        files.push((k.path, k.bytes));
        (clamped, psnr) = (k.clamped, k.psnr);
    }
    let mut delivery = Delivery::new(files, snippet, clamped);
    delivery.psnr = psnr;
    Ok(delivery)
}
