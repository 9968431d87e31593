//! Issue 48, item 3: every KTX2 cubeforge writes passes `ktx validate -e` (warnings as
//! errors): only the specification's keys, unless `--cubeforge-keys` asks for cubeforge's.
//! What the keys said is still said (a chain's levels beside it, the encoding and the fixup
//! in the command's report), and files with the keys, old or new, read as before.

use crate::common::ktx2_rule::{check_file, key_problem};
use crate::common::{run, stderr};
use cubeforge::internals::io::{self, Decoded};
use cubeforge::ReadOptions;
use std::path::Path;

const SKY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");

fn ok(args: &[&str]) -> String {
    let r = run(args);
    assert!(r.status.success(), "{args:?}: {}", stderr(&r));
    String::from_utf8_lossy(&r.stdout).into_owned()
}

fn keys(path: &Path) -> Vec<String> {
    io::ktx2::metadata(&std::fs::read(path).unwrap())
        .into_iter()
        .map(|(k, _)| k)
        .collect()
}

/// Every command and option that writes a KTX2, as it does by default: each file keeps the
/// rule (checked again here, beyond what `common::run` checks).
#[test]
fn every_ktx2_written_passes_the_validators_rule() {
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n).to_str().unwrap().to_owned();
    let commands: Vec<Vec<String>> = [
        "convert SKY -o sky.ktx2 --size 16",
        "convert SKY -o zstd.ktx2 --size 16 --zstd",
        "convert SKY -o bc6h.ktx2 --size 16 --gpu-format bc6h",
        "convert SKY -o rgbm.ktx2 --size 16 --gpu-format rgba8 --hdr-encoding rgbm7",
        "convert SKY -o warp.ktx2 --size 16 --edge-fixup warp",
        "irradiance SKY -o irr.ktx2 --size 8 --hdr-encoding rgbd --gpu-format rgba8 --edge-fixup stretch",
        "prefilter SKY -o ggx.ktx2 --filter ggx --size 16 --samples 4",
        "prefilter SKY -o box.ktx2 --filter box --size 16 --hdr-encoding rgbm16 --gpu-format rgba8",
        "ibl SKY -o bevy --target bevy --size 16 --samples 4",
        "ibl SKY -o gltf --target gltf --size 16 --samples 4 --sheen",
        "ibl SKY -o generic --target generic --size 16 --samples 4",
        "lut -o dfg.ktx2 --size 16",
        "control CONTROL -o frosted.ktx2 --size 16x16",
    ]
    .iter()
    .map(|c| {
        let mut words: Vec<String> = c
            .split(' ')
            .map(|w| match w {
                "SKY" => SKY.to_owned(),
                "CONTROL" => concat!(
                    env!("CARGO_MANIFEST_DIR"),
                    "/fixtures/control/frosted_glass.toml"
                )
                .to_owned(),
                w => w.to_owned(),
            })
            .collect();
        let i = words.iter().position(|w| w == "-o").unwrap();
        words[i + 1] = d(&words[i + 1]);
        words
    })
    .collect();
    let mut files = 0;
    for c in commands {
        let args: Vec<&str> = c.iter().map(String::as_str).collect();
        ok(&args);
        let i = c.iter().position(|w| w == "-o").unwrap();
        for f in crate::common::ktx2_rule::ktx2_files(Path::new(&c[i + 1])) {
            assert_eq!(keys(&f), ["KTXwriter"], "{}", f.display());
            check_file(&f, false);
            files += 1;
        }
    }
    assert!(files >= 15, "{files} KTX2 files checked");
    // A custom key is what the rule (and `ktx validate -e`) rejects.
    let with_key = std::fs::read(dir.path().join("sky.ktx2")).unwrap();
    assert!(key_problem(&with_key, false).is_none());
    let cube = match cubeforge::internals::convert::read(
        &dir.path().join("sky.ktx2"),
        &ReadOptions::default(),
    ) {
        Ok((Decoded::Cube(c), _)) => c,
        _ => panic!("a cube map"),
    };
    let tagged = io::ktx2::encode_with_metadata(
        &cube,
        io::GpuFormat::Rgba16f,
        &[(io::ktx2::LEVELS_KEY, b"{}")],
    );
    assert!(key_problem(&tagged, false).unwrap().contains("7010"));
    assert!(key_problem(&tagged, true).is_none());
}

