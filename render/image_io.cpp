#include "render/image_io.h"

#include "scenes/threads.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <zlib.h>

#include "scenes/errors.h"

#include <algorithm>
#include <array>
#include <filesystem>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstring>
#include <string>
#include <memory>
#include <stdexcept>
#include <vector>

#include <unistd.h>

namespace raybundle::render {

void write_atomically(const std::string& path, const std::function<void(const std::string& tmp)>& write) {
    const std::string tmp = path + ".partial-" + std::to_string(::getpid());
    try {
        write(tmp);
    } catch (...) {
        std::remove(tmp.c_str());
        throw;
    }
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
        const std::string why = std::strerror(errno);
        std::remove(tmp.c_str());
        throw std::runtime_error(path + ": cannot write (" + why + ")");
    }
}

void write_exr(const std::string& path, const Image& image) {
    write_atomically(path, [&](const std::string& tmp) {
        try {
            Imf::Header header(image.width, image.height);
            header.channels().insert("R", Imf::Channel(Imf::FLOAT));
            header.channels().insert("G", Imf::Channel(Imf::FLOAT));
            header.channels().insert("B", Imf::Channel(Imf::FLOAT));
            Imf::OutputFile file(tmp.c_str(), header);
            Imf::FrameBuffer fb;
            char* base = reinterpret_cast<char*>(const_cast<float*>(image.rgb.data()));
            const std::size_t xs = 3 * sizeof(float), ys = xs * image.width;
            fb.insert("R", Imf::Slice(Imf::FLOAT, base, xs, ys));
            fb.insert("G", Imf::Slice(Imf::FLOAT, base + sizeof(float), xs, ys));
            fb.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xs, ys));
            file.setFrameBuffer(fb);
            file.writePixels(image.height);
        } catch (const std::exception& e) {
            throw std::runtime_error(path + ": cannot write EXR (" + e.what() + ")");
        }
    });
}

Image read_exr(const std::string& path) {
    try {
        Imf::InputFile file(path.c_str());
        const Imf::Header& header = file.header();
        for (const char* name : {"R", "G", "B"})
            if (header.channels().findChannel(name) == nullptr)
                throw std::runtime_error(std::string("no channel ") + name);
        const Imath::Box2i dw = header.dataWindow();
        Image image(dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1);
        // Slice::Make addresses the data window's first pixel as pixel (min.x, min.y).
        const std::size_t xs = 3 * sizeof(float), ys = xs * image.width;
        float* base = image.rgb.data();
        Imf::FrameBuffer fb;
        fb.insert("R", Imf::Slice::Make(Imf::FLOAT, base, dw, xs, ys));
        fb.insert("G", Imf::Slice::Make(Imf::FLOAT, base + 1, dw, xs, ys));
        fb.insert("B", Imf::Slice::Make(Imf::FLOAT, base + 2, dw, xs, ys));
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        return image;
    } catch (const std::exception& e) {
        throw std::runtime_error(path + ": cannot read EXR (" + e.what() + ")");
    }
}

unsigned char tone_map(double linear, double exposure) { return to_srgb8(linear * std::exp2(exposure)); }

unsigned char to_srgb8(double scaled) {
    double v = std::clamp(scaled, 0.0, 1.0);
    v = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
    return static_cast<unsigned char>(std::lround(v * 255.0));
}

namespace {

// to_srgb8 without a pow per value: the least double at which each byte value begins
// (found once by bisection over the doubles' order, so that the byte is to_srgb8's to
// the bit), and per 1/4096 of 0..1 the byte where that bin begins; a value's byte is
// its bin's, raised past the beginnings at or below it (at most one or two).
class Srgb8 {
public:
    Srgb8() {
        for (int k = 1; k < 256; ++k) {
            double lo = 0.0, hi = 1.0;  // to_srgb8(lo) < k <= to_srgb8(hi)
            while (std::nextafter(lo, 1.0) < hi) {
                const double mid = 0.5 * (lo + hi);
                (to_srgb8(mid) >= k ? hi : lo) = mid;
            }
            starts_[static_cast<std::size_t>(k - 1)] = hi;
        }
        for (std::size_t i = 0; i < kBins; ++i) bin_[i] = to_srgb8(static_cast<double>(i) / kBins);
    }
    unsigned char operator()(double v) const {
        if (!(v > 0.0)) return std::isnan(v) ? to_srgb8(v) : 0;
        if (v >= 1.0) return 255;
        unsigned b = bin_[std::min(kBins - 1, static_cast<std::size_t>(v * kBins))];
        while (b < 255 && v >= starts_[b]) ++b;
        return static_cast<unsigned char>(b);
    }

private:
    static constexpr std::size_t kBins = 4096;
    std::array<double, 255> starts_{};  // [k - 1]: where byte k begins
    std::array<unsigned char, kBins> bin_{};
};

}  // namespace

