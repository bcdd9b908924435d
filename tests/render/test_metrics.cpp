// The image error measures (render/metrics.h) on images whose errors are known by hand.
#include "render/metrics.h"

#include <catch2/catch.hpp>

using namespace raybundle;

namespace {

render::Image filled(int w, int h, float v) {
    render::Image img(w, h);
    img.rgb.assign(img.rgb.size(), v);
    return img;
}

}  // namespace

TEST_CASE("block errors: grain averages out, bias stays", "[render][metrics]") {
    const render::Image reference = filled(8, 8, 1.0f);
    // A checkerboard of +-0.5 around the reference: 50 % per pixel, nothing on blocks.
    render::Image grain = reference;
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x)
            for (int c = 0; c < 3; ++c) grain.at(x, y)[c] = (x + y) % 2 ? 1.5f : 0.5f;
    CHECK(render::relative_l1(grain, reference) == Approx(0.5));
    CHECK(render::block_relative_l1(grain, reference, 4) == Approx(0.0).margin(1e-12));
    CHECK(render::worst_block(grain, reference, 4) == Approx(0.0).margin(1e-12));
    CHECK(render::mse(grain, reference) == Approx(0.25));

    // One 4x4 block 20 % too bright, the rest right: a quarter of the blocks.
    render::Image bias = reference;
    for (int y = 4; y < 8; ++y)
        for (int x = 0; x < 4; ++x)
            for (int c = 0; c < 3; ++c) bias.at(x, y)[c] = 1.2f;
    CHECK(render::relative_l1(bias, reference) == Approx(0.05));
    CHECK(render::block_relative_l1(bias, reference, 4) == Approx(0.05));
    CHECK(render::worst_block(bias, reference, 4) == Approx(0.2));
    // Block by block, a row at a time from the top: the bright one is the third.
    const auto errors = render::block_errors(bias, reference, 4);
    REQUIRE(errors.size() == 4);
    CHECK(errors[0] == 0.0);
    CHECK(errors[1] == 0.0);
    CHECK(errors[2] == Approx(0.2));
    CHECK(errors[3] == 0.0);
    // The 8x8 block holds it all, diluted four times.
    CHECK(render::worst_block(bias, reference, 8) == Approx(0.05));
    // The sign says which way: too dark is negative.
    CHECK(render::worst_block(filled(8, 8, 0.9f), reference, 4) == Approx(-0.1));
}

TEST_CASE("block errors: blocks cut by the edge are left out, sizes checked", "[render][metrics]") {
    render::Image reference = filled(6, 5, 1.0f), image = filled(6, 5, 1.0f);
    // Only the top-left 4x4 block is whole; the error outside it does not count.
    for (int y = 0; y < 5; ++y)
        for (int c = 0; c < 3; ++c) image.at(5, y)[c] = 3.0f;
    CHECK(render::block_relative_l1(image, reference, 4) == 0.0);
    CHECK(render::worst_block(image, reference, 4) == 0.0);
    CHECK(render::worst_block(image, reference, 16) == 0.0);  // no whole block
    const auto e = render::image_error(image, reference);
    CHECK(e.relative_l1 == Approx(10.0 / 30.0));
    CHECK(e.block4_l1 == 0.0);
    CHECK_THROWS_AS(render::block_relative_l1(image, filled(5, 5, 1.0f), 4), std::invalid_argument);
    CHECK_THROWS_AS(render::block_relative_l1(image, reference, 0), std::invalid_argument);
}
