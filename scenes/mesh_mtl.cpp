#include "scenes/mesh_readers.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <sstream>
#include <vector>

namespace raybundle::scenes {

namespace {

// The file of a map statement's text: its options passed over (-o, -s, -t with 1 to 3
// numbers; -mm with 2; -bm, -boost, -texres with 1; -blendu, -blendv, -cc, -clamp with
// on or off; -imfchan with a channel; -type with a word), each argument only where it
// is of its kind and not the last word; then the rest of the line, spaces included (as
// Blender writes a name with spaces), its '\' separators read as '/' (as exporters on
// Windows write them). The arguments of each option, in `given` where asked for.
std::string map_file(const std::string& text, std::map<std::string, std::vector<std::string>>* given = nullptr) {
    enum Kind { numbers, switch_, channel, word_ };
    struct Option {
        int most;  // arguments at most (fewer where the next word is not of its kind)
        Kind kind;
    };
    static const std::map<std::string, Option> kArguments = {
        {"-o", {3, numbers}},      {"-s", {3, numbers}},      {"-t", {3, numbers}},      {"-mm", {2, numbers}},
        {"-bm", {1, numbers}},     {"-boost", {1, numbers}},  {"-texres", {1, numbers}}, {"-blendu", {1, switch_}},
        {"-blendv", {1, switch_}}, {"-cc", {1, switch_}},     {"-clamp", {1, switch_}},  {"-imfchan", {1, channel}},
        {"-type", {1, word_}}};
    const auto of_kind = [](const std::string& argument, Kind kind) {
        if (kind == switch_) return argument == "on" || argument == "off";
        if (kind == channel) return argument.size() == 1 && std::string("rgbmlz").find(argument[0]) != std::string::npos;
        if (kind == word_) return true;
        char* stop = nullptr;
        std::strtod(argument.c_str(), &stop);
        return !argument.empty() && stop == argument.c_str() + argument.size();
    };
    std::size_t at = 0;
    auto word = [&](std::size_t from) {  // [start, end) of the word at or after `from`
        const std::size_t start = text.find_first_not_of(" \t", from);
        if (start == std::string::npos) return std::pair{text.size(), text.size()};
        const std::size_t end = text.find_first_of(" \t", start);
        return std::pair{start, end == std::string::npos ? text.size() : end};
    };
    for (;;) {
        const auto [start, end] = word(at);
        const auto option = kArguments.find(text.substr(start, end - start));
        if (option == kArguments.end()) {
            at = start;
            break;
        }
        at = end;
        std::vector<std::string> arguments;
        // The last word is never an argument ("-clamp tex.png" without its on/off is
        // the name).
        for (int k = 0; k < option->second.most; ++k) {
            const auto [a, b] = word(at);
            if (a == b || word(b).first == text.size() || !of_kind(text.substr(a, b - a), option->second.kind)) break;
            arguments.push_back(text.substr(a, b - a));
            at = b;
        }
        if (given) (*given)[option->first] = arguments;
    }
    std::string file = text.substr(at);
    std::replace(file.begin(), file.end(), '\\', '/');
    return file;
}

}  // namespace

// ---------------------------------------------------------------------------- MTL
// The statements a material of this project uses: newmtl, Kd, Ke, Ks, Ns, illum,
// map_Kd. Colours are three numbers (one number is a grey, as writers abbreviate it);
// a `spectral` or `xyz` colour is refused; a `#` ends the numbers of a line. Everything
// else is read past.
std::vector<MtlMaterial> parse_mtl(std::string_view content, const std::string& shown) {
    std::vector<MtlMaterial> out;
    std::istringstream in{std::string(content)};
    std::string line;
    long line_no = 0;
    bool blender = false, commented = false;
    while (std::getline(in, line)) {
        if (++line_no == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const std::string where = "line " + std::to_string(line_no);
        std::istringstream ls(line);
        std::string tag;
        if (!(ls >> tag)) continue;
        if (tag[0] == '#') {
            // "# Blender 3.6.0 MTL File: 'None'", "# Blender MTL File: 'room.blend'"
            if (!commented) blender = line.find("Blender") != std::string::npos && line.find("MTL File") != std::string::npos;
            commented = true;
            continue;
        }
        std::string rest;
        std::getline(ls, rest);
        const auto first = rest.find_first_not_of(" \t"), last = rest.find_last_not_of(" \t");
        rest = first == std::string::npos ? std::string() : rest.substr(first, last - first + 1);
        if (tag == "newmtl") {
            if (rest.empty()) throw SceneError(shown, where, "newmtl without a name");
            for (const auto& m : out)
                if (m.name == rest)
                    throw SceneError(shown, where,
                                     "material '" + rest + "' is defined twice (first on line " + std::to_string(m.line) + ")");
            out.push_back({});
            out.back().name = rest;
            out.back().line = line_no;
            out.back().blender = blender;
            continue;
        }
        const bool used = tag == "Kd" || tag == "Ke" || tag == "Ks" || tag == "Ns" || tag == "illum" || tag == "map_Kd";
        if (!used) continue;
        if (out.empty()) throw SceneError(shown, where, tag + " before the first newmtl");
        MtlMaterial& m = out.back();
        // Numbers with strtod, each whole and finite.
        std::vector<double> numbers;
        if (tag != "map_Kd") {
            // A comment may end the line ("Kd 0.63 0.065 0.05 # Red").
            std::istringstream ns(rest.substr(0, rest.find('#')));
            std::string word;
            while (ns >> word) {
                char* end = nullptr;
                const double x = std::strtod(word.c_str(), &end);
                if (end != word.c_str() + word.size() || !std::isfinite(x))
                    throw SceneError(shown, where, tag + ": '" + word + "' is not a finite number");
                numbers.push_back(x);
            }
        }
        if (tag == "Kd" || tag == "Ke" || tag == "Ks") {
            if (numbers.size() != 1 && numbers.size() != 3)
                throw SceneError(shown, where, tag + ": expected 3 numbers (r g b), got '" + rest + "'");
            const Rgb c = numbers.size() == 1 ? Rgb::Constant(numbers[0]) : Rgb(numbers[0], numbers[1], numbers[2]);
            if ((c < 0.0).any()) throw SceneError(shown, where, tag + ": negative colour '" + rest + "'");
            (tag == "Kd" ? m.kd : tag == "Ke" ? m.ke : m.ks) = c;
        } else if (tag == "Ns") {
            if (numbers.size() != 1 || numbers[0] < 0.0)
                throw SceneError(shown, where, "Ns: expected one number >= 0, got '" + rest + "'");
            m.ns = numbers[0];
        } else if (tag == "illum") {
            if (numbers.size() != 1 || numbers[0] != std::floor(numbers[0]) || numbers[0] < 0 || numbers[0] > 10)
                throw SceneError(shown, where, "illum: expected a whole number 0..10, got '" + rest + "'");
            m.illum = static_cast<int>(numbers[0]);
        } else {
            std::map<std::string, std::vector<std::string>> options;
            m.map_kd = map_file(rest, &options);
            if (m.map_kd.empty()) throw SceneError(shown, where, "map_Kd without a file name");
            // -o u [v [w]], -s u [v [w]] (v 0 and 1 where not given; w not read), -clamp on.
            const auto uv = [&](const char* option, double fallback) {
                Uv values = Uv::Constant(fallback);
                const auto it = options.find(option);
                if (it == options.end()) return values;
                for (std::size_t k = 0; k < 2 && k < it->second.size(); ++k) {
                    values[static_cast<Eigen::Index>(k)] = std::strtod(it->second[k].c_str(), nullptr);
                    if (!std::isfinite(values[static_cast<Eigen::Index>(k)]))
                        throw SceneError(shown, where, std::string("map_Kd ") + option + ": '" + it->second[k] +
                                                           "' is not a finite number");
                }
                return values;
            };
            m.map_kd_offset = uv("-o", 0.0);
            m.map_kd_scale = uv("-s", 1.0);
            const auto clamp = options.find("-clamp");
            m.map_kd_clamp = clamp != options.end() && !clamp->second.empty() && clamp->second[0] == "on";
            // An option this reader does not know ("-gamma 2.2 wood.png") would be read
            // as part of the name: the last word is kept to try where that name is no file.
            m.map_kd_last = map_file(rest.substr(rest.find_last_of(" \t") == std::string::npos ? 0
                                                                                                : rest.find_last_of(" \t") + 1));
        }
    }
    return out;
}

}  // namespace raybundle::scenes
