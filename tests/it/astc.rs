//! ASTC HDR (4x4 and 6x6 blocks) in KTX2, built with the cargo feature `astc`: quality and
//! light on the real panoramas, round trips through `info` and `convert`, ktx-parse's and
//! Bevy's own readers, `ibl --target bevy|godot`, refusals, damaged blocks, thread counts.
//! Without the feature, only the refusal is tested.

use crate::common;

fn cli(args: &[&dyn AsRef<std::ffi::OsStr>]) -> std::process::Output {
    common::run(args.iter().map(|a| a.as_ref()))
}

/// `convert INPUT -o OUT --gpu-format astc-hdr-4x4`, which must fail and write nothing: its
/// message.
#[cfg(feature = "astc")]
fn astc_refused(input: &std::path::Path, out: &std::path::Path) -> String {
    let o = cli(&[
        &"convert",
        &input,
        &"-o",
        &out,
        &"--gpu-format",
        &"astc-hdr-4x4",
    ]);
    assert!(!o.status.success());
    assert!(!out.exists());
    common::stderr(&o)
}

/// In a build without the feature a format needs: `convert` of a small HDR image to a KTX2
/// in `format` fails and writes nothing; its message.
#[cfg(any(not(feature = "astc"), not(feature = "uastc")))]
pub(crate) fn refused_without_the_feature(format: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.hdr");
    let img = cubeforge::internals::image::Image {
        width: 16,
        height: 8,
        pixels: vec![glam::Vec4::ONE; 128],
    };
    common::write_image(&input, &img);
    let out = dir.path().join("o.ktx2");
    let o = cli(&[&"convert", &input, &"-o", &out, &"--gpu-format", &format]);
    assert!(!o.status.success());
    assert!(!out.exists());
    common::stderr(&o)
}

#[cfg(not(feature = "astc"))]
#[test]
fn astc_without_the_feature_is_refused_before_any_work() {
    let e = refused_without_the_feature("astc-hdr-4x4");
    assert!(e.contains("--features astc"), "{e}");
}

#[cfg(feature = "astc")]
pub(crate) mod with_astc {
    use super::*;
    use cubeforge::internals::convert;
    use cubeforge::internals::cube::CubeMap;
    use cubeforge::internals::flux;
    use cubeforge::internals::io::{gpu, ktx2, Decoded, GpuFormat, Limits, ReadOptions};
    use cubeforge::internals::resample::Resampler;
    use std::path::{Path, PathBuf};

    use crate::gpu_formats::panoramas;

    /// The first real panorama (.hdr), or None when the fixtures are absent.
    fn panorama() -> Option<PathBuf> {
        panoramas().into_iter().next()
    }

    /// Level 0 of a 256-face cube of each real panorama against the uncompressed map, by
    /// [`gpu::psnr`] (RGB after v / (1 + v), peak 1): least dB, and the most the light (each
    /// channel's flux) may be off, in %. Measured on esplanade, park, studio and venice (BC6H
    /// beside them: 45.1 to 57.3 dB, light within 0.91 %): the suns' blocks span 15 stops, so
    /// their weights are a stop or two apart and some light goes (see src/io/gpu/astc.rs).
    const BOUNDS: [(GpuFormat, f64, f64, f64); 2] = [
        // 4x4: 44.7 (esplanade) to 59.9 dB (studio); light within 1.51 / 1.98 / 0.09 / 0.05 %.
        // Smaller levels: at least 28.3 dB.
        (GpuFormat::AstcHdr4x4, 43.0, 2.5, 25.0),
        // 6x6: 38.5 to 51.3 dB; light within 2.26 / 3.32 / 0.41 / 0.08 %.
        // Smaller levels: at least 22.2 dB.
        (GpuFormat::AstcHdr6x6, 37.0, 4.0, 20.0),
    ];

    /// A panorama's name as the docs' tables head it.
    pub(crate) fn stem(p: &Path) -> String {
        p.file_stem()
            .map_or(String::new(), |s| s.to_string_lossy().into_owned())
    }

    /// A markdown table: a blank corner over the panoramas' names, one row per label.
    pub(crate) fn table(names: &[String], rows: &[(String, Vec<String>)]) -> String {
        let mut out = vec![
            format!("| | {} |", names.join(" | ")),
            format!("| --- |{}", " --- |".repeat(names.len())),
        ];
        for (label, cells) in rows {
            out.push(format!("| {label} | {} |", cells.join(" | ")));
        }
        out.join("\n")
    }

    fn cube_of(bytes: &[u8]) -> CubeMap {
        match ktx2::decode(bytes, Path::new("t"), &Limits::default())
            .unwrap()
            .0
        {
            Decoded::Cube(c) => c,
            Decoded::Image(_) => panic!("expected a cube map"),
        }
    }