/// What the keys said is said elsewhere: a chain's description beside it (read by `info`
/// and `preview`), the encoding and the fixup in the command's report; with
/// `--cubeforge-keys` the file holds them and reads back with no flag, as old files do.
#[test]
fn what_the_keys_said_is_still_said() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n);
    let s = |n: &str| p(n).to_str().unwrap().to_owned();
    // The chain: its description in NAME.ktx2.levels.json, which info and preview read.
    ok(&[
        "prefilter",
        SKY,
        "-o",
        s("ggx.ktx2").as_str(),
        "--filter",
        "ggx",
        "--size",
        "16",
        "--samples",
        "4",
    ]);
    assert!(p("ggx.ktx2.levels.json").is_file());
    let info = ok(&["info", s("ggx.ktx2").as_str(), "--json"]);
    let v: serde_json::Value = serde_json::from_str(&info).unwrap();
    assert_eq!(v["levels"]["filter"], "ggx", "{v}");
    let r = run([
        "preview",
        s("ggx.ktx2").as_str(),
        "-o",
        s("pbr.png").as_str(),
        "--material",
        "pbr",
        "--size",
        "16",
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    assert!(
        !stderr(&r).contains("does not say their roughness"),
        "{}",
        stderr(&r)
    );
    // With the keys: in the file, no sidecar, and info reads it the same.
    ok(&[
        "prefilter",
        SKY,
        "-o",
        s("keys.ktx2").as_str(),
        "--filter",
        "ggx",
        "--size",
        "16",
        "--samples",
        "4",
        "--cubeforge-keys",
    ]);
    assert!(!p("keys.ktx2.levels.json").exists());
    assert!(keys(&p("keys.ktx2")).contains(&io::ktx2::LEVELS_KEY.to_owned()));
    let v: serde_json::Value =
        serde_json::from_str(&ok(&["info", s("keys.ktx2").as_str(), "--json"])).unwrap();
    assert_eq!(v["levels"]["filter"], "ggx", "{v}");

    // RGBM in a KTX2: the report says how to read it back; --decode does.
    let said = ok(&[
        "convert",
        SKY,
        "-o",
        s("m.ktx2").as_str(),
        "--size",
        "16",
        "--gpu-format",
        "rgba8",
        "--hdr-encoding",
        "rgbm7",
    ]);
    assert!(said.contains("--decode rgbm7"), "{said}");
    assert!(said.contains("rgb * a * 7.0"), "{said}");
    let read = |path: &Path, decode: Option<io::HdrEncoding>| {
        let opts = ReadOptions {
            hdr_encoding: decode,
            ..ReadOptions::default()
        };
        match cubeforge::internals::convert::read(path, &opts) {
            Ok((Decoded::Cube(c), meta)) => (c, meta),
            _ => panic!("{} is not a cube map", path.display()),
        }
    };
    let (plain, _) = read(&p("m.ktx2"), None);
    let (decoded, meta) = read(&p("m.ktx2"), Some(io::HdrEncoding::Rgbm7));
    assert!(meta.hdr);
    let top = |c: &cubeforge::CubeMap| {
        c.levels[0]
            .iter()
            .flat_map(|f| f.pixels.iter())
            .map(|p| p.truncate().max_element())
            .fold(0.0f32, f32::max)
    };
    assert!(top(&plain) <= 1.0 && top(&decoded) > 1.0);
    // With the key the file names its encoding, as files written before did.
    ok(&[
        "convert",
        SKY,
        "-o",
        s("mk.ktx2").as_str(),
        "--size",
        "16",
        "--gpu-format",
        "rgba8",
        "--hdr-encoding",
        "rgbm7",
        "--cubeforge-keys",
    ]);
    let (named, _) = read(&p("mk.ktx2"), None);
    assert_eq!(named.levels[0][0].pixels, decoded.levels[0][0].pixels);

    // The edge fixup: said in the report; with the key, info names it.
    let said = ok(&[
        "convert",
        SKY,
        "-o",
        s("w.ktx2").as_str(),
        "--size",
        "16",
        "--edge-fixup",
        "warp",
    ]);
    assert!(said.contains("does not record its edge fixup"), "{said}");
    ok(&[
        "convert",
        SKY,
        "-o",
        s("wk.ktx2").as_str(),
        "--size",
        "16",
        "--edge-fixup",
        "warp",
        "--cubeforge-keys",
    ]);
    assert!(ok(&["info", s("wk.ktx2").as_str()]).contains("edge fixup warp"));
    assert!(!ok(&["info", s("w.ktx2").as_str()]).contains("edge fixup"));
    // The option where no KTX2 is written: ignored, with a warning.
    let r = run([
        "convert",
        SKY,
        "-o",
        s("x.exr").as_str(),
        "--size",
        "8",
        "--cubeforge-keys",
    ]);
    assert!(r.status.success());
    assert!(
        stderr(&r).contains("--cubeforge-keys applies to KTX2 outputs"),
        "{}",
        stderr(&r)
    );
}
