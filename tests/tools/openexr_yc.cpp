// OpenEXR's own luminance/chroma writer and reader, for tests/it/exr_openexr.rs: writes a
// smooth 64x32 RGB image through RgbaOutputFile as WRITE_YC (Y, and RY BY subsampled 2x2) or
// WRITE_Y (luminance only), then reads it back through RgbaInputFile, whose reconstruction
// (chroma filters, YCA to RGB) is the reference, and dumps that RGB as raw 32-bit floats.
// Usage: openexr_yc OUT.exr OUT.raw yc|y
#include <ImfArray.h>
#include <ImfRgbaFile.h>
#include <cstdio>
#include <cstring>

int main(int argc, char** argv) {
    if (argc != 4) return 2;
    const bool luminance_only = !std::strcmp(argv[3], "y");
    const int w = 64, h = 32;
    Imf::Array2D<Imf::Rgba> px(h, w);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float u = (x + 0.5f) / w, v = (y + 0.5f) / h;
            px[y][x] = Imf::Rgba(0.2f + 2.0f * u, 0.1f + v, 0.3f + 0.5f * u * v, 1.0f);
        }
    {
        Imf::RgbaOutputFile out(argv[1], w, h, luminance_only ? Imf::WRITE_Y : Imf::WRITE_YC,
                                1, Imath::V2f(0, 0), 1, Imf::INCREASING_Y,
                                Imf::ZIP_COMPRESSION);
        out.setFrameBuffer(&px[0][0], 1, w);
        out.writePixels(h);
    }
    Imf::RgbaInputFile in(argv[1]);
    Imf::Array2D<Imf::Rgba> back(h, w);
    in.setFrameBuffer(&back[0][0], 1, w);
    in.readPixels(0, h - 1);
    FILE* raw = std::fopen(argv[2], "wb");
    if (!raw) return 1;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float v[3] = {back[y][x].r, back[y][x].g, back[y][x].b};
            std::fwrite(v, sizeof(float), 3, raw);
        }
    return std::fclose(raw) == 0 ? 0 : 1;
}
