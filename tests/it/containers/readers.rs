//! Independent readers (tests/common): each test is skipped, with a line on stderr, when its
//! reader is not installed, and fails when CI is set.

use super::*;
use crate::common;
use std::process::Command;

#[test]
fn ktx_parse_reads_our_ktx2() {
    let Some(tools) = common::ktx_parse() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    for format in FORMATS {
        let cube = test_cube(format);
        let path = dir.path().join("cube.ktx2");
        std::fs::write(&path, ktx2::encode(&cube, format)).unwrap();
        let v = common::ktx_check(&tools, &path, format.name());
        let bpt = format.block_bytes() as u64;
        let (vk, transfer) = match format {
            GpuFormat::Rgba16f => (97, 1),
            GpuFormat::Rgba32f => (109, 1),
            GpuFormat::Rgba8Srgb => (43, 2),
            GpuFormat::Rgba8 => (37, 1),
            _ => unreachable!("the plain formats"),
        };
        assert_eq!(v["vkFormat"], vk, "{v}");
        assert_eq!(v["typeSize"], bpt / 4, "{v}");
        assert_eq!(v["pixelWidth"], 8, "{v}");
        assert_eq!(v["pixelHeight"], 8, "{v}");
        assert_eq!(v["pixelDepth"], 0, "{v}");
        assert_eq!(v["layerCount"], 0, "{v}");
        assert_eq!(v["faceCount"], 6, "{v}");
        assert_eq!(v["levelCount"], 4, "{v}");
        assert_eq!(v["supercompressionScheme"], 0, "{v}");
        let sizes: Vec<u64> = (0..4).map(|l| 6 * (8u64 >> l).pow(2) * bpt).collect();
        assert_eq!(v["levels"], serde_json::json!(sizes), "{v}");
        assert_eq!(v["uncompressedLevels"], serde_json::json!(sizes), "{v}");
        let dfd = &v["dfd"];
        assert_eq!(dfd["colorModel"], 1, "RGBSDA: {v}");
        assert_eq!(dfd["colorPrimaries"], 1, "BT709: {v}");
        assert_eq!(dfd["transferFunction"], transfer, "{v}");
        assert_eq!(dfd["bytesPlane0"], bpt, "{v}");
        let samples = dfd["samples"].as_array().unwrap();
        assert_eq!(samples.len(), 4, "{v}");
        let bits = bpt * 2;
        for (i, (s, channel)) in samples.iter().zip([0u64, 1, 2, 15]).enumerate() {
            assert_eq!(s["bitOffset"], i as u64 * bits, "{v}");
            assert_eq!(s["bitLength"], bits - 1, "{v}");
            assert_eq!(s["channelType"].as_u64().unwrap() & 0xF, channel, "{v}");
        }
        assert_eq!(
            v["writer"],
            format!("cubeforge {}", env!("CARGO_PKG_VERSION")),
            "{v}"
        );
        assert_eq!(
            v["rewriteIdentical"], true,
            "ktx-parse lays the file out differently: {v}"
        );
    }
}

#[test]
fn pillow_reads_our_rgba8_dds() {
    if !common::pillow() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for format in [GpuFormat::Rgba8Srgb, GpuFormat::Rgba8] {
        let cube = test_cube(format);
        let path = dir.path().join("cube.dds");
        std::fs::write(&path, dds::encode(&cube, format).unwrap()).unwrap();
        // Pillow reads the first surface: face +X, level 0.
        let script = "import sys, json\nfrom PIL import Image\nim = Image.open(sys.argv[1])\n\
                      im.load()\nprint(json.dumps({'format': im.format, 'size': im.size, \
                      'mode': im.mode, 'pixels': list(im.tobytes())}))";
        let out = Command::new("python3")
            .args(["-c", script])
            .arg(&path)
            .output()
            .expect("run python3");
        assert!(
            out.status.success(),
            "Pillow failed on {}: {}",
            format.name(),
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(v["format"], "DDS", "{v}");
        assert_eq!(v["size"], serde_json::json!([8, 8]), "{v}");
        assert_eq!(v["mode"], "RGBA", "{v}");
        let expected = format.encode_image(&cube.levels[0][0]).unwrap();
        let got: Vec<u8> = v["pixels"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap() as u8)
            .collect();
        assert_eq!(got, expected, "{}: Pillow sees other texels", format.name());
    }
}

/// NVIDIA's DDS parser (nvddsinfo, from NVIDIA Texture Tools) reads our headers, float formats
/// included. It prints the header only: the texels are checked by the Pillow test above.
#[test]
fn nvddsinfo_reads_our_dds_headers() {
    if !common::nvddsinfo() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for format in FORMATS {
        let path = dir.path().join("cube.dds");
        std::fs::write(&path, dds::encode(&test_cube(format), format).unwrap()).unwrap();
        let out = Command::new("nvddsinfo").arg(&path).output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "nvddsinfo rejected {}: {text}",
            format.name()
        );
        let dxgi = match format {
            GpuFormat::Rgba16f => "10 (R16G16B16A16_FLOAT)",
            GpuFormat::Rgba32f => "2 (R32G32B32A32_FLOAT)",
            GpuFormat::Rgba8Srgb => "29 (R8G8B8A8_UNORM_SRGB)",
            GpuFormat::Rgba8 => "28 (R8G8B8A8_UNORM)",
            _ => unreachable!("the plain formats"),
        };
        for expected in [
            "Width: 8",
            "Height: 8",
            "Mipmap count: 4",
            "DDSCAPS2_CUBEMAP_ALL_FACES",
            "DDSD_MIPMAPCOUNT",
            &format!("DXGI Format: {dxgi}"),
            "Resource dimension: 3 (TEXTURE2D)",
            "Misc flag: 4",
            "Array size: 1",
        ] {
            assert!(
                text.contains(expected),
                "{}: nvddsinfo does not say {expected:?}:\n{text}",
                format.name()
            );
        }
    }
}
