// The error of an image against a reference, as render/metrics.h defines it:
//
//   image_error IMAGE.exr REFERENCE.exr
//   image_error IMAGE.exr --constant V      (the reference: V in every pixel and channel)
//
// prints three lines: "relative_l1 X" (sum |a - b| / sum |b| over all pixels and
// channels), "mse Y" (mean of (a - b)^2 over all pixels and channels) and "mean M" (the
// image's mean over pixels and channels). The files are read as linear RGB
// (render::read_exr); their sizes must agree.
#include "render/image_io.h"
#include "render/metrics.h"

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
        std::printf("relative_l1 %.6g\nmse %.6g\nmean %.6g\n", render::relative_l1(image, reference),
                    render::mse(image, reference), mean);
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "image_error: error: %s\n", e.what());
        return 1;
    }
}