    #[test]
    fn astc_keeps_real_panoramas_within_the_stated_psnr_and_light() {
        // docs/formats.md's table: per format, its PSNR row and its light row.
        let mut rows: Vec<(String, Vec<String>)> = BOUNDS
            .iter()
            .flat_map(|(f, ..)| {
                // As the command line names them.
                let flag = match f {
                    GpuFormat::AstcHdr4x4 => "astc-hdr-4x4",
                    _ => "astc-hdr-6x6",
                };
                [
                    (format!("`{flag}` PSNR"), Vec::new()),
                    (format!("`{flag}` light kept within"), Vec::new()),
                ]
            })
            .collect();
        let mut names = Vec::new();
        for pano in panoramas() {
            names.push(stem(&pano));
            let loaded = convert::load(std::slice::from_ref(&pano), None, &ReadOptions::default())
                .expect("loads");
            let cube = convert::to_cube(&loaded, 256, &Resampler::default()).with_box_mips(None);
            let light = |c: &CubeMap| {
                let faces: Vec<&cubeforge::internals::image::Image> = c.levels[0].iter().collect();
                flux::mean_radiance(flux::Grid::Cube(c.size()), &faces)
            };
            let source = light(&cube);
            for (i, (format, bound, within, mip_bound)) in BOUNDS.into_iter().enumerate() {
                let bytes = ktx2::encode(&cube, format);
                // The same bytes on one thread.
                let one = rayon::ThreadPoolBuilder::new()
                    .num_threads(1)
                    .build()
                    .unwrap()
                    .install(|| ktx2::encode(&cube, format));
                assert!(one == bytes, "{}: bytes depend on threads", format.name());
                let back = cube_of(&bytes);
                assert_eq!(back.levels.len(), cube.levels.len());
                let p = gpu::psnr(format, &cube.levels[0], &back.levels[0]);
                let kept = light(&back);
                let worst = (0..3)
                    .map(|c| (kept[c] / source[c] - 1.0).abs() * 100.0)
                    .fold(0.0, f64::max);
                println!(
                    "{} {}: {p:.2} dB, light within {worst:.3} %",
                    pano.display(),
                    format.name()
                );
                rows[2 * i].1.push(format!("{p:.1} dB"));
                rows[2 * i + 1].1.push(format!("{worst:.2}%"));
                assert!(p >= bound, "{}: {p:.2} dB < {bound}", pano.display());
                assert!(
                    worst <= within,
                    "{}: light off by {worst:.3} %",
                    pano.display()
                );
                // The box mips: tiny faces put a whole bright sky into one block.
                let mips = (1..cube.levels.len())
                    .map(|l| gpu::psnr(format, &cube.levels[l], &back.levels[l]))
                    .fold(f64::INFINITY, f64::min);
                println!("  smaller levels: at least {mips:.2} dB");
                assert!(mips >= mip_bound, "{}: {mips:.2} dB", pano.display());
            }
        }
        if !names.is_empty() {
            crate::figures::check("docs/formats.md", "astc real", &table(&names, &rows));
        }
    }

    #[test]
    fn astc_round_trips_through_info_convert_and_the_readers() {
        let Some(pano) = panorama() else {
            return;
        };
        let dir = tempfile::tempdir().unwrap();
        for (flag, vk, bevy, dim) in [
            (
                "astc-hdr-4x4",
                1_000_066_000u32,
                "Astc { block: B4x4, channel: Hdr }",
                3,
            ),
            (
                "astc-hdr-6x6",
                1_000_066_004,
                "Astc { block: B6x6, channel: Hdr }",
                5,
            ),
        ] {
            let out = dir.path().join(format!("{flag}.ktx2"));
            let o = cli(&[
                &"convert",
                &pano,
                &"-o",
                &out,
                &"--size",
                &"64",
                &"--gpu-format",
                &flag,
                &"-v",
            ]);
            assert!(o.status.success(), "{}", common::stderr(&o));
            assert!(
                common::stderr(&o).contains("quality: PSNR"),
                "{}",
                common::stderr(&o)
            );
            let o = cli(&[&"info", &out]);
            let text = String::from_utf8_lossy(&o.stdout);
            assert!(text.contains(if dim == 3 {
                "ASTC 4x4 HDR"
            } else {
                "ASTC 6x6 HDR"
            }));
            assert!(text.contains("mip levels:   7"), "{text}");
            // Back to an EXR cross: decoded, finite, and the same bytes on one thread.
            let exr = dir.path().join(format!("{flag}.exr"));
            let o = cli(&[&"convert", &out, &"-o", &exr, &"--to", &"hcross"]);
            assert!(o.status.success(), "{}", common::stderr(&o));
            if let Some(tools) = common::ktx_parse() {
                let v = common::ktx_check(&tools, &out, flag);
                assert_eq!(v["vkFormat"], vk, "{v}");
                assert_eq!(v["typeSize"], 1, "{v}");
                assert_eq!(v["faceCount"], 6, "{v}");
                assert_eq!(v["levelCount"], 7, "{v}");
                assert_eq!(v["dfd"]["colorModel"], 162, "{v}");
                assert_eq!(v["dfd"]["bytesPlane0"], 16, "{v}");
                let s = &v["dfd"]["samples"][0];
                assert_eq!(s["bitLength"], 127, "{v}");
                assert_eq!(s["channelType"], 0xC0, "{v}"); // FLOAT | SIGNED, ASTC data
                assert_eq!(v["rewriteIdentical"], true, "{v}");
            }
            if let Some(bin) = common::bevy_ktx2() {
                let v = common::bevy_check(&bin, &out);
                assert_eq!(v["view"], "Cube", "{v}");
                assert_eq!(v["mips"], 7, "{v}");
                assert_eq!(v["format"], bevy, "{v}");
            }
        }
        // Containers without ASTC are refused in one line, before any work.
        for ext in ["dds", "ktx"] {
            let e = astc_refused(&pano, &dir.path().join(format!("o.{ext}")));
            assert!(e.contains("holds no ASTC 4x4 HDR: write .ktx2"), "{e}");
            assert_eq!(e.trim().lines().count(), 1, "{e}");
        }
    }