namespace {

// PNG's filters (ISO 15948 section 9): 0 none, 1 sub, 2 up, 3 average, 4 Paeth; `left`
// is the byte distance to the pixel before (3 for 8-bit RGB).
unsigned char paeth(int a, int b, int c) {
    const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
    return static_cast<unsigned char>(pa <= pb && pa <= pc ? a : pb <= pc ? b : c);
}

void filter_row(int type, const unsigned char* row, const unsigned char* above, std::size_t size, std::size_t left,
                unsigned char* out) {
    for (std::size_t k = 0; k < size; ++k) {
        const int a = k >= left ? row[k - left] : 0, b = above ? above[k] : 0,
                  c = k >= left && above ? above[k - left] : 0;
        const int predicted = type == 1 ? a : type == 2 ? b : type == 3 ? (a + b) / 2 : type == 4 ? paeth(a, b, c) : 0;
        out[k] = static_cast<unsigned char>(row[k] - predicted);
    }
}

void put_u32(std::string& out, std::uint32_t v) {
    for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<char>(v >> shift & 0xff));
}

void put_chunk(std::string& out, const char* type, const std::string& data) {
    put_u32(out, static_cast<std::uint32_t>(data.size()));
    const std::size_t from = out.size();
    out.append(type, 4);
    out += data;
    put_u32(out, static_cast<std::uint32_t>(
                     crc32(0, reinterpret_cast<const Bytef*>(out.data() + from), static_cast<uInt>(out.size() - from))));
}

}  // namespace

void write_png(const std::string& path, const Image& image, double exposure, int threads) {
    // The pixels tone-mapped, each row filtered (the filter of least absolute sum, as
    // libpng chooses) and compressed at zlib's fastest level, all on the threads: an
    // image is written once and read by a viewer, and level 1 takes a sixth of the
    // default's time for files about a third larger. The rows are compressed in
    // segments of kSegmentRows, each its own deflate stream ending on a byte (a sync
    // flush), joined into one zlib stream whose Adler-32 combines theirs: the file is
    // the same for any number of threads.
    if (image.width <= 0 || image.height <= 0 || image.width > (1 << 24) || image.height > (1 << 24))
        throw std::runtime_error(path + ": cannot write PNG (" + std::to_string(image.width) + " x " +
                                 std::to_string(image.height) + " pixels; 1 to 16,777,216 a side)");
    constexpr int kSegmentRows = 32;
    const std::size_t row_size = static_cast<std::size_t>(3) * image.width, line = row_size + 1;
    const auto height = static_cast<std::size_t>(image.height);
    std::vector<unsigned char> bytes(row_size * height), filtered(line * height);
    const double scale = std::exp2(exposure);
    static const Srgb8 srgb8;
    parallel_bands(image.height, threads, [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
            const float* src = image.at(0, y);
            unsigned char* dst = bytes.data() + row_size * static_cast<std::size_t>(y);
            for (std::size_t k = 0; k < row_size; ++k) dst[k] = srgb8(src[k] * scale);
        }
    });
    parallel_bands(image.height, threads, [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y) {
            const unsigned char* row = bytes.data() + row_size * static_cast<std::size_t>(y);
            const unsigned char* above = y > 0 ? row - row_size : nullptr;
            // Each filter's bytes summed as signed values (small differences either way
            // score low); the first of the least sum filters the row.
            std::array<long, 5> sum{};
            auto magnitude = [](int d) { return static_cast<long>(static_cast<unsigned char>(d) < 128 ? static_cast<unsigned char>(d) : 256 - static_cast<unsigned char>(d)); };
            for (std::size_t k = 0; k < row_size; ++k) {
                const int x = row[k], a = k >= 3 ? row[k - 3] : 0, b = above ? above[k] : 0,
                          c = k >= 3 && above ? above[k - 3] : 0;
                sum[0] += magnitude(x);
                sum[1] += magnitude(x - a);
                sum[2] += magnitude(x - b);
                sum[3] += magnitude(x - (a + b) / 2);
                sum[4] += magnitude(x - paeth(a, b, c));
            }
            const auto type = static_cast<int>(std::min_element(sum.begin(), sum.end()) - sum.begin());
            unsigned char* out = filtered.data() + line * static_cast<std::size_t>(y);
            out[0] = static_cast<unsigned char>(type);
            filter_row(type, row, above, row_size, 3, out + 1);
        }
    });
    const int segments = (image.height + kSegmentRows - 1) / kSegmentRows;
    std::vector<std::string> deflated(static_cast<std::size_t>(segments));
    std::vector<uLong> adler(static_cast<std::size_t>(segments));
    std::vector<std::size_t> sizes(static_cast<std::size_t>(segments));
    std::vector<char> failed(static_cast<std::size_t>(segments), 0);
    parallel_chunks(segments, threads, [&](int s0, int s1) {
        for (int s = s0; s < s1; ++s) {
            const std::size_t from = line * static_cast<std::size_t>(s) * kSegmentRows;
            const std::size_t size = std::min(filtered.size(), from + line * kSegmentRows) - from;
            auto* in = const_cast<Bytef*>(reinterpret_cast<const Bytef*>(filtered.data() + from));
            z_stream z{};
            std::string& out = deflated[static_cast<std::size_t>(s)];
            if (deflateInit2(&z, 1, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
                failed[static_cast<std::size_t>(s)] = 1;
                continue;
            }
            out.resize(deflateBound(&z, static_cast<uLong>(size)) + 16);
            z.next_in = in;
            z.avail_in = static_cast<uInt>(size);
            z.next_out = reinterpret_cast<Bytef*>(out.data());
            z.avail_out = static_cast<uInt>(out.size());
            const bool last = s + 1 == segments;
            const int rc = deflate(&z, last ? Z_FINISH : Z_SYNC_FLUSH);
            if (rc != (last ? Z_STREAM_END : Z_OK) || z.avail_in != 0) failed[static_cast<std::size_t>(s)] = 1;
            out.resize(out.size() - z.avail_out);
            deflateEnd(&z);
            adler[static_cast<std::size_t>(s)] = adler32(adler32(0, nullptr, 0), in, static_cast<uInt>(size));
            sizes[static_cast<std::size_t>(s)] = size;
        }
    });
    if (std::find(failed.begin(), failed.end(), 1) != failed.end())
        throw std::runtime_error(path + ": cannot write PNG (zlib failed)");
    std::string idat = {'\x78', '\x01'};  // deflate, 32 KiB window, fastest: (0x78 << 8 | 0x01) % 31 == 0
    uLong check = adler32(0, nullptr, 0);
    for (int s = 0; s < segments; ++s) {
        idat += deflated[static_cast<std::size_t>(s)];
        check = adler32_combine(check, adler[static_cast<std::size_t>(s)], static_cast<z_off_t>(sizes[static_cast<std::size_t>(s)]));
    }
    put_u32(idat, static_cast<std::uint32_t>(check));
    std::string file = "\x89PNG\r\n\x1a\n";
    std::string header;
    put_u32(header, static_cast<std::uint32_t>(image.width));
    put_u32(header, static_cast<std::uint32_t>(image.height));
    header += std::string{'\x08', '\x02', '\x00', '\x00', '\x00'};  // 8 bits, RGB, deflate, filters, no interlace
    put_chunk(file, "IHDR", header);
    put_chunk(file, "sRGB", std::string(1, '\x00'));  // rendering intent: perceptual
    constexpr std::size_t kChunk = std::size_t{1} << 30;  // a chunk's length is below 2^31
    for (std::size_t at = 0; at < idat.size(); at += kChunk) put_chunk(file, "IDAT", idat.substr(at, kChunk));
    put_chunk(file, "IEND", "");
    write_atomically(path, [&](const std::string& tmp) {
        std::unique_ptr<FILE, int (*)(FILE*)> fp(std::fopen(tmp.c_str(), "wb"), &std::fclose);
        if (!fp) throw std::runtime_error(path + ": cannot write PNG (" + std::strerror(errno) + ")");
        if (std::fwrite(file.data(), 1, file.size(), fp.get()) != file.size() || std::fflush(fp.get()) != 0)
            throw std::runtime_error(path + ": cannot write PNG (" + std::strerror(errno) + ")");
    });
}

