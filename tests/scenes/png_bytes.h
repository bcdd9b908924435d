#pragma once
// A small RGBA PNG in memory, for the texture tests (MTL map_Kd, glTF images).
#include <catch2/catch.hpp>
#include <png.h>

#include <string>

namespace raybundle::test {

// `rgba`: width x height texels, 8 bits a channel, rows top to bottom.
inline std::string png_bytes(int width, int height, const unsigned char* rgba) {
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    image.width = static_cast<png_uint_32>(width);
    image.height = static_cast<png_uint_32>(height);
    image.format = PNG_FORMAT_RGBA;
    png_alloc_size_t size = 0;
    REQUIRE(png_image_write_to_memory(&image, nullptr, &size, 0, rgba, 0, nullptr));
    std::string bytes(size, '\0');
    REQUIRE(png_image_write_to_memory(&image, bytes.data(), &size, 0, rgba, 0, nullptr));
    bytes.resize(size);
    return bytes;
}

}  // namespace raybundle::test
