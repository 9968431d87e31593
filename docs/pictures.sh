#!/usr/bin/env bash
# Regenerates every documentation picture (docs/*.png) with a cubeforge binary.
#
#   bash docs/pictures.sh target/release/cubeforge          # over the tracked docs/*.png
#   bash docs/pictures.sh target/release/cubeforge /tmp/p   # into another folder
#
# Pictures of the real photographs need ../shared/fixtures/real beside the repository (Poly
# Haven panoramas, CC0; not in a clone): without it they are skipped with a line saying so.
# `cargo test --release --test it doc_pictures` renders them all into a temporary folder and
# checks that the tracked ones are current.
set -euo pipefail

if [ $# -lt 1 ] || [ $# -gt 2 ]; then
    echo "usage: bash docs/pictures.sh CUBEFORGE [OUTDIR]" >&2
    exit 2
fi
bin="$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"
repo="$(cd "$(dirname "$0")/.." && pwd)"
out="${2:-$repo/docs}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
cd "$repo"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

cf() { "$bin" --quiet "$@"; }

# The demo sky (fixtures/sky.exr): +Z carries a chiral "L", -Z a yellow dot, +Y is green.
cf preview fixtures/sky.exr -o "$out/preview_chrome.png" --material chrome --size 384
cf preview fixtures/sky.exr -o "$out/preview_materials.png" --yaw 180 --size 256 \
    --grid chrome,mirror-decal,glass,water,diamond,plastic,crystal
cf prefilter fixtures/sky.exr -o "$work/sky_gaussian.ktx2" --filter gaussian --size 128 --min-size 16
cf preview "$work/sky_gaussian.ktx2" -o "$out/preview_bias.png" --yaw 180 --size 256 \
    --grid-bias 0,1,2,3
cf preview fixtures/sky.exr -o "$out/preview_per_vertex.png" --yaw 180 --size 384 \
    --shading per-vertex --tessellation 8
# Glass as the texts refract it (once, at the front) and exactly (the solid sphere: a lens).
cf preview fixtures/sky.exr -o "$out/preview_glass_texts.png" --yaw 180 --size 192 \
    --grid glass,diamond,crystal
cf preview fixtures/sky.exr -o "$out/preview_glass_exact.png" --yaw 180 --size 192 \
    --grid glass,diamond,crystal --refraction exact

# The viewer (cubeforge view) in headless Chromium: the page with its panel. Needs node,
# chromium and puppeteer-core (target/tools, as .ci/run installs them).
shot=tests/tools/view_shot.cjs
if command -v node >/dev/null 2>&1 && command -v chromium >/dev/null 2>&1 \
    && [ -d target/tools/node_modules/puppeteer-core ]; then
    cf view fixtures/sky.exr -o "$work/view"
    mkdir -p "$work/shots"
    SHOT_PAGE=1 node "$shot" "$work/view/index.html" "$work/shots" \
        "material=crystal&size=480&yaw=150&pitch=12" >/dev/null
    cp "$work/shots/0.png" "$out/view_page.png"
else
    echo "skipped: view_page.png needs node, chromium and target/tools' puppeteer-core" >&2
fi

# A real photograph: Poly Haven's studio, as ../shared/fixtures/real/SOURCES.md describes.
real=../shared/fixtures/real
if [ -d "$real" ]; then
    cf preview "$real/hdr/studio.hdr" -o "$out/preview_pbr_roughness.png" \
        --material pbr --size 192 --grid-roughness 0,0.25,0.5,0.75,1 --grid-metallic 0,1 \
        --tonemap aces --exposure -2 --yaw 40 --pitch 10
    # Esplanade's sun taken out and shone as a light (docs/engines.md, the sun as a light): the
    # grey ball on a grey floor and the sun's shadow, the sun nearly overhead.
    cf preview "$real/hdr/esplanade.hdr" -o "$out/preview_sun.png" --material pbr --sun --ground \
        --size 256 --pitch 25 --distance 6 --tonemap aces
else
    echo "skipped: preview_pbr_roughness.png and preview_sun.png need $real (not in a clone)" >&2
fi
