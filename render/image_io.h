#pragma once
// Image files. Every writer writes to a temporary file beside the target and renames
// it into place only when complete: a failure never leaves a half-written file.
#include "render/image.h"

#include <functional>
#include <string>

namespace raybundle::render {

// Who removes a temporary file if a signal ends the process (the command line's
// signal thread, render/signals.h): track(path) before the file is made gives a slot,
// untrack(slot) once it is renamed or removed. Between hold() and release() (an
// OutputSet's commit) a signal that would end the process waits. Empty functions:
// nobody.
struct TemporaryTracker {
    std::function<int(const std::string& path)> track;
    std::function<void(int slot)> untrack;
    std::function<void()> hold, release;
};

// Runs write(tmp) for a temporary path next to `path`, then renames tmp to path.
// On any exception the temporary file is removed and the exception propagates.
void write_atomically(const std::string& path, const std::function<void(const std::string& tmp)>& write);

// Linear RGB as 32-bit float channels R, G, B (OpenEXR).
void write_exr(const std::string& path, const Image& image);

// Reads the R, G and B channels of an OpenEXR file (any pixel type, converted to
// float; the data window, rows top to bottom) as linear RGB. Throws
// std::runtime_error naming the file when it cannot be read or lacks R, G or B.
Image read_exr(const std::string& path);

// Linear RGB as a portable float map (PFM: little-endian floats, rows bottom to top).
void write_pfm(const std::string& path, const Image& image);

// sRGB PNG, 8 bits. Tone map: v = clamp(2^exposure * L, 0, 1) per channel, then the
// sRGB transfer curve. exposure in stops (0: radiance 1 maps to white). The tone map
// runs on `threads` (the file is the same for any count).
void write_png(const std::string& path, const Image& image, double exposure, int threads = 1);

// The format a file name asks for, by its extension (case-insensitive): .exr, .png or
// .pfm; throws OptionError("output") for any other.
enum class ImageFormat { exr, png, pfm };
ImageFormat image_format(const std::string& path);
// Writes the image in the format its name asks for (exposure and threads: PNG only).
void write_image(const std::string& path, const Image& image, double exposure, int threads = 1);

// The 8-bit sRGB code of a linear value after exposure (the PNG tone map, shared with
// the PLY colours).
unsigned char tone_map(double linear, double exposure);
// The same of a value already scaled by 2^exposure.
unsigned char to_srgb8(double scaled);

}  // namespace raybundle::render