    #[test]
    fn damaged_astc_blocks_read_finite() {
        let cube = CubeMap::from_fn(16, |d| (d.abs() * 3.0).extend(1.0)).with_box_mips(None);
        let mut bytes = ktx2::encode(&cube, GpuFormat::AstcHdr4x4);
        // Every block after the header's first kilobyte replaced by noise: reserved and
        // illegal encodings among them.
        let mut rng = common::XorShift(7);
        for b in bytes.iter_mut().skip(1024) {
            *b = rng.next() as u8;
        }
        let back = cube_of(&bytes);
        for level in &back.levels {
            for face in level {
                assert!(face.pixels.iter().all(|p| p.is_finite()));
            }
        }
    }

    #[test]
    fn ibl_ships_astc_hdr_to_bevy_and_godot() {
        let Some(pano) = panorama() else {
            return;
        };
        let dir = tempfile::tempdir().unwrap();
        let bevy = dir.path().join("bevy");
        let small = ["--size", "64", "--diffuse-size", "16", "--samples", "64"];
        let mut args = vec!["--gpu-format", "astc-hdr-4x4", "-v"];
        args.extend(small);
        let o = ibl(&pano, &bevy, "bevy", &args);
        assert!(o.status.success(), "{}", common::stderr(&o));
        assert!(
            common::stderr(&o).contains("ASTC 4x4 HDR quality"),
            "{}",
            common::stderr(&o)
        );
        let godot = dir.path().join("godot");
        let o = ibl(&pano, &godot, "godot", &["--gpu-format", "astc-hdr-4x4"]);
        assert!(o.status.success(), "{}", common::stderr(&o));
        let panorama = godot.join("env.ktx2");
        let (decoded, meta) =
            cubeforge::internals::convert::read_raw(&panorama, &ReadOptions::default()).unwrap();
        assert_eq!(meta.pixel_format, "ASTC 4x4 HDR");
        let Decoded::Image(img) = decoded else {
            panic!("Godot's panorama is a 2D texture");
        };
        assert_eq!(img.width, 2 * img.height);
        if let Some(bin) = common::bevy_ktx2() {
            for file in [
                bevy.join("env_specular.ktx2"),
                bevy.join("env_diffuse.ktx2"),
                panorama.clone(),
            ] {
                let v = common::bevy_check(&bin, &file);
                assert_eq!(v["format"], "Astc { block: B4x4, channel: Hdr }", "{v}");
                if file == panorama {
                    // A 2D texture (no view of its own), its chain down to one texel high.
                    assert_eq!((&v["layers"], &v["view"]), (&1.into(), &"".into()), "{v}");
                    assert_eq!(v["mips"], img.height.ilog2() + 1, "{v}");
                } else {
                    assert_eq!(v["view"], "Cube", "{v}");
                }
            }
        }
        // Targets with no place for the format say so before any work.
        for (target, format, says) in [
            (
                "godot",
                "astc-hdr-6x6",
                "Godot reads ASTC HDR in 4x4 blocks",
            ),
            (
                "unity",
                "astc-hdr-4x4",
                "unity is given a panorama that it filters itself",
            ),
            ("filament", "astc-hdr-4x4", "KTX 1 output takes"),
        ] {
            let out = dir.path().join(format!("{target}-refused"));
            let o = ibl(&pano, &out, target, &["--gpu-format", format]);
            assert!(!o.status.success(), "{target}");
            assert!(common::stderr(&o).contains(says), "{}", common::stderr(&o));
            assert!(!out.exists(), "{target}");
        }
    }

    /// `cubeforge ibl INPUT -o OUT --target TARGET EXTRA...`, its outcome unchecked.
    fn ibl(input: &Path, out: &Path, target: &str, extra: &[&str]) -> std::process::Output {
        let head = [
            input.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
            "--target".as_ref(),
        ];
        let args = std::iter::once("ibl".as_ref())
            .chain(head)
            .chain([target.as_ref()])
            .chain(extra.iter().map(|a| a.as_ref()));
        common::run(args.collect::<Vec<&std::ffi::OsStr>>())
    }
}
