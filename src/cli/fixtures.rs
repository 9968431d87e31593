//! Writes the project's own fixtures: the demo sky the README's set-up and examples read.

use cubeforge::io::{self, WriteOptions};
use cubeforge::layout::Projection;
use cubeforge::resample::{FnEnv, Resampler};
use cubeforge::{synthetic, Result};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Folder that receives sky.exr (HDR) and sky.png (LDR), 512 x 256 panoramas.
    #[arg(default_value = "fixtures")]
    pub dir: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    let env = FnEnv(synthetic::demo_sky);
    // Antialiased by supersampling the function itself: 4 x 4 exact samples per pixel.
    let big = Resampler::default().to_projection(&env, Projection::Equirect, 2048, 1024);
    let img = big.downsample_2x().downsample_2x();
    std::fs::create_dir_all(&args.dir).map_err(|e| cubeforge::Error::io(&args.dir, e))?;
    let mut files = Vec::new();
    for name in ["sky.exr", "sky.png"] {
        let path = args.dir.join(name);
        let bytes = io::encode_image(&path, &img, &WriteOptions::default())?;
        files.push((path, bytes));
    }
    super::write_files(&files)
}
