// EXR reading: what write_exr writes comes back bit for bit, the right way up; a file
// that cannot be read is named in the error. PNG: the tone map of every pixel, the same
// file for any thread count.
#include "render/image_io.h"

#include <catch2/catch.hpp>
#include <png.h>

#include <array>
#include <limits>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <vector>
#include <filesystem>
#include <string>

#include <unistd.h>

using namespace raybundle;

TEST_CASE("EXR: write then read gives the same image", "[render][image_io]") {
    render::Image image(5, 3);  // not square: width and height must not swap
    for (std::size_t k = 0; k < image.rgb.size(); ++k) image.rgb[k] = 0.1f * static_cast<float>(k) - 1.0f / 3.0f;
    image.at(4, 2)[1] = 1e6f;  // the last row's last pixel: rows are not flipped
    const std::string path =
        (std::filesystem::temp_directory_path() / ("raybundle-test-" + std::to_string(::getpid()) + ".exr")).string();
    render::write_exr(path, image);
    const render::Image back = render::read_exr(path);
    std::remove(path.c_str());
    REQUIRE(back.width == 5);
    REQUIRE(back.height == 3);
    REQUIRE(back.rgb == image.rgb);
}

TEST_CASE("EXR: a missing or malformed file throws, naming it", "[render][image_io]") {
    const std::string dir = std::filesystem::temp_directory_path().string();
    const std::string missing = dir + "/raybundle-no-such-file-" + std::to_string(::getpid()) + ".exr";
    REQUIRE_THROWS_WITH(render::read_exr(missing), Catch::Contains(missing));
    const std::string text = dir + "/raybundle-not-an-exr-" + std::to_string(::getpid()) + ".exr";
    {
        std::FILE* f = std::fopen(text.c_str(), "w");
        REQUIRE(f != nullptr);
        std::fputs("not an image\n", f);
        std::fclose(f);
    }
    REQUIRE_THROWS_WITH(render::read_exr(text), Catch::Contains(text) && Catch::Contains("cannot read EXR"));
    std::remove(text.c_str());
}

namespace {

// `image` written as a PNG on 1 and on `threads` threads: the two files' bytes equal,
// read back by libpng (which checks the chunks' CRCs and zlib's Adler-32) at the
// image's size; its RGB bytes.
std::vector<unsigned char> png_written(const render::Image& image, double exposure, int threads) {
    const auto tmp = std::filesystem::temp_directory_path();
    std::vector<std::string> bytes;
    for (const int t : {1, threads}) {
        const std::string path =
            (tmp / ("raybundle-test-" + std::to_string(::getpid()) + "-" + std::to_string(t) + ".png")).string();
        render::write_png(path, image, exposure, t);
        std::ifstream in(path, std::ios::binary);
        bytes.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
        std::remove(path.c_str());
    }
    REQUIRE(bytes[0] == bytes[1]);
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    REQUIRE(png_image_begin_read_from_memory(&png, bytes[0].data(), bytes[0].size()));
    png.format = PNG_FORMAT_RGB;
    REQUIRE(static_cast<int>(png.width) == image.width);
    REQUIRE(static_cast<int>(png.height) == image.height);
    std::vector<unsigned char> pixels(PNG_IMAGE_SIZE(png));
    REQUIRE(png_image_finish_read(&png, nullptr, pixels.data(), 0, nullptr));
    return pixels;
}

}  // namespace

TEST_CASE("PNG: every pixel tone-mapped, rows in order, the same file for any thread count", "[render][image_io]") {
    render::Image image(7, 37);  // more rows than threads, not a multiple of them
    for (std::size_t k = 0; k < image.rgb.size(); ++k) image.rgb[k] = 0.013f * static_cast<float>(k % 97) - 0.1f;
    const double exposure = 0.5;
    const std::vector<unsigned char> pixels = png_written(image, exposure, 3);
    for (std::size_t k = 0; k < image.rgb.size(); ++k) {
        INFO("channel value " << k);
        REQUIRE(pixels[k] == render::tone_map(image.rgb[k], exposure));
    }
}

TEST_CASE("PNG: rows in several compressed segments, and every byte value to_srgb8's", "[render][image_io]") {
    // 700 x 100 pixels (four segments of 32 rows joined into one zlib stream), the
    // channels sweeping 0 .. 1.07 in steps of 2^-16 (every byte value and every
    // boundary between two, up to a step) with negatives, infinities and NaN among them:
    // read back by libpng (which checks the chunks' CRCs and zlib's Adler-32), every
    // byte is to_srgb8's, and 1 and 4 threads write the same file.
    render::Image image(700, 100);
    for (std::size_t k = 0; k < image.rgb.size(); ++k) image.rgb[k] = static_cast<float>(k % 70001) / 65536.0f;
    image.rgb[5] = -0.5f;
    image.rgb[6] = std::numeric_limits<float>::infinity();
    image.rgb[7] = -std::numeric_limits<float>::infinity();
    image.rgb[8] = std::numeric_limits<float>::quiet_NaN();
    const std::vector<unsigned char> pixels = png_written(image, 0.0, 4);
    std::size_t differ = 0;
    std::array<bool, 256> seen{};
    for (std::size_t k = 0; k < image.rgb.size(); ++k) {
        differ += pixels[k] != render::to_srgb8(image.rgb[k]) ? 1 : 0;
        seen[pixels[k]] = true;
    }
    CHECK(differ == 0);
    CHECK(std::count(seen.begin(), seen.end(), true) == 256);
}
