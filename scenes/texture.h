#pragma once
// An asset's colour texture (an MTL's map_Kd, a glTF's baseColorTexture): its texels as
// stored (8-bit sRGB, the first row the image's top), read as linear colours,
// bilinearly between texel centres and wrapped at the edges as its sampler says.
#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace raybundle::scenes {

using Rgb = Eigen::Array3d;

// The decoded image: width x height RGB texels, 3 bytes each, sRGB-encoded.
struct TexelImage {
    int width = 0, height = 0;
    std::vector<std::uint8_t> srgb;
    Rgb mean = Rgb::Zero();        // the linear mean over the texels
    Rgb brightest = Rgb::Zero();   // per channel, the largest linear value
};

// The image of a PNG or JPEG file's bytes (at most 8192 texels on a side; alpha left
// out: the colours as stored, not mixed onto black; 16-bit samples rounded to 8 bits;
// the values read as sRGB whatever a PNG's gAMA, sRGB or iCCP chunk says, as glTF asks
// and Blender reads them), or nothing with why in `why` ("not a PNG or JPEG", "a PNG
// libpng cannot read: ...", "a JPEG of 9000 x 10 texels, more than 8192 on a side").
std::optional<TexelImage> decode_image(std::string_view bytes, std::string* why = nullptr);

// The linear value of an 8-bit sRGB value.
double srgb_to_linear(std::uint8_t v);

struct Texture {
    enum class Wrap { repeat, clamp, mirror };
    // Where it came from, to tell two apart: the file's path, or "model.glb: images[2]".
    std::string name;
    // The same for messages: the name as the MTL writes it ("maps/wood.png"), or the
    // glTF image's ("model.glb: images[2] (wood.png)").
    std::string shown;
    std::shared_ptr<const TexelImage> image;
    Wrap wrap_s = Wrap::repeat, wrap_t = Wrap::repeat;

    // The linear colour at texture coordinates (s, t): s from the image's left edge, t
    // from its top edge, 1 its width or height (glTF's convention; an OBJ's v is 1 - t).
    Rgb at(double s, double t) const;
    const Rgb& mean() const { return image->mean; }
    bool same(const Texture& o) const { return name == o.name && wrap_s == o.wrap_s && wrap_t == o.wrap_t; }
};

}  // namespace raybundle::scenes
