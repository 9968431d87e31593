//! The snippets `ibl --target filament` prints run: the C++ compiles against declarations of
//! the Filament calls it makes (no undeclared name), and the JavaScript runs in Filament's own
//! web build, handing `irradianceSh` the 27 coefficients of the file's `sh` key. Babylon's
//! JavaScript parses.

use crate::common::{self, run, stderr};
use std::path::Path;
use std::process::Command;

const SKY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");

/// The Filament declarations the C++ snippet uses, with Filament's signatures
/// (filament/IndirectLight.h, Skybox.h, Scene.h, image/Ktx1Bundle.h, ktxreader/Ktx1Reader.h).
const FILAMENT_DECLS: &str = r#"
#include <cstddef>
#include <cstdint>
namespace filament {
namespace math { struct float3 { float x, y, z; }; }
class Engine; class Texture;
class IndirectLight { public: class Builder { public:
    Builder& reflections(Texture const*) noexcept;
    Builder& irradiance(uint8_t bands, math::float3 const* sh) noexcept;
    Builder& intensity(float) noexcept;
    IndirectLight* build(Engine&); }; };
class Skybox { public: class Builder { public:
    Builder& environment(Texture*) noexcept;
    Skybox* build(Engine&); }; };
class Scene { public: void setIndirectLight(IndirectLight*) noexcept; void setSkybox(Skybox*) noexcept; };
}
namespace image { class Ktx1Bundle { public:
    Ktx1Bundle(uint8_t const* bytes, uint32_t nbytes);
    bool getSphericalHarmonics(filament::math::float3* result); }; }
namespace ktxreader { namespace Ktx1Reader {
    filament::Texture* createTexture(filament::Engine*, image::Ktx1Bundle*, bool srgb); } }
"#;

/// The printed lines from `// C++` (or `// JavaScript`) to the next blank line.
fn part(out: &str, heading: &str) -> String {
    let mut lines = out.lines().skip_while(|l| !l.starts_with(heading));
    lines
        .by_ref()
        .take_while(|l| !l.trim().is_empty())
        .collect::<Vec<_>>()
        .join("\n")
}

/// What `ibl --target TARGET` prints, its files written to `dir/TARGET`.
fn printed(dir: &Path, target: &str) -> String {
    let out = dir.join(target);
    let o = run([
        "ibl",
        SKY,
        "-o",
        out.to_str().unwrap(),
        "--target",
        target,
        "--size",
        "32",
        "--samples",
        "4",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    String::from_utf8(o.stdout).unwrap()
}

#[test]
fn filament_cpp_snippet_compiles() {
    if !common::cxx() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let cpp = part(&printed(dir.path(), "filament"), "// C++");
    assert!(cpp.contains("getSphericalHarmonics"), "{cpp}");
    let source = format!(
        "{FILAMENT_DECLS}\nvoid load(filament::Engine* engine, filament::Scene* scene, \
         const uint8_t* iblData, uint32_t iblSize, const uint8_t* skyData, uint32_t skySize) {{\n\
         {cpp}\n}}\n"
    );
    let file = dir.path().join("snippet.cpp");
    std::fs::write(&file, source).unwrap();
    let o = Command::new("c++")
        .args(["-std=c++17", "-fsyntax-only", "-Werror"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{cpp}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn filament_javascript_snippet_passes_the_sh_key() {
    let Some(tools) = common::filament_js() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let js = part(&printed(dir.path(), "filament"), "// JavaScript");
    let file = dir.path().join("snippet.js");
    std::fs::write(&file, &js).unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/tools/filament_snippet.cjs");
    let o = Command::new("node")
        .arg(&script)
        .arg(&tools)
        .arg(&file)
        .arg(dir.path().join("filament"))
        .output()
        .expect("node runs");
    assert!(
        o.status.success(),
        "{js}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let seen: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(seen["reflections"], "env_ibl.ktx", "{seen}");
    assert_eq!(seen["sky"], "env_skybox.ktx", "{seen}");
    let light = &seen["light"];
    assert_eq!(light["reflections"], "env_ibl.ktx", "{seen}");
    assert_eq!(light["bands"], 3, "{seen}");
    assert_eq!(light["engine"], true, "{seen}");
    // The 27 numbers of sh.txt, in order.
    let text = std::fs::read_to_string(dir.path().join("filament/sh.txt")).unwrap();
    let want: Vec<f64> = text
        .lines()
        .flat_map(|l| {
            l.split(['(', ')', ',', ';'])
                .filter_map(|t| t.trim().parse::<f64>().ok())
                .collect::<Vec<_>>()
        })
        .collect();
    let got: Vec<f64> = light["sh"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(got.len(), 27, "{seen}");
    assert_eq!(want.len(), 27, "{text}");
    for (g, w) in got.iter().zip(&want) {
        assert!(
            (g - w).abs() <= 1e-6 * w.abs().max(1e-3),
            "{got:?} vs {want:?}"
        );
    }
    assert!(got[0] > 0.0);
}

#[test]
fn babylon_snippet_is_javascript() {
    if common::filament_js().is_none() {
        return; // node is the checker, installed with the npm readers
    }
    let dir = tempfile::tempdir().unwrap();
    let text = printed(dir.path(), "babylon");
    let js = part(&text, "// Babylon.js");
    assert!(
        js.contains("CreateFromPrefilteredData(\"env.env\""),
        "{text}"
    );
    let file = dir.path().join("snippet.js");
    std::fs::write(&file, &js).unwrap();
    let o = Command::new("node")
        .arg("--check")
        .arg(&file)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{js}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
}
