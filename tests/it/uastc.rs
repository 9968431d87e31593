//! UASTC HDR 4x4 in KTX2, built with the cargo feature `uastc` (basis_universal's encoder):
//! quality and light on the real panoramas, thread counts, round trips through `info` and
//! `convert`, and the readers: ktx-parse, Bevy's own loader, and Basis Universal's transcoder
//! as three.js ships it (`tests/tools/uastc_check.cjs`), which must take the file as UASTC HDR
//! and transcode every image to BC6H and to half floats. Without the feature, only the refusal.

#[cfg(feature = "uastc")]
use crate::common;

#[cfg(feature = "uastc")]
fn cli(args: &[&dyn AsRef<std::ffi::OsStr>]) -> std::process::Output {
    common::run(args.iter().map(|a| a.as_ref()))
}

#[cfg(not(feature = "uastc"))]
#[test]
fn uastc_without_the_feature_is_refused_before_any_work() {
    let e = crate::astc::refused_without_the_feature("uastc-hdr-4x4");
    assert!(e.contains("--features uastc"), "{e}");
}

#[cfg(feature = "uastc")]
mod with_uastc {
    use super::*;
    use crate::gpu_formats::panoramas;
    use cubeforge::internals::convert;
    use cubeforge::internals::cube::CubeMap;
    use cubeforge::internals::flux;
    use cubeforge::internals::image::Image;
    use cubeforge::internals::io::{gpu, ktx2, Decoded, GpuFormat, Limits, ReadOptions};
    use cubeforge::internals::resample::Resampler;
    use std::path::Path;
    use std::process::Command;

    const TRANSCODER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/tools/uastc_check.cjs");

    fn cube_of(bytes: &[u8]) -> CubeMap {
        match ktx2::decode(bytes, Path::new("t"), &Limits::default())
            .unwrap()
            .0
        {
            Decoded::Cube(c) => c,
            Decoded::Image(_) => panic!("expected a cube map"),
        }
    }

    fn light(c: &CubeMap) -> [f64; 3] {
        let faces: Vec<&Image> = c.levels[0].iter().collect();
        flux::mean_radiance(flux::Grid::Cube(c.size()), &faces)
    }

    /// Level 0 of a 256-face cube of each real panorama against the uncompressed map (PSNR
    /// as for BC6H and ASTC), the light of each channel, and the bytes on one thread.
    /// Measured: 42.8 (esplanade), 52.3 (park), 56.3 (studio) and 52.9 dB (venice), light
    /// within 0.72 / 1.76 / 0.16 / 0.03 %; smaller levels at least 24.6 dB. astcenc's
    /// unrestricted 4x4 blocks: 44.7 to 59.9 dB (tests/it/astc.rs).
    #[test]
    fn uastc_keeps_real_panoramas_within_the_stated_psnr_and_light() {
        let (mut names, mut psnr, mut kept_light) = (Vec::new(), Vec::new(), Vec::new());
        for pano in panoramas() {
            names.push(crate::astc::with_astc::stem(&pano));
            let loaded = convert::load(std::slice::from_ref(&pano), None, &ReadOptions::default())
                .expect("loads");
            let cube = convert::to_cube(&loaded, 256, &Resampler::default()).with_box_mips(None);
            let source = light(&cube);
            let format = GpuFormat::UastcHdr4x4;
            let bytes = ktx2::encode(&cube, format);
            let one = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap()
                .install(|| ktx2::encode(&cube, format));
            assert!(one == bytes, "bytes depend on threads");
            let back = cube_of(&bytes);
            assert_eq!(back.levels.len(), cube.levels.len());
            let p = gpu::psnr(format, &cube.levels[0], &back.levels[0]);
            let kept = light(&back);
            let worst = (0..3)
                .map(|c| (kept[c] / source[c] - 1.0).abs() * 100.0)
                .fold(0.0, f64::max);
            let mips = (1..cube.levels.len())
                .map(|l| gpu::psnr(format, &cube.levels[l], &back.levels[l]))
                .fold(f64::INFINITY, f64::min);
            println!(
                "{}: {p:.2} dB, light within {worst:.3} %, smaller levels at least {mips:.2} dB",
                pano.display()
            );
            psnr.push(format!("{p:.1} dB"));
            kept_light.push(format!("{worst:.2}%"));
            assert!(p >= 41.5, "{}: {p:.2} dB", pano.display());
            assert!(
                worst <= 2.5,
                "{}: light off by {worst:.3} %",
                pano.display()
            );
            assert!(mips >= 23.0, "{}: {mips:.2} dB", pano.display());
        }
        if !names.is_empty() {
            let rows = [
                ("`uastc-hdr-4x4` PSNR".to_string(), psnr),
                ("`uastc-hdr-4x4` light kept within".to_string(), kept_light),
            ];
            let text = crate::astc::with_astc::table(&names, &rows);
            crate::figures::check("docs/formats.md", "uastc real", &text);
        }
    }