void write_pfm(const std::string& path, const Image& image) {
    static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "PFM: the scale -1 below says little-endian floats");
    write_atomically(path, [&](const std::string& tmp) {
        std::FILE* f = std::fopen(tmp.c_str(), "wb");
        if (!f) throw std::runtime_error(path + ": cannot open for writing (" + std::strerror(errno) + ")");
        // Portable float map: a negative scale means little-endian floats; rows bottom to top.
        std::fprintf(f, "PF\n%d %d\n-1.0\n", image.width, image.height);
        bool ok = true;
        for (int y = image.height - 1; y >= 0 && ok; --y)
            ok = std::fwrite(image.at(0, y), sizeof(float), 3 * static_cast<std::size_t>(image.width), f) ==
                 3 * static_cast<std::size_t>(image.width);
        ok = std::fclose(f) == 0 && ok;
        if (!ok) throw std::runtime_error(path + ": write failed");
    });
}

ImageFormat image_format(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    if (!ext.empty()) ext.erase(0, 1);  // the dot
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext == "exr") return ImageFormat::exr;
    if (ext == "png") return ImageFormat::png;
    if (ext == "pfm") return ImageFormat::pfm;
    if (!path.empty() && path.back() == '/')
        throw scenes::OptionError("output", path + ": names a folder, not a file (e.g. " + path + "image.exr)");
    if (ext.empty())
        throw scenes::OptionError("output", path + ": no extension to tell the image format (known: .exr, .png, .pfm)");
    throw scenes::OptionError("output", path + ": unknown image format '" + ext + "' (known: .exr, .png, .pfm)");
}

void write_image(const std::string& path, const Image& image, double exposure, int threads) {
    switch (image_format(path)) {
        case ImageFormat::exr: write_exr(path, image); break;
        case ImageFormat::png: write_png(path, image, exposure, threads); break;
        case ImageFormat::pfm: write_pfm(path, image); break;
    }
}

}  // namespace raybundle::render
