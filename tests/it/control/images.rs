//! Images as sources: their channels, luminance and sRGB decoding, the filters they are
//! resized with, and where the map's size comes from.

use super::*;
use cubeforge::internals::image::{luminance, srgb_to_linear};
use glam::Vec4;

#[test]
fn image_channels_luminance_and_srgb_decode() {
    let dir = tempfile::tempdir().unwrap();
    let px = [200u8, 100, 50, 128, 10, 20, 240, 255];
    write_png8(&dir.path().join("m.png"), 2, 1, &px);
    let f = |b: u8| b as f32 / 255.0;
    let get = |ch: &str, srgb: bool| {
        let text = format!(
            "[reflectivity]\nimage = {{ path = \"m.png\", channel = \"{ch}\", srgb = {srgb} }}\n"
        );
        channel(&bake_in(dir.path(), &text, 2, 1), 0)
    };
    assert_close(&get("r", false), &[f(200), f(10)]);
    assert_close(&get("g", false), &[f(100), f(20)]);
    assert_close(&get("b", false), &[f(50), f(240)]);
    assert_close(&get("a", false), &[f(128), f(255)]);
    assert_close(&get("red", false), &[f(200), f(10)]);
    let lum = |a: [u8; 3], dec: bool| {
        let t = |b: u8| if dec { srgb_to_linear(f(b)) } else { f(b) };
        luminance(Vec4::new(t(a[0]), t(a[1]), t(a[2]), 0.0))
    };
    assert_close(
        &get("luminance", false),
        &[lum([200, 100, 50], false), lum([10, 20, 240], false)],
    );
    // srgb = true decodes colour; alpha is never decoded.
    assert_close(
        &get("r", true),
        &[srgb_to_linear(f(200)), srgb_to_linear(f(10))],
    );
    assert_close(&get("a", true), &[f(128), f(255)]);
    assert_close(
        &get("luminance", true),
        &[lum([200, 100, 50], true), lum([10, 20, 240], true)],
    );
    // Luminance is the default channel.
    let d = bake_in(
        dir.path(),
        "[reflectivity]\nimage = { path = \"m.png\" }\n",
        2,
        1,
    );
    assert_close(&channel(&d, 0), &get("luminance", false));

    // A grey 16-bit PNG: exact 16-bit values.
    let grey16: Vec<u16> = vec![0, 13107, 65535, 32768];
    let bytes: Vec<u8> = grey16.iter().flat_map(|v| v.to_ne_bytes()).collect();
    image::save_buffer(
        dir.path().join("g16.png"),
        &bytes,
        4,
        1,
        image::ExtendedColorType::L16,
    )
    .unwrap();
    let v = channel(
        &bake_in(
            dir.path(),
            "max_lod_bias = 1\n[blur]\nimage = { path = \"g16.png\", channel = \"r\" }\n",
            4,
            1,
        ),
        2,
    );
    assert_close(&v, &[0.0, 0.2, 1.0, 32768.0 / 65535.0]);

    // Float data above 1 clamps to 1; srgb does not apply to it.
    let img = cubeforge::internals::image::Image {
        width: 2,
        height: 1,
        pixels: vec![
            Vec4::new(3.0, 0.25, 0.0, 1.0),
            Vec4::new(0.5, 0.0, 0.0, 1.0),
        ],
    };
    let exr = dir.path().join("f.exr");
    std::fs::write(
        &exr,
        cubeforge::internals::output::encode_image(&exr, &img, &Default::default()).unwrap(),
    )
    .unwrap();
    let v = channel(
        &bake_in(
            dir.path(),
            "[fresnel]\nimage = { path = \"f.exr\", channel = \"r\", srgb = true }\n",
            2,
            1,
        ),
        3,
    );
    assert_close(&v, &[1.0, 0.5]);
}

