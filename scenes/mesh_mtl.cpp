#include "scenes/mesh_readers.h"

#include <algorithm>
#include <cstdlib>
#include <map>
#include <sstream>

namespace raybundle::scenes {

namespace {

// The file of a map statement's text: its options (-o, -s, -t with up to 3 numbers; -mm
// with 2; -blendu, -blendv, -bm, -boost, -cc, -clamp, -imfchan, -texres, -type with 1)
// passed over, then the rest of the line, spaces included (as Blender writes a name
// with spaces), its '\' separators read as '/' (as exporters on Windows write them).
std::string map_file(const std::string& text) {
    static const std::map<std::string, int> kArguments = {
        {"-o", 3}, {"-s", 3}, {"-t", 3}, {"-mm", 2}, {"-blendu", 1}, {"-blendv", 1}, {"-bm", 1}, {"-boost", 1},
        {"-cc", 1}, {"-clamp", 1}, {"-imfchan", 1}, {"-texres", 1}, {"-type", 1}};
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
        // -o, -s, -t take 1 to 3 numbers; the others exactly their count.
        for (int k = 0; k < option->second; ++k) {
            const auto [a, b] = word(at);
            if (a == b) break;
            const std::string argument = text.substr(a, b - a);
            char* stop = nullptr;
            std::strtod(argument.c_str(), &stop);
            const bool number = stop == argument.c_str() + argument.size();
            if (option->second == 3 && k > 0 && !number) break;
            at = b;
        }
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
    while (std::getline(in, line)) {
        if (++line_no == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const std::string where = "line " + std::to_string(line_no);
        std::istringstream ls(line);
        std::string tag;
        if (!(ls >> tag) || tag[0] == '#') continue;
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
            m.map_kd = map_file(rest);
            if (m.map_kd.empty()) throw SceneError(shown, where, "map_Kd without a file name");
        }
    }
    return out;
}

}  // namespace raybundle::scenes