    /// What Basis Universal's transcoder (three.js's copy) makes of `file`, its images
    /// written into `out`; None (after a SKIPPED line, or a failure under CI) without three.
    fn transcoded(file: &Path, out: &Path) -> Option<serde_json::Value> {
        let tools = common::three_js()?;
        let o = Command::new("node")
            .arg(TRANSCODER)
            .arg(out)
            .arg(file)
            .env("CUBEFORGE_TOOLS", &tools)
            .output()
            .expect("node runs");
        assert!(o.status.success(), "{}", common::stderr(&o));
        Some(serde_json::from_slice(&o.stdout).expect("uastc_check.cjs prints JSON"))
    }

    #[test]
    fn uastc_round_trips_and_basis_transcodes_every_image() {
        let Some(pano) = panoramas().into_iter().next() else {
            return;
        };
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("u.ktx2");
        let o = cli(&[
            &"convert",
            &pano,
            &"-o",
            &out,
            &"--size",
            &"64",
            &"--gpu-format",
            &"uastc-hdr-4x4",
            &"-v",
        ]);
        assert!(o.status.success(), "{}", common::stderr(&o));
        assert!(common::stderr(&o).contains("UASTC HDR 4x4 quality: PSNR"));
        let o = cli(&[&"info", &out]);
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(text.contains("UASTC HDR 4x4"), "{text}");
        assert!(text.contains("mip levels:   7"), "{text}");
        let exr = dir.path().join("back.exr");
        let o = cli(&[&"convert", &out, &"-o", &exr, &"--to", &"hcross"]);
        assert!(o.status.success(), "{}", common::stderr(&o));
        let ours = cube_of(&std::fs::read(&out).unwrap());

        if let Some(tools) = common::ktx_parse() {
            let v = common::ktx_check(&tools, &out, "UASTC HDR 4x4");
            assert_eq!(v["vkFormat"], 1_000_066_000u32, "{v}");
            assert_eq!(v["faceCount"], 6, "{v}");
            assert_eq!(v["levelCount"], 7, "{v}");
            assert_eq!(v["dfd"]["colorModel"], 167, "{v}"); // basis_universal's UASTC HDR 4x4
            let s = &v["dfd"]["samples"][0];
            assert_eq!(s["bitLength"], 127, "{v}");
            assert_eq!(s["channelType"], 0x80, "{v}"); // FLOAT, as basis_universal writes it
            assert_eq!(v["rewriteIdentical"], true, "{v}");
        }
        if let Some(bin) = common::bevy_ktx2() {
            // Bevy takes the blocks as the ASTC HDR they are.
            let v = common::bevy_check(&bin, &out);
            assert_eq!(v["view"], "Cube", "{v}");
            assert_eq!(v["mips"], 7, "{v}");
            assert_eq!(v["format"], "Astc { block: B4x4, channel: Hdr }", "{v}");
        }
        let images = dir.path().join("transcoded");
        std::fs::create_dir(&images).unwrap();
        if let Some(v) = transcoded(&out, &images) {
            assert_eq!(v["valid"], true, "{v}");
            assert_eq!(
                (&v["hdr"], &v["uastc"]),
                (&true.into(), &false.into()),
                "{v}"
            );
            assert_eq!((&v["faces"], &v["levels"]), (&6.into(), &7.into()), "{v}");
            assert_eq!(v["failed"], serde_json::json!([]), "{v}");
            let (mut worst_half, mut bc6h_levels) = (0f32, Vec::new());
            let mut bc6h_light = [0.0f64; 3];
            for (l, level) in ours.levels.iter().enumerate() {
                let mut bc6h_faces = Vec::new();
                for (f, face) in level.iter().enumerate() {
                    let read = |name: &str, format: GpuFormat| {
                        let bytes = std::fs::read(images.join(format!("{name}_{l}_{f}.bin")));
                        format
                            .decode_image(&bytes.unwrap(), face.width, face.height)
                            .unwrap()
                    };
                    // Basis's half floats are the ASTC blocks decoded: ours, to half precision.
                    let half = read("half", GpuFormat::Rgba16f);
                    for (a, b) in half.pixels.iter().zip(&face.pixels) {
                        let e =
                            ((*a - *b).abs() / b.abs().max(glam::Vec4::splat(1e-3))).max_element();
                        worst_half = worst_half.max(e);
                    }
                    bc6h_faces.push(read("bc6h", GpuFormat::Bc6h));
                }
                // Its BC6H: the same map, within BC6H's own error.
                bc6h_levels.push(gpu::psnr(GpuFormat::Bc6h, level, &bc6h_faces));
                if l == 0 {
                    let faces: Vec<&Image> = bc6h_faces.iter().collect();
                    bc6h_light = flux::mean_radiance(flux::Grid::Cube(level[0].width), &faces);
                }
            }
            println!("transcoder: half floats within {worst_half:.2e}, BC6H by level {bc6h_levels:.2?} dB");
            assert!(worst_half <= 1e-3, "{worst_half}");
            // What a desktop browser gets (three.js transcodes to BC6H there): its light
            // against the panorama's own at this size.
            let loaded = convert::load(std::slice::from_ref(&pano), None, &ReadOptions::default())
                .expect("loads");
            let source = light(&convert::to_cube(&loaded, 64, &Resampler::default()));
            let off: Vec<String> = ["red", "green", "blue"]
                .iter()
                .enumerate()
                .map(|(c, n)| format!("{:+.1}% {n}", (bc6h_light[c] / source[c] - 1.0) * 100.0))
                .collect();
            let text = format!(
                "its BC6H is {:.1} dB from them at level 0, and the light a desktop browser gets \
                 from it is off the panorama's by {} ({})",
                bc6h_levels[0],
                off.join(", "),
                crate::astc::with_astc::stem(&pano)
            );
            crate::figures::check("docs/formats.md", "uastc transcoded", &text);
            assert!(bc6h_levels[0] >= 44.0, "{bc6h_levels:?}");
            // The check has teeth: astcenc's blocks (outside the subset) under UASTC's colour
            // model do not transcode to BC6H.
            let astc = dir.path().join("astc.ktx2");
            let o = cli(&[
                &"convert",
                &pano,
                &"-o",
                &astc,
                &"--size",
                &"64",
                &"--gpu-format",
                &"astc-hdr-4x4",
            ]);
            assert!(o.status.success(), "{}", common::stderr(&o));
            let mut bytes = std::fs::read(&astc).unwrap();
            let dfd = u32::from_le_bytes(bytes[48..52].try_into().unwrap()) as usize;
            assert_eq!(bytes[dfd + 12], 162);
            bytes[dfd + 12] = 167;
            std::fs::write(&astc, &bytes).unwrap();
            let v = transcoded(&astc, &images).unwrap();
            assert!(!v["failed"].as_array().unwrap().is_empty(), "{v}");
            // Zstandard levels, which the transcoder inflates itself.
            let zstd = dir.path().join("zstd.ktx2");
            let o = cli(&[
                &"convert",
                &out,
                &"-o",
                &zstd,
                &"--gpu-format",
                &"uastc-hdr-4x4",
                &"--zstd",
            ]);
            assert!(o.status.success(), "{}", common::stderr(&o));
            let v = transcoded(&zstd, &images).unwrap();
            assert_eq!((&v["hdr"], &v["levels"]), (&true.into(), &7.into()), "{v}");
            assert_eq!(v["failed"], serde_json::json!([]), "{v}");
        }
    }

