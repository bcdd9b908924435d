// The error of an image against a reference, as render/metrics.h defines it:
//
//   image_error IMAGE.exr REFERENCE.exr
//   image_error IMAGE.exr --constant V      (the reference: V in every pixel and channel)
//   image_error IMAGE.exr REFERENCE.exr --map K
//
// prints five lines: "relative_l1 X" (sum |a - b| / sum |b| over all pixels and
// channels), "mse Y" (mean of (a - b)^2 over all pixels and channels), "mean M" (the
// image's mean over pixels and channels), "block4_l1 B" (the relative L1 of the means
// of 4x4-pixel blocks: grain averaged, bias kept) and "worst_block16 W" (the signed
// relative error of the 16x16-pixel block, summed over its pixels and channels, whose
// error is largest in magnitude; +0.05: 5 % too bright). Blocks cut by the image's
// edge are left out (render/metrics.h). The files are read as linear RGB
// (render::read_exr); their sizes must agree, or the image's be k times the
// reference's in both directions (k an integer): then the image's k x k means are
// compared (a 512^2 image against a 128^2 reference, whose pixels cover the same area).
// With --map K it prints instead the signed
// relative error of every whole K x K block, in per cent, a row of blocks a line, top
// first: where the error is.
#include "render/image_io.h"
#include "render/metrics.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

using namespace raybundle;

int main(int argc, char** argv) {
    if (argc == 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h")) {
        std::printf("usage: image_error IMAGE.exr REFERENCE.exr [--map K] | IMAGE.exr --constant V\n");
        return 0;
    }
    const bool constant = argc == 4 && std::string(argv[2]) == "--constant";
    const bool map = argc == 5 && std::string(argv[3]) == "--map";
    if (argc != 3 && !constant && !map) {
        std::fprintf(stderr, "usage: image_error IMAGE.exr REFERENCE.exr [--map K] | IMAGE.exr --constant V\n");
        return 2;
    }
    try {
        render::Image image = render::read_exr(argv[1]);
        render::Image reference;
        if (constant) {
            reference = render::Image(image.width, image.height);
            std::size_t used = 0;
            float v = 0.0f;
            try {
                v = std::stof(argv[3], &used);
            } catch (const std::exception&) {
            }
            if (used == 0 || argv[3][used] != '\0')
                throw std::runtime_error(std::string("--constant ") + argv[3] + ": not a number");
            reference.rgb.assign(reference.rgb.size(), v);
        } else {
            reference = render::read_exr(argv[2]);
        }
        if (reference.width > 0 && reference.height > 0 && image.width % reference.width == 0 &&
            image.height % reference.height == 0 && image.width / reference.width == image.height / reference.height &&
            image.width > reference.width) {
            // The image's k x k means.
            const int k = image.width / reference.width;
            render::Image means(reference.width, reference.height);
            for (int y = 0; y < image.height; ++y)
                for (int x = 0; x < image.width; ++x)
                    for (int c = 0; c < 3; ++c) means.at(x / k, y / k)[c] += image.at(x, y)[c] / static_cast<float>(k * k);
            image = std::move(means);
        }
        if (image.width != reference.width || image.height != reference.height)
            throw std::runtime_error(std::string(argv[1]) + " is " + std::to_string(image.width) + "x" +
                                     std::to_string(image.height) + ", " + argv[2] + " is " +
                                     std::to_string(reference.width) + "x" + std::to_string(reference.height));
        if (map) {
            char* end = nullptr;
            const long k = std::strtol(argv[4], &end, 10);
            if (end == argv[4] || *end != '\0' || k < 1 || k > 1 << 16)
                throw std::runtime_error(std::string("--map ") + argv[4] + ": not a block size from 1 to 65536");
            const auto errors = render::block_errors(image, reference, static_cast<int>(k));
            const std::size_t per_row = static_cast<std::size_t>(image.width / k);
            for (std::size_t i = 0; i < errors.size(); ++i)
                std::printf(" %+6.1f%s", 100.0 * errors[i], (i + 1) % per_row == 0 ? "\n" : "");
            return 0;
        }
        const double mean = image.rgb.empty() ? 0.0
                                              : std::accumulate(image.rgb.begin(), image.rgb.end(), 0.0) /
                                                    static_cast<double>(image.rgb.size());
        const render::ImageError e = render::image_error(image, reference);
        std::printf("relative_l1 %.6g\nmse %.6g\nmean %.6g\nblock4_l1 %.6g\nworst_block16 %.6g\n", e.relative_l1, e.mse,
                    mean, e.block4_l1, e.worst_block16);
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "image_error: error: %s\n", e.what());
        return 1;
    }
}
