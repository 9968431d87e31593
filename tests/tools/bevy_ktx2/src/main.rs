//! Loads each KTX2 file given with Bevy's own loader (`bevy_image::ktx2_buffer_to_image`, what
//! `AssetServer` runs for `.ktx2`) and prints, one JSON line per file, what Bevy made of it.
//! Exits non-zero, with Bevy's error, when Bevy refuses a file. The device it loads for
//! takes BC and ASTC HDR blocks (a desktop GPU, a phone's GPU).

fn main() {
    use bevy_image::{ktx2_buffer_to_image, CompressedImageFormats};
    let mut failed = false;
    for path in std::env::args().skip(1) {
        let bytes = std::fs::read(&path).expect("readable file");
        match ktx2_buffer_to_image(
            &bytes,
            CompressedImageFormats::BC | CompressedImageFormats::ASTC_HDR,
            false,
        ) {
            Ok(img) => {
                let d = &img.texture_descriptor;
                let view = img
                    .texture_view_descriptor
                    .as_ref()
                    .and_then(|v| v.dimension)
                    .map(|v| format!("{v:?}"))
                    .unwrap_or_default();
                println!(
                    "{{\"file\":{path:?},\"width\":{},\"height\":{},\"layers\":{},\"mips\":{},\"format\":\"{:?}\",\"view\":\"{view}\",\"bytes\":{}}}",
                    d.size.width,
                    d.size.height,
                    d.size.depth_or_array_layers,
                    d.mip_level_count,
                    d.format,
                    img.data.as_ref().map_or(0, |b| b.len()),
                );
            }
            Err(e) => {
                eprintln!("{path}: Bevy refused it: {e:?}");
                failed = true;
            }
        }
    }
    std::process::exit(i32::from(failed));
}