    /// `cubeforge ibl PANO -o OUT --target TARGET --gpu-format uastc-hdr-4x4 --size 64 ...`.
    fn ibl(pano: &Path, out: &Path, target: &str) -> std::process::Output {
        cli(&[
            &"ibl",
            &pano,
            &"-o",
            &out,
            &"--target",
            &target,
            &"--gpu-format",
            &"uastc-hdr-4x4",
            &"--size",
            &"64",
            &"--diffuse-size",
            &"16",
            &"--samples",
            &"64",
        ])
    }

    #[test]
    fn ibl_ships_uastc_hdr_to_bevy_and_three() {
        let Some(pano) = panoramas().into_iter().next() else {
            return;
        };
        let dir = tempfile::tempdir().unwrap();
        let bevy = dir.path().join("bevy");
        let o = ibl(&pano, &bevy, "bevy");
        assert!(o.status.success(), "{}", common::stderr(&o));
        for file in ["env_specular.ktx2", "env_diffuse.ktx2"] {
            let (_, meta) =
                cubeforge::internals::convert::read_raw(&bevy.join(file), &ReadOptions::default())
                    .unwrap();
            assert_eq!(meta.pixel_format, "UASTC HDR 4x4");
            if let Some(bin) = common::bevy_ktx2() {
                common::bevy_check(&bin, &bevy.join(file));
            }
        }
        // three.js: the UltraHDR and .hdr panoramas, and the same as UASTC HDR with its mips
        // for KTX2Loader, which Basis's transcoder takes whole.
        let three = dir.path().join("three");
        let o = ibl(&pano, &three, "three");
        assert!(o.status.success(), "{}", common::stderr(&o));
        let printed = String::from_utf8_lossy(&o.stdout);
        assert!(printed.contains("KTX2Loader"), "{printed}");
        for file in ["env.jpg", "env.hdr", "env.ktx2"] {
            assert!(three.join(file).is_file(), "{file}");
        }
        let images = dir.path().join("transcoded");
        std::fs::create_dir(&images).unwrap();
        if let Some(v) = transcoded(&three.join("env.ktx2"), &images) {
            assert_eq!((&v["hdr"], &v["faces"]), (&true.into(), &1.into()), "{v}");
            assert_eq!(v["width"], 2 * v["height"].as_u64().unwrap(), "{v}");
            assert_eq!(v["failed"], serde_json::json!([]), "{v}");
        }
        // Godot's loader is no transcoder: it is given ASTC HDR.
        let godot = dir.path().join("godot");
        let o = ibl(&pano, &godot, "godot");
        assert!(!o.status.success());
        assert!(
            common::stderr(&o).contains("astc-hdr-4x4"),
            "{}",
            common::stderr(&o)
        );
        assert!(!godot.exists());
    }

