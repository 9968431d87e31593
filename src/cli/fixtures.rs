//! Writes the project's own fixtures: the demo sky the README's set-up and examples read, and
//! a two-part OpenEXR file of it (as renderers write their passes) for `--part`.

use cubeforge::internals::io::WriteOptions;
use cubeforge::internals::layout::Projection;
use cubeforge::internals::resample::{FnEnv, Resampler};
use cubeforge::internals::synthetic;
use cubeforge::Result;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Folder that receives sky.exr (HDR) and sky.png (LDR), 512 x 256 panoramas, and
    /// passes.exr (the sky at 256 x 128 in two parts, "sky" and "dim" at a quarter of it).
    #[arg(default_value = "fixtures")]
    pub dir: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    let env = FnEnv(synthetic::demo_sky);
    // Antialiased by supersampling the function itself: 4 x 4 exact samples per pixel.
    let big = Resampler::default().to_projection(&env, Projection::Equirect, 2048, 1024);
    let img = big.downsample_2x().downsample_2x();
    let mut files = Vec::new();
    for name in ["sky.exr", "sky.png"] {
        let path = args.dir.join(name);
        let bytes =
            cubeforge::internals::output::encode_image(&path, &img, &WriteOptions::default())?;
        files.push((path, bytes));
    }
    let small = img.downsample_2x();
    files.push((args.dir.join("passes.exr"), passes(&small)?));
    // The folder, when missing, is made by the write path with the files, whole.
    super::write_files(&files)
}

/// `img` as a two-part OpenEXR file: part "sky", and part "dim" at a quarter of it (half
/// floats, ZIP), through the exr crate.
fn passes(img: &cubeforge::internals::image::Image) -> Result<Vec<u8>> {
    use exr::prelude::*;
    let part = |name: &str, scale: f32| {
        let plane = |c: usize| {
            let samples = img
                .pixels
                .iter()
                .map(|p| f16::from_f32(p[c] * scale))
                .collect();
            AnyChannel::new(["R", "G", "B"][c], FlatSamples::F16(samples))
        };
        let channels = AnyChannels::sort(SmallVec::from_vec(vec![plane(0), plane(1), plane(2)]));
        Layer::new(
            (img.width, img.height),
            LayerAttributes::named(name),
            Encoding::SMALL_LOSSLESS,
            channels,
        )
    };
    let layers = vec![part("sky", 1.0), part("dim", 0.25)];
    let bounds = IntegerBounds::from_dimensions((img.width, img.height));
    let mut bytes = std::io::Cursor::new(Vec::new());
    exr::image::Image::from_layers(ImageAttributes::new(bounds), layers)
        .write()
        .non_parallel()
        .to_buffered(&mut bytes)
        .map_err(|e| cubeforge::Error::usage(format!("cannot write passes.exr: {e}")))?;
    Ok(bytes.into_inner())
}
