#include "scenes/texture.h"

#include <cstdio>  // before jpeglib.h, which uses FILE and size_t

#include <jpeglib.h>
#include <png.h>

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <cstring>

namespace raybundle::scenes {

namespace {

// sRGB's 8-bit values, decoded to linear.
struct SrgbTable {
    double linear[256];
    SrgbTable() {
        for (int v = 0; v < 256; ++v) {
            const double c = v / 255.0;
            linear[v] = c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
        }
    }
};
const SrgbTable kSrgb;

constexpr int kMaxTexels = 8192;  // on either side (8k x 8k: 192 MB as 3 bytes a texel)

// libjpeg's errors end its calls by longjmp (a C library: no exception may cross it).
struct JpegErrors {
    jpeg_error_mgr manager;
    std::jmp_buf jump;
    char message[JMSG_LENGTH_MAX];
};

// Why a JPEG's header is refused, or "" (its size, as a PNG's).
std::string jpeg_size_refused(const jpeg_decompress_struct& jpeg) {
    if (jpeg.image_width > 0 && jpeg.image_height > 0 && jpeg.image_width <= kMaxTexels &&
        jpeg.image_height <= kMaxTexels)
        return "";
    return "a JPEG of " + std::to_string(jpeg.image_width) + " x " + std::to_string(jpeg.image_height) +
           " texels, more than 8192 on a side";
}

// Decodes a JPEG's texels into `image`, or says why not in `why`. The setjmp of
// libjpeg's errors is here, with locals of trivial types only (as libjpeg's own
// example): what outlives a longjmp is the caller's.
bool decode_jpeg(std::string_view bytes, TexelImage& image, std::string& why) {
    jpeg_decompress_struct jpeg{};
    JpegErrors errors{};
    jpeg.err = jpeg_std_error(&errors.manager);
    errors.manager.error_exit = [](j_common_ptr common) {
        auto* e = reinterpret_cast<JpegErrors*>(common->err);
        (*common->err->format_message)(common, e->message);
        std::longjmp(e->jump, 1);
    };
    errors.manager.output_message = [](j_common_ptr) {};  // its warnings: counted below
    if (setjmp(errors.jump)) {
        jpeg_destroy_decompress(&jpeg);
        why = std::string("a JPEG libjpeg cannot read: ") + errors.message;
        return false;
    }
    jpeg_create_decompress(&jpeg);
    jpeg_mem_src(&jpeg, reinterpret_cast<const unsigned char*>(bytes.data()), static_cast<unsigned long>(bytes.size()));
    jpeg_read_header(&jpeg, TRUE);
    why = jpeg_size_refused(jpeg);
    if (!why.empty()) {
        jpeg_destroy_decompress(&jpeg);
        return false;
    }
    jpeg.out_color_space = JCS_RGB;  // grey and YCbCr alike (CMYK is refused: its message)
    jpeg_start_decompress(&jpeg);
    image.width = static_cast<int>(jpeg.output_width);
    image.height = static_cast<int>(jpeg.output_height);
    image.srgb.resize(static_cast<std::size_t>(image.width) * image.height * 3);
    while (jpeg.output_scanline < jpeg.output_height) {
        JSAMPROW rows[1] = {image.srgb.data() + static_cast<std::size_t>(jpeg.output_scanline) * image.width * 3};
        jpeg_read_scanlines(&jpeg, rows, 1);
    }
    jpeg_finish_decompress(&jpeg);
    // A warning (a file cut short: libjpeg fills the rest with grey) leaves no image of
    // the texture's own colours.
    const long warnings = jpeg.err->num_warnings;
    jpeg_destroy_decompress(&jpeg);
    if (warnings > 0) why = "a JPEG libjpeg reads only in part (cut short?)";
    return warnings == 0;
}

// libpng's errors end its calls by longjmp, as libjpeg's.
struct PngErrors {
    char message[256];
};

// Decodes a PNG's texels as stored into `image` (`rows`: the caller's, so that nothing
// of this frame needs destroying after a longjmp), or says why not in `why`. Through
// libpng's own reader, not its simplified one: that one reads a 16-bit file without a
// colour chunk as linear and converts a gAMA chunk's gamma, and glTF (as Blender) reads
// every texture's values as sRGB whatever the file says. 16-bit samples are rounded to
// 8 bits, grey and palettes expanded to RGB, alpha left out.
bool decode_png(std::string_view bytes, TexelImage& image, std::vector<unsigned char*>& rows, std::string& why) {
    struct Source {
        const unsigned char* at;
        std::size_t left;
    } source{reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size()};
    PngErrors errors{};
    png_structp png = png_create_read_struct(
        PNG_LIBPNG_VER_STRING, &errors,
        [](png_structp p, png_const_charp message) {
            auto* e = static_cast<PngErrors*>(png_get_error_ptr(p));
            std::snprintf(e->message, sizeof e->message, "%s", message);
            png_longjmp(p, 1);
        },
        [](png_structp, png_const_charp) {});
    if (!png) {
        why = "a PNG libpng cannot read: out of memory";
        return false;
    }
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        why = std::string("a PNG libpng cannot read: ") + errors.message;
        return false;
    }
    if (!info) png_error(png, "out of memory");
    png_set_read_fn(png, &source, [](png_structp p, png_bytep out, png_size_t n) {
        auto* from = static_cast<Source*>(png_get_io_ptr(p));
        if (n > from->left) png_error(p, "the file ends inside its data (cut short?)");
        std::memcpy(out, from->at, n);
        from->at += n, from->left -= n;
    });
    png_read_info(png, info);
    const png_uint_32 width = png_get_image_width(png, info), height = png_get_image_height(png, info);
    if (width == 0 || height == 0 || width > kMaxTexels || height > kMaxTexels) {
        why = "a PNG of " + std::to_string(width) + " x " + std::to_string(height) + " texels, more than 8192 on a side";
        png_destroy_read_struct(&png, &info, nullptr);
        return false;
    }
    png_set_scale_16(png);
    png_set_expand(png);  // palettes, grey below 8 bits, tRNS
    png_set_gray_to_rgb(png);
    png_set_strip_alpha(png);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    if (png_get_rowbytes(png, info) != static_cast<png_size_t>(width) * 3) png_error(png, "an unexpected row layout");
    image.width = static_cast<int>(width);
    image.height = static_cast<int>(height);
    image.srgb.resize(static_cast<std::size_t>(width) * height * 3);
    rows.resize(height);
    for (png_uint_32 y = 0; y < height; ++y) rows[y] = image.srgb.data() + static_cast<std::size_t>(y) * width * 3;
    png_read_image(png, rows.data());
    png_read_end(png, nullptr);
    png_destroy_read_struct(&png, &info, nullptr);
    return true;
}

// A texel index along one side of `n` texels, wrapped.
int wrapped(long long i, int n, Texture::Wrap wrap) {
    switch (wrap) {
        case Texture::Wrap::clamp: return static_cast<int>(std::clamp<long long>(i, 0, n - 1));
        case Texture::Wrap::mirror: {
            long long k = i % (2LL * n);
            if (k < 0) k += 2LL * n;
            return static_cast<int>(k < n ? k : 2LL * n - 1 - k);
        }
        case Texture::Wrap::repeat:
        default: {
            long long k = i % n;
            return static_cast<int>(k < 0 ? k + n : k);
        }
    }
}

}  // namespace

