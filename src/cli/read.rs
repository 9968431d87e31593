//! How inputs are read beyond their layout: which part of an OpenEXR file, and 8-bit files
//! that hold RGBM or RGBD.

/// Which part of a multi-part OpenEXR input to read.
#[derive(clap::Args, Debug)]
pub struct PartArg {
    /// Which part of a multi-part OpenEXR file to read: its index (0 is the first) or its
    /// name. Without it the first is read, and a warning says so.
    #[arg(long, value_name = "N|NAME")]
    pub part: Option<String>,
}

impl PartArg {
    /// The part's index, a name looked up in `inputs` (one OpenEXR file).
    pub fn index(&self, inputs: &[std::path::PathBuf]) -> cubeforge::Result<Option<usize>> {
        let Some(choice) = &self.part else {
            return Ok(None);
        };
        match inputs {
            [file] => cubeforge::internals::io::exr_part(file, choice).map(Some),
            _ => choice.parse().map(Some).map_err(|_| {
                cubeforge::Error::usage(format!(
                    "--part {choice:?}: a part's name needs one OpenEXR input"
                ))
            }),
        }
    }
}

/// `--decode`: an 8-bit file that holds RGBM or RGBD radiance.
#[derive(clap::Args, Debug)]
pub struct DecodeArg {
    /// Read an 8-bit PNG, TGA or RGBA8 KTX2/DDS as RGBM (L = rgb a 6, 7, 8 or 16) or Babylon's
    /// RGBD (L = rgb^2.2 / a): HDR radiance. PNGs cubeforge wrote, and KTX2s written with
    /// --cubeforge-keys, say so themselves.
    #[arg(long, value_enum, value_name = "ENCODING")]
    pub decode: Option<cubeforge::internals::io::HdrEncoding>,
}