    /// three.js's own KTX2Loader (headless Chromium, its Basis transcoder in a worker, formats
    /// from the page's WebGL2 renderer) loads `ibl --target three`'s env.ktx2 of the marker
    /// panorama: the transcoded level 0 is our map (its rows bottom first, as three.js uploads
    /// a compressed texture unflipped), and the marks land where they do for env.jpg.
    #[test]
    fn three_ktx2loader_sees_the_marks_where_they_belong() {
        let dir = tempfile::tempdir().unwrap();
        let src = crate::ibl::marker_panorama(dir.path());
        let out = dir.path().join("three");
        let o = ibl(&src, &out, "three");
        assert!(o.status.success(), "{}", common::stderr(&o));
        let file = out.join("env.ktx2");
        // cubeforge reads it back top row first (KTXorientation "ru" undone).
        let (decoded, _) =
            cubeforge::internals::convert::read_raw(&file, &ReadOptions::default()).unwrap();
        let Decoded::Image(ours) = decoded else {
            panic!("a 2D texture")
        };
        let marks = crate::ultrahdr::marks_three_sees(&ours, true, "cubeforge's read");
        crate::ibl::assert_unmirrored("cubeforge env.ktx2", marks, true, glam::Vec3::Z);
        if !crate::view::browser() || common::three_js().is_none() {
            return;
        }
        let read = dir.path().join("read");
        std::fs::create_dir(&read).unwrap();
        let o = Command::new("node")
            .arg(crate::ultrahdr::THREE_TOOL)
            .arg(&read)
            .arg(&file)
            .output()
            .expect("node runs");
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{stdout} {}", common::stderr(&o));
        let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
        assert!(v.get("error").is_none(), "KTX2Loader: {v}");
        assert_eq!(v["flipY"], false, "{v}");
        assert_eq!(v["mips"], ours.height.ilog2() + 1, "{v}");
        let format = match v["format"].as_str() {
            Some("bc6h") => GpuFormat::Bc6h,
            Some("half") => GpuFormat::Rgba16f,
            other => panic!("KTX2Loader made {other:?}"),
        };
        let bytes = std::fs::read(read.join("0.f32")).unwrap();
        let theirs = format
            .decode_image(&bytes, ours.width, ours.height)
            .unwrap();
        let p = gpu::psnr(GpuFormat::Bc6h, [&ours.flipped_rows()], [&theirs]);
        println!(
            "KTX2Loader: {} ({p:.1} dB from cubeforge's read)",
            v["format"]
        );
        assert!(p >= 40.0, "{p:.1} dB");
        let marks = crate::ultrahdr::marks_three_sees(&theirs, false, "KTX2Loader");
        crate::ibl::assert_unmirrored("three.js env.ktx2", marks, true, glam::Vec3::Z);
    }
}