double srgb_to_linear(std::uint8_t v) { return kSrgb.linear[v]; }

std::optional<TexelImage> decode_image(std::string_view bytes, std::string* why) {
    auto fail = [why](std::string reason) {
        if (why) *why = std::move(reason);
        return std::nullopt;
    };
    auto starts = [bytes](std::string_view magic) { return bytes.substr(0, magic.size()) == magic; };
    TexelImage image;
    if (starts("\xFF\xD8\xFF")) {
        std::string reason;
        if (!decode_jpeg(bytes, image, reason)) return fail(reason);
    } else {
        if (!starts("\x89PNG\r\n\x1A\n")) return fail("not a PNG or JPEG");
        std::vector<unsigned char*> rows;
        std::string reason;
        if (!decode_png(bytes, image, rows, reason)) return fail(reason);
    }
    // The mean, row by row (each row's sum exact enough in double, added in order).
    std::uint8_t top[3] = {0, 0, 0};
    for (std::size_t i = 0; i < image.srgb.size(); ++i) top[i % 3] = std::max(top[i % 3], image.srgb[i]);
    image.brightest = Rgb(kSrgb.linear[top[0]], kSrgb.linear[top[1]], kSrgb.linear[top[2]]);
    Rgb sum = Rgb::Zero();
    const std::size_t row = static_cast<std::size_t>(image.width) * 3;
    for (std::size_t y = 0; y < static_cast<std::size_t>(image.height); ++y) {
        Rgb line = Rgb::Zero();
        for (std::size_t i = y * row; i < (y + 1) * row; i += 3)
            line += Rgb(kSrgb.linear[image.srgb[i]], kSrgb.linear[image.srgb[i + 1]], kSrgb.linear[image.srgb[i + 2]]);
        sum += line;
    }
    image.mean = sum / (static_cast<double>(image.width) * image.height);
    return image;
}

Rgb Texture::at(double s, double t) const {
    const TexelImage& im = *image;
    // Texel centres at (i + 1/2) / width: the four around the point, weighted bilinearly.
    const double x = s * im.width - 0.5, y = t * im.height - 0.5;
    if (!std::isfinite(x) || !std::isfinite(y)) return im.mean;
    const double fx = std::floor(x), fy = std::floor(y);
    const double ax = x - fx, ay = y - fy;
    // Coordinates past 2^40 texels have no position within a texel left: the mean.
    if (std::abs(fx) > 1e12 || std::abs(fy) > 1e12) return im.mean;
    const auto x0 = static_cast<long long>(fx), y0 = static_cast<long long>(fy);
    const int xs[2] = {wrapped(x0, im.width, wrap_s), wrapped(x0 + 1, im.width, wrap_s)};
    const int ys[2] = {wrapped(y0, im.height, wrap_t), wrapped(y0 + 1, im.height, wrap_t)};
    auto texel = [&im](int tx, int ty) {
        const std::size_t i = (static_cast<std::size_t>(ty) * im.width + tx) * 3;
        return Rgb(kSrgb.linear[im.srgb[i]], kSrgb.linear[im.srgb[i + 1]], kSrgb.linear[im.srgb[i + 2]]);
    };
    return (1.0 - ay) * ((1.0 - ax) * texel(xs[0], ys[0]) + ax * texel(xs[1], ys[0])) +
           ay * ((1.0 - ax) * texel(xs[0], ys[1]) + ax * texel(xs[1], ys[1]));
}

}  // namespace raybundle::scenes
