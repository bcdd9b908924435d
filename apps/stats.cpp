#include "stats.h"

#include "render/image_io.h"

#include <fstream>
#include <stdexcept>

namespace raybundle::apps {

void write_json(const std::string& path, const nlohmann::json& doc) {
    render::write_atomically(path, [&](const std::string& tmp) {
        std::ofstream out(tmp);
        if (!out) throw std::runtime_error(path + ": cannot open for writing");
        out << doc.dump(2) << '\n';
        out.close();
        if (!out) throw std::runtime_error(path + ": write failed");
    });
}

}  // namespace raybundle::apps
