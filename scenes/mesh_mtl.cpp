#include "scenes/mesh_readers.h"

#include <sstream>

namespace raybundle::scenes {

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
        } else {  // map_Kd: options (-o, -s, -bm ...) before the file name are not read
            if (rest.empty()) throw SceneError(shown, where, "map_Kd without a file name");
            m.map_kd = rest.substr(rest.find_last_of(" \t") == std::string::npos ? 0 : rest.find_last_of(" \t") + 1);
        }
    }
    return out;
}

}  // namespace raybundle::scenes
