#pragma once
// The two kinds of bad input a library reports, each one clear line:
//  - SceneError: a scene (file, built-in, override) with a bad value: names the file,
//    the object and the value.
//  - OptionError: a run option the library cannot use, named in the library's own
//    terms (a field of SolverOptions, GatherOptions, ...); the command line maps the
//    name to its flag.
// Anything else a library throws is a failure, not the user's fault.
#include <algorithm>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

namespace raybundle::scenes {

// Edits (insertions, deletions, substitutions) between a and b: the "did you mean"
// of a message (an unknown option, an unknown glTF key).
inline std::size_t edit_distance(const std::string& a, const std::string& b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diagonal = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t up = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diagonal = up;
        }
    }
    return row[b.size()];
}

// `text` with its control characters (newlines, tabs, escape sequences: bytes below 32
// and 127) written as \n, \t or \xHH, so that a message with a file name or a string
// from a file stays one line and cannot drive the terminal. Other bytes (UTF-8) stay.
inline std::string printable(const std::string& text) {
    std::string out;
    for (const char ch : text) {
        const auto c = static_cast<unsigned char>(ch);
        if (c >= 32 && c != 127) {
            out += ch;
        } else if (c == '\n') {
            out += "\\n";
        } else if (c == '\t') {
            out += "\\t";
        } else {
            static const char digits[] = "0123456789abcdef";
            out += {'\\', 'x', digits[c >> 4], digits[c & 15]};
        }
    }
    return out;
}

class SceneError : public std::runtime_error {
public:
    // file: the scene or mesh file ("" for built-in scenes); where: the object path
    // inside it (e.g. "objects[2].material"); what: the problem with the value.
    SceneError(const std::string& file, const std::string& where, const std::string& what)
        : std::runtime_error(compose(file, where, what)), file_(file), where_(where), problem_(what) {}
    const std::string& file() const { return file_; }
    const std::string& where() const { return where_; }
    const std::string& problem() const { return problem_; }

private:
    std::string file_, where_, problem_;

    static std::string compose(const std::string& file, const std::string& where,
                               const std::string& what) {
        std::string s;
        if (!file.empty()) s += file + ": ";
        if (!where.empty()) s += where + ": ";
        return s + what;
    }
};

class OptionError : public std::runtime_error {
public:
    OptionError(std::string option, std::string what)
        : std::runtime_error(option + ": " + what), option_(std::move(option)), what_(std::move(what)) {}
    const std::string& option() const { return option_; }
    const std::string& problem() const { return what_; }

private:
    std::string option_, what_;
};

}  // namespace raybundle::scenes
