#pragma once
// A glTF document and its binary buffer as one GLB file's bytes, for the glTF tests.
#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>

namespace raybundle::test {

// The document's first buffer becomes the binary chunk (its uri dropped, its
// byteLength the bytes'); both chunks padded to 4 bytes as the format asks.
inline std::string glb(nlohmann::json doc, const std::string& bin) {
    doc["buffers"][0].erase("uri");
    doc["buffers"][0]["byteLength"] = bin.size();
    std::string text = doc.dump();
    text.resize((text.size() + 3) / 4 * 4, ' ');
    std::string padded = bin;
    padded.resize((padded.size() + 3) / 4 * 4, '\0');
    std::string out;
    auto word = [&](std::uint32_t w) { out.append(reinterpret_cast<const char*>(&w), 4); };
    word(0x46546C67u), word(2), word(static_cast<std::uint32_t>(28 + text.size() + padded.size()));
    word(static_cast<std::uint32_t>(text.size())), word(0x4E4F534Au);
    out += text;
    word(static_cast<std::uint32_t>(padded.size())), word(0x004E4942u);
    return out + padded;
}

}  // namespace raybundle::test
