#pragma once
// SceneError: one clear line naming the file, the object and the offending value.
#include <stdexcept>
#include <string>

namespace raybundle::scenes {

class SceneError : public std::runtime_error {
public:
    // file: the scene or mesh file ("" for built-in scenes); where: the object path
    // inside it (e.g. "objects[2].material"); what: the problem with the value.
    SceneError(const std::string& file, const std::string& where, const std::string& what)
        : std::runtime_error(compose(file, where, what)) {}

private:
    static std::string compose(const std::string& file, const std::string& where,
                               const std::string& what) {
        std::string s;
        if (!file.empty()) s += file + ": ";
        if (!where.empty()) s += where + ": ";
        return s + what;
    }
};

}  // namespace raybundle::scenes
