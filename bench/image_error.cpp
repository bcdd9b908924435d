// The error of an image against a reference, as render/metrics.h defines it:
//
//   image_error IMAGE.exr REFERENCE.exr
//   image_error IMAGE.exr --constant V      (the reference: V in every pixel and channel)
//
// prints five lines: "relative_l1 X" (sum |a - b| / sum |b| over all pixels and
// channels), "mse Y" (mean of (a - b)^2 over all pixels and channels), "mean M" (the
// image's mean over pixels and channels), "block4_l1 B" (the relative L1 of the means
// of 4x4-pixel blocks: grain averaged, bias kept) and "worst_block16 W" (the signed
// relative error of the 16x16-pixel block, summed over its pixels and channels, whose
// error is largest in magnitude; +0.05: 5 % too bright). Blocks cut by the image's
// edge are left out. The files are read as linear RGB
// (render::read_exr); their sizes must agree.
#include "render/image_io.h"
#include "render/metrics.h"

#include <cmath>
#include <cstdio>
#include <exception>
#include <numeric>
#include <stdexcept>
#include <string>

using namespace raybundle;

int main(int argc, char** argv) {
    const bool constant = argc == 4 && std::string(argv[2]) == "--constant";
    if (argc != 3 && !constant) {
        std::fprintf(stderr, "usage: image_error IMAGE.exr REFERENCE.exr | IMAGE.exr --constant V\n");
        return 2;
    }
    try {
        const render::Image image = render::read_exr(argv[1]);
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
        if (image.width != reference.width || image.height != reference.height)
            throw std::runtime_error(std::string(argv[1]) + " is " + std::to_string(image.width) + "x" +
                                     std::to_string(image.height) + ", " + argv[2] + " is " +
                                     std::to_string(reference.width) + "x" + std::to_string(reference.height));
        const double mean = image.rgb.empty() ? 0.0
                                              : std::accumulate(image.rgb.begin(), image.rgb.end(), 0.0) /
                                                    static_cast<double>(image.rgb.size());
        // Sums over k x k blocks, per channel: the block error of both measures.
        auto blocks = [&](int k, auto&& each) {
            for (int by = 0; by + k <= image.height; by += k)
                for (int bx = 0; bx + k <= image.width; bx += k) {
                    double a[3] = {0, 0, 0}, b[3] = {0, 0, 0};
                    for (int y = by; y < by + k; ++y)
                        for (int x = bx; x < bx + k; ++x)
                            for (int c = 0; c < 3; ++c) a[c] += image.at(x, y)[c], b[c] += reference.at(x, y)[c];
                    each(a, b);
                }
        };
        double diff4 = 0.0, sum4 = 0.0, worst = 0.0;
        blocks(4, [&](const double* a, const double* b) {
            for (int c = 0; c < 3; ++c) diff4 += std::abs(a[c] - b[c]), sum4 += std::abs(b[c]);
        });
        blocks(16, [&](const double* a, const double* b) {
            const double ref = b[0] + b[1] + b[2];
            const double rel = ref > 0.0 ? (a[0] + a[1] + a[2] - ref) / ref : 0.0;
            if (std::abs(rel) > std::abs(worst)) worst = rel;
        });
        std::printf("relative_l1 %.6g\nmse %.6g\nmean %.6g\nblock4_l1 %.6g\nworst_block16 %.6g\n",
                    render::relative_l1(image, reference), render::mse(image, reference), mean,
                    sum4 > 0.0 ? diff4 / sum4 : 0.0, worst);
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "image_error: error: %s\n", e.what());
        return 1;
    }
}