#[test]
fn images_resize_with_area_filter_down_and_bilinear_up() {
    let dir = tempfile::tempdir().unwrap();
    // 4 x 1 grey: 0, 64, 128, 255.
    let row = [0u8, 64, 128, 255];
    let rgba: Vec<u8> = row.iter().flat_map(|&v| [v, v, v, 255]).collect();
    write_png8(&dir.path().join("row.png"), 4, 1, &rgba);
    let f = |b: u8| b as f32 / 255.0;
    let src = "[reflectivity]\nimage = { path = \"row.png\", channel = \"r\" }\n";
    // Shrinking 4 -> 2: each output texel is the mean of the two it covers.
    assert_close(
        &channel(&bake_in(dir.path(), src, 2, 1), 0),
        &[(f(0) + f(64)) / 2.0, (f(128) + f(255)) / 2.0],
    );
    // 4 -> 1: the mean of all.
    assert_close(
        &channel(&bake_in(dir.path(), src, 1, 1), 0),
        &[(f(0) + f(64) + f(128) + f(255)) / 4.0],
    );
    // 4 -> 3: area weights (each output texel covers 4/3 input texels).
    assert_close(
        &channel(&bake_in(dir.path(), src, 3, 1), 0),
        &[
            (f(0) + f(64) / 3.0) * 0.75,
            (f(64) * 2.0 / 3.0 + f(128) * 2.0 / 3.0) * 0.75,
            (f(128) / 3.0 + f(255)) * 0.75,
        ],
    );
    // Enlarging 4 -> 8: bilinear between texel centres, edges clamped.
    let (a, b, c, d) = (f(0), f(64), f(128), f(255));
    assert_close(
        &channel(&bake_in(dir.path(), src, 8, 1), 0),
        &[
            a,
            a * 0.75 + b * 0.25,
            a * 0.25 + b * 0.75,
            b * 0.75 + c * 0.25,
            b * 0.25 + c * 0.75,
            c * 0.75 + d * 0.25,
            c * 0.25 + d * 0.75,
            d,
        ],
    );
    // Each axis on its own: 4x1 -> 2x3 shrinks across and stretches down (one row: copies).
    let v = channel(&bake_in(dir.path(), src, 2, 3), 0);
    let want = [(a + b) / 2.0, (c + d) / 2.0];
    assert_close(&v, &[want, want, want].concat());

    // A 2 x 2 image -> 1 x 1 is the mean; vertical shrinking works like horizontal.
    let sq = [10u8, 20, 30, 40];
    let rgba: Vec<u8> = sq.iter().flat_map(|&v| [v, v, v, 255]).collect();
    write_png8(&dir.path().join("sq.png"), 2, 2, &rgba);
    let v = channel(
        &bake_in(
            dir.path(),
            "[reflectivity]\nimage = { path = \"sq.png\", channel = \"g\" }\n",
            1,
            1,
        ),
        0,
    );
    assert_close(&v, &[(f(10) + f(20) + f(30) + f(40)) / 4.0]);
    let v = channel(
        &bake_in(
            dir.path(),
            "[reflectivity]\nimage = { path = \"sq.png\", channel = \"g\" }\n",
            2,
            1,
        ),
        0,
    );
    assert_close(&v, &[(f(10) + f(30)) / 2.0, (f(20) + f(40)) / 2.0]);

    // The library function on a plane directly.
    assert_close(
        &control::resize(&[0.0, 1.0], 2, 1, 4, 1),
        &[0.0, 0.25, 0.75, 1.0],
    );
    assert_close(
        &control::resize(&[0.0, 1.0], 1, 2, 1, 4),
        &[0.0, 0.25, 0.75, 1.0],
    );
}

#[test]
fn size_comes_from_the_option_the_recipe_or_the_first_image() {
    let dir = tempfile::tempdir().unwrap();
    write_png8(&dir.path().join("m.png"), 3, 2, &[255u8; 24]);
    let r = parse_in(
        dir.path(),
        "[fresnel]\nimage = { path = \"m.png\" }\n",
        Syntax::Toml,
    )
    .unwrap();
    assert_eq!(r.output_size(None).unwrap(), Size::new(3, 2).unwrap());
    let r = parse_in(
        dir.path(),
        "size = \"7x5\"\n[fresnel]\nimage = { path = \"m.png\" }\n",
        Syntax::Toml,
    )
    .unwrap();
    assert_eq!(r.output_size(None).unwrap(), Size::new(7, 5).unwrap());
    let given = Some(Size::new(4, 4).unwrap());
    assert_eq!(r.output_size(given).unwrap(), Size::new(4, 4).unwrap());
    let r = parse_in(dir.path(), "size = 16\n", Syntax::Toml).unwrap();
    assert_eq!(r.output_size(None).unwrap(), Size::new(16, 16).unwrap());
    let r = parse_in(dir.path(), "reflectivity = 1\n", Syntax::Toml).unwrap();
    let e = r.output_size(None).unwrap_err().to_string();
    assert!(e.contains("no size"), "{e}");
    assert!("0x4".parse::<Size>().is_err());
    assert!("4by4".parse::<Size>().is_err());
    assert_eq!("12X3".parse::<Size>().unwrap(), Size::new(12, 3).unwrap());
}
