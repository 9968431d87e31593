#!/usr/bin/env bash
# Digests of a few dozen commands' outputs, to show a restructuring changed no byte:
#   tests/tools/digests.sh OLD_BINARY > before.txt; tests/tools/digests.sh target/release/cubeforge > after.txt
#   diff before.txt after.txt
# Run from the repository root. Each line: sha256, then the output's path under the work folder.
# QUIET= KEEP_STDERR=1 compares the printed summaries and warnings too.
set -uo pipefail
bin=$(realpath "$1")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
o=$work
run() { "$bin" ${QUIET---quiet} "$@" >"$o/stdout.$n" 2>"$o/stderr.$n" || echo "exit $? : $*" >>"$o/failures"; n=$((n + 1)); }
n=0
s=fixtures/sky.exr
run convert $s -o $o/faces --to faces --size 32
run convert fixtures/sky.png -o $o/faces_png --to faces --size 32 --format png
run convert $s -o $o/hcross.exr --size 32
run convert $s -o $o/vcross.png --to vcross --size 32 --tonemap aces --exposure -1
run convert $s -o $o/hstrip.tga --to hstrip --size 16
run convert $s -o $o/equirect.hdr --to equirect --size 32 --yaw 30 --pitch 10
run convert $s -o $o/sphere.exr --to sphere --size 32
run convert $s -o $o/angular.exr --to angular --size 32 --interp bicubic
run convert $s -o $o/octa.exr --to octahedral --size 32 --mirror
run convert $o/sphere.exr --from sphere -o $o/from_sphere.exr --to equirect --size 16
run convert $o/octa.exr --from octahedral -o $o/from_octa.exr --to hcross --size 16
run convert $s -o $o/sky.ktx2 --size 32
run convert $s -o $o/sky_bc6h.ktx2 --size 32 --gpu-format bc6h --zstd
run convert $s -o $o/sky.dds --size 32 --gpu-format rgba8-srgb --levels 2
run convert $s -o $o/sky_bc7.dds --size 32 --gpu-format bc7-srgb
run convert $s -o $o/sky.ktx --size 32
run convert $s -o $o/sky.env --size 32
run convert $o/sky.ktx2 -o $o/back.png --to equirect
run convert $s -o $o/png16.png --size 16 --png16 --linear
run convert $s -o - --format ktx2 --size 16
run prefilter $s -o $o/ggx.ktx2 --filter ggx --size 32 --samples 8
run prefilter $s -o $o/gauss.dds --filter gaussian --size 32
run prefilter $s -o $o/chain --filter cosine --lighting phongbrdf --size 32
run prefilter $s -o $o/box.ktx2 --filter box --levels 4 --size 32
run prefilter $s -o $o/charlie.ktx2 --filter charlie --size 32 --min-size 8 --samples 4
run prefilter $s -o - --format ktx --filter ggx --size 16 --samples 4
run irradiance $s -o $o/irr --size 8 --sh $o/sh.json
run irradiance $s -o $o/irr.ktx2 --size 8
run irradiance $s -o $o/irr_png --format png --size 8 --tonemap reinhard
run ibl $s -o $o/ibl_bevy --target bevy --size 32 --samples 4
run ibl $s -o $o/ibl_gltf --target gltf --size 32 --samples 4 --sheen
run ibl $s -o $o/ibl_filament --target filament --size 32 --samples 4
run ibl $s -o $o/ibl_babylon --target babylon --size 32 --samples 4
run ibl $s -o $o/ibl_generic --target generic --size 32 --samples 4 --name sky
run lut -o $o/dfg.png --size 32
run lut -o $o/dfg_ms.exr --multiscatter --size 32
run lut -o $o/charlie.png --charlie --png16 --size 32
run lut -o $o/dfg.ktx2 --size 16
run control fixtures/control/chrome_and_paint.toml -o $o/chrome.png --size 64x32
run control fixtures/control/frosted_glass.toml -o $o/frosted.ktx2 --size 32x32
run control fixtures/control/wet_ground.json -o $o/wet.exr --size 64x32
run preview $s -o $o/chrome_prev.png --size 48
run preview $s -o $o/glass_prev.png --size 48 --material glass
run preview $o/ggx.ktx2 -o $o/pbr_prev.exr --size 48 --material pbr
run preview $s -o - --format png --size 32 --material crystal
# The output options (issue 46's Encoding): every texel format, sample type, 8-bit HDR encoding,
# edge fixup and face format, across the jobs that take them.
run convert $s -o $o/f32.exr --size 16 --exr-float f32
run convert $s -o $o/faces_f32 --to faces --size 16 --exr-float f32
run convert $s -o $o/faces_hdr --to faces --format hdr --size 16
run convert $s -o $o/faces_jpg --to faces --format jpg --size 16 --tonemap reinhard
run convert $s -o $o/equirect.png --to equirect --size 16 --tonemap aces --exposure -2
run convert $s -o $o/rgbm6.png --size 16 --hdr-encoding rgbm6
run convert $s -o $o/rgbd.png --to equirect --size 16 --hdr-encoding rgbd
run convert $s -o $o/rgbm8.ktx2 --size 16 --gpu-format rgba8 --hdr-encoding rgbm8
run convert $s -o $o/rgbd.dds --size 16 --gpu-format rgba8 --hdr-encoding rgbd
run convert $s -o $o/faces_rgbm --to faces --format png --size 16 --hdr-encoding rgbm6
run convert $s -o $o/uhdr.jpg --to equirect --size 16 --ultrahdr
run convert $s -o $o/uhdr_cross.jpg --size 16 --ultrahdr --tonemap reinhard
run convert $s -o $o/plain.jpg --size 16
run convert $s -o $o/warp.ktx2 --size 16 --edge-fixup warp
run convert $s -o $o/stretch.dds --size 16 --edge-fixup stretch
run convert $s -o $o/stretch_faces --to faces --size 16 --edge-fixup stretch
run convert $s -o $o/warp.png --size 16 --edge-fixup warp
run convert $s -o $o/warp_equirect.exr --to equirect --size 16 --edge-fixup warp
run convert $s -o $o/rgba32f.ktx2 --size 16 --gpu-format rgba32f --zstd=3
run convert $s -o $o/rgb9e5.ktx2 --size 16 --gpu-format rgb9e5
run convert $s -o $o/rg11b10.dds --size 16 --gpu-format rg11b10
run convert $s -o $o/bc7.ktx2 --size 16 --gpu-format bc7 --linear
run convert $s -o $o/rgba8.ktx2 --size 16 --gpu-format rgba8 --tonemap aces
run convert $s -o $o/rgba8_srgb.ktx --size 16 --gpu-format rgba8-srgb
run convert $s -o $o/bc6h.ktx --size 16 --gpu-format bc6h
run convert $s -o $o/levels.ktx --size 16 --levels 3
run convert $s -o $o/sky_f32.env --size 16 --zstd
run convert $s -o $o/ignored.exr --size 16 --gpu-format bc6h --zstd --hdr-encoding rgbm6
run convert $s -o - --format png --size 16 --hdr-encoding rgbd
run convert $s -o - --format dds --size 16 --gpu-format rgb9e5
run prefilter $s -o $o/pf_png --format png --filter ggx --size 16 --samples 4 --hdr-encoding rgbm6
run prefilter $s -o $o/pf_hdr --format hdr --filter gaussian --size 16
run prefilter $s -o $o/pf_f32 --exr-float f32 --filter gaussian --size 16
run prefilter $s -o $o/pf_warp.ktx2 --filter ggx --size 16 --samples 4 --edge-fixup warp --gpu-format bc6h --zstd
run prefilter $s -o $o/pf_stretch.dds --filter gaussian --size 16 --edge-fixup stretch --gpu-format rgba8 --hdr-encoding rgbd
run prefilter $s -o $o/pf.ktx --filter gaussian --size 16 --gpu-format rgb9e5
run prefilter $s -o $o/pf.env --filter ggx --size 16 --samples 4
run prefilter $s -o $o/pf_stretch_dir --filter gaussian --size 16 --edge-fixup stretch --exposure 1
run irradiance $s -o $o/irr_f32 --size 8 --exr-float f32 --edge-fixup warp
run irradiance $s -o $o/irr.dds --size 8 --gpu-format rgba8 --hdr-encoding rgbm8
run irradiance $s -o $o/irr_rgb9e5.ktx2 --size 8 --gpu-format rgb9e5 --zstd=5
run irradiance $s -o $o/irr.ktx --size 8
run irradiance $s -o $o/irr_cross.exr --to hcross --size 8
run irradiance $s -o $o/irr_equirect.png --to equirect --size 8 --tonemap aces --hdr-encoding rgbd
run irradiance $s -o $o/irr_jpg --format jpg --size 8
run ibl $s -o $o/ibl_bevy_bc6h --target bevy --size 32 --samples 4 --gpu-format bc6h --zstd
run ibl $s -o $o/ibl_three --target three --size 32 --samples 4
run ibl $s -o $o/ibl_gltf_f32 --target gltf --size 32 --samples 4 --exr-float f32 --exposure 1
run ibl $s -o $o/ibl_babylon_rgba --target babylon --size 32 --samples 4 --gpu-format rgba32f
run ibl $s -o $o/ibl_filament_zstd --target filament --size 32 --samples 4 --zstd
run control fixtures/control/chrome_and_paint.toml -o $o/chrome_bc7.ktx2 --size 32x32 --gpu-format bc7 --zstd --levels 2
run control fixtures/control/wet_ground.json -o $o/wet.dds --size 32x32 --gpu-format rgba8
run control fixtures/control/frosted_glass.toml -o $o/frosted16.png --size 32x32 --png16
run lut -o $o/dfg16.png --size 16 --png16
run lut -o $o/dfg.dds --size 16
run preview $s -o $o/prev.jpg --size 32
run preview $s -o $o/prev.hdr --size 32 --material pbr
run convert $s -o $o/warned.exr --size 16 --gpu-format bc6h --tonemap aces --zstd
run convert $s -o $o/warned_faces --to faces --size 16 --levels 3 --zstd=4
run prefilter $s -o $o/warned_dir --filter gaussian --size 16 --gpu-format bc7 --zstd
run irradiance $s -o $o/warned_irr.exr --to equirect --size 8 --gpu-format bc6h --edge-fixup warp
run ibl $s -o $o/warned_ibl --target gltf --size 32 --samples 4 --zstd --exr-float f32
run convert $s -o $o/bad_env.env --size 16 --edge-fixup warp
run convert $s -o $o/bad_rgbm.exr --size 16 --hdr-encoding rgbm6 --to equirect
run convert $s -o $o/bad_rgbm_bc6h.ktx2 --size 16 --hdr-encoding rgbm6 --gpu-format bc6h
run convert $s -o $o/bad_uhdr.png --size 16 --ultrahdr
run prefilter $s -o $o/bad_pf.ktx2 --size 16 --format png
run irradiance $s -o $o/bad_irr.ktx --size 8 --zstd
run ibl $s -o $o/bad_ibl --target bevy --size 32 --gpu-format rgba8
# Refusals: their messages (with KEEP_STDERR) and exit codes.
run convert $s -o $o/bad.dds --zstd --size 8
run convert $s -o $o/bad.png --size 0
run convert $s -o $o/bad_faces --to faces --format ktx2 --size 8
run convert $s -o $o/bad.exr --levels 0
run prefilter $s -o $o/bad_chain --format ktx2 --size 8
run prefilter $s -o $o/bad.ktx2 --size 8 --min-size 16
run irradiance $s -o - --format exr --sh $o/bad.json
run ibl $s -o - --target bevy
run lut -o $o/bad.jpg
run lut -o $o/bad.exr --png16
run control fixtures/control/chrome_and_paint.toml -o $o/bad.exr --levels 2
run preview $s -o $o/bad.ktx2
run preview $s -o $o/bad.png --grid-roughness 0.5
run preview $s -o $o/bad.png --size 64 --max-memory 1K
run convert $s -o $o/bad.ktx2 --size 4096 --max-memory 10M
# Inputs read back (issue 46, item 3: RGBM/RGBD, .env, edge fixup undone, UltraHDR moved out of io)
# and `info --json`, on the project's fixtures and, where present, the shared real ones.
run convert $o/rgbm6.png -o $o/rb_rgbm6.exr --to equirect --size 16
run convert $o/rgbd.dds --decode rgbd -o $o/rb_rgbd.exr --size 8
run convert $o/sky.env -o $o/rb_env.exr --to equirect --size 16
run convert $o/warp.ktx2 -o $o/rb_warp.exr --size 16
run convert $o/uhdr.jpg -o $o/rb_uhdr.exr --size 16
run convert fixtures/passes.exr --part dim -o $o/rb_part.exr --size 16
run convert $o/faces -o $o/rb_faces.ktx2 --size 16
run convert $o/chain --level 1 -o $o/rb_chain.exr --size 8
run ibl $o/ibl_babylon/*.env -o $o/rb_ibl_babylon --target gltf --size 16 --samples 4
for f in $o/sky.env $o/warp.ktx2 $o/rgbm6.png $o/uhdr.jpg $o/sky.ktx $o/sky.dds $o/ggx.ktx2 $o/chain $o/ibl_bevy fixtures/passes.exr; do
    run info --json "$f"; done
r=../shared/fixtures/real
if [ -d "$r" ]; then
    run convert $r/zip/park.exr -o $o/real_park.ktx2 --size 32
    run convert $r/dwab/sunset.exr -o $o/real_sunset.exr --to hcross --size 32
    run convert $r/hdr/venice.hdr -o $o/real_venice.png --to equirect --size 32
    run convert $r/png/city.png -o $o/real_city.dds --size 32 --gpu-format bc7-srgb
    run convert $r/ball/studio_mirrorball.exr --from sphere -o $o/real_ball.exr --size 32
    run convert $r/ball/park_angular.exr --from angular -o $o/real_ang.exr --size 32
    run convert $r/faces/city -o $o/real_faces.ktx2 --size 32
    run convert $r/ultrahdr/esplanade_iso.jpg -o $o/real_uhdr_iso.exr --size 32
    run convert $r/ultrahdr/esplanade_xmp.jpg -o $o/real_uhdr_xmp.exr --size 32
    run prefilter $r/zip/esplanade.exr -o $o/real_esp.ktx2 --filter ggx --size 32 --samples 8
    run irradiance $r/hdr/studio.hdr -o $o/real_irr.ktx2 --size 8 --sh $o/real_sh.json
    run ibl $r/zip/sky.exr -o $o/real_ibl_babylon --target babylon --size 32 --samples 4
    run ibl $r/dwab/park.exr -o $o/real_ibl_three --target three --size 32 --samples 4
    run ibl $r/zip/esplanade.exr -o $o/real_ibl_filament --target filament --size 32 --samples 4
    run info --json $r/ultrahdr/esplanade_iso.jpg
    run info --json $r/dwab/night.exr
    run info --json $r/ball/studio_mirrorball.exr
fi
cd "$o"
# UltraHDR JPEGs carry an ICC profile whose header holds the time it was made: zeroed here.
find . -name '*.jpg' -type f -exec perl -0777 -pi -e 's/(mntrRGB XYZ ).{12}/$1 . ("\0" x 12)/se' {} +
# Printed paths name the work folder, which differs between runs.
sed -i "s|$o|OUT|g" stdout.* stderr.*
if [ -n "${KEEP_STDERR:-}" ]; then
    find . -type f ! -name failures -print0 | sort -z | xargs -0 sha256sum
else
    find . -type f ! -name failures ! -name 'stderr.*' -print0 | sort -z | xargs -0 sha256sum
fi
[ -f failures ] && sed 's|'"$o"'|$o|g' failures
exit 0
