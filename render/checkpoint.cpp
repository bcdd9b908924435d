#include "render/checkpoint.h"

#include "render/image_io.h"
#include "render/memory.h"
#include "scenes/errors.h"
#include "scenes/mesh_file.h"
#include "visibility/exact_spans.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>

#ifndef RAYBUNDLE_VERSION
#define RAYBUNDLE_VERSION "unknown"
#endif

namespace raybundle::render {

namespace {

using json = nlohmann::json;

// The format's number: 2 since the walk sources (solver/walk_source.h) save their own
// state after a tag of the sampler.
constexpr char kMagic[] = "raybundle checkpoint 2\n";
constexpr char kMagicPrefix[] = "raybundle checkpoint ";
constexpr std::uint32_t kByteOrder = 0x01020304u;
// The largest checkpoint read: two chains of 10^7 patches with the ambient variate's
// vectors are about 3 GB.
constexpr std::uintmax_t kMaxCheckpointBytes = std::uintmax_t{16} << 30;
// The largest step count and solve time a header may hold: the command line's limit on
// --iterations, and a hundred years.
constexpr long kMaxSteps = 1000000000L;
constexpr double kMaxSeconds = 3.2e9;

struct Fnv {
    std::uint64_t h = 0xcbf29ce484222325ull;
    void bytes(const void* p, std::size_t n) {
        const auto* c = static_cast<const unsigned char*>(p);
        for (std::size_t i = 0; i < n; ++i) h = (h ^ c[i]) * 0x100000001b3ull;
    }
    template <class T>
    void value(const T& v) {
        bytes(&v, sizeof v);
    }
    void vec(const Eigen::Vector3d& v) { bytes(v.data(), 3 * sizeof(double)); }
    void rgb(const Eigen::Array3d& v) { bytes(v.data(), 3 * sizeof(double)); }
};

std::string hex(std::uint64_t h) {
    char text[17];
    std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(h));
    return text;
}

// Everything of the loaded scene that the solve and the image read.
std::string scene_hash(const scenes::Scene& scene) {
    Fnv f;
    f.value(scene.patch_count());
    for (const auto& p : scene.patch_list()) {
        f.bytes(p.v, sizeof p.v);
        f.value(p.material);
        f.value(p.object);
    }
    for (const auto& v : scene.vertex_positions()) f.vec(v);
    for (const auto& corners : scene.corner_normals())
        for (const auto& n : corners) f.vec(n);
    for (const auto& m : scene.materials) {
        f.rgb(m.albedo);
        f.rgb(m.emission);
        f.rgb(m.specular);
        f.value(m.exponent);
        f.value(m.two_sided);
    }
    // A textured scene's albedos per patch and its textures' texels (the same hash as
    // before for scenes without).
    if (scene.textured()) {
        for (std::size_t i = 0; i < scene.patch_count(); ++i) f.rgb(scene.albedo_of(i));
        for (const auto& m : scene.materials)
            if (m.texture) {
                f.bytes(m.texture->image->srgb.data(), m.texture->image->srgb.size());
                f.value(static_cast<int>(m.texture->wrap_s));
                f.value(static_cast<int>(m.texture->wrap_t));
                f.rgb(m.tint);
            }
        for (const auto& map : scene.texture_maps) {
            f.bytes(map.linear.data(), sizeof(double) * 6);
            f.vec(map.origin);
            f.bytes(map.at_origin.data(), sizeof(double) * 2);
            if (map.has_colour()) {  // (textures alone hash as before)
                f.bytes(map.colour_linear.data(), sizeof(double) * 9);
                f.rgb(map.colour_at_origin);
            }
        }
    }
    const auto& c = scene.camera;
    f.vec(c.eye);
    f.vec(c.target);
    f.vec(c.up);
    f.value(c.fov_y);
    f.value(c.width);
    f.value(c.height);
    for (const auto& l : scene.point_lights) {
        f.vec(l.position);
        f.rgb(l.intensity);
        if (l.spot()) {  // (an isotropic light's record as before spots were read)
            f.vec(l.axis);
            f.value(l.cos_inner);
            f.value(l.cos_outer);
        }
    }
    if (!scene.directional_lights.empty()) f.value(scene.directional_lights.size());  // (none: as before they were read)
    for (const auto& l : scene.directional_lights) {
        f.vec(l.direction);
        f.rgb(l.irradiance);
    }
    if (scene.sky) {
        f.rgb(scene.sky->radiance);
        f.vec(scene.sky->up);
        f.value(static_cast<int>(scene.sky->model));
    }
    return hex(f.h);
}

CheckpointError bad(const std::string& path, const std::string& why) { return CheckpointError(path + ": " + why); }

// Appends a u64 length and the bytes.
void put_block(std::string& out, const std::string& block) {
    const std::uint64_t n = block.size();
    out.append(reinterpret_cast<const char*>(&n), sizeof n);
    out += block;
}

// The header's values of the types and in the ranges a run writes them: anything else
// is refused here, naming the value, before the run uses it.
void check_header(const std::string& path, const json& h) {
    auto need = [&path](bool ok, const std::string& what) {
        if (!ok) throw bad(path, "its header is damaged (" + what + ")");
    };
    auto string_at = [](const json& o, const char* key) { return o.is_object() && o.contains(key) && o[key].is_string(); };
    need(h.is_object(), "not a JSON object");
    need(h.contains("identity") && h["identity"].is_object(), "identity: not an object");
    const json& id = h["identity"];
    need(string_at(id, "version"), "identity.version: not a string");
    need(id.contains("scene") && string_at(id["scene"], "name") && string_at(id["scene"], "hash") &&
             id["scene"].contains("patches") && id["scene"]["patches"].is_number_unsigned(),
         "identity.scene: not a name, a hash and a patch count");
    need(id.contains("options") && id["options"].is_object(), "identity.options: not an object");
    for (const auto& [flag, values] : id["options"].items()) {
        bool strings = values.is_array();
        for (const auto& v : values) strings = strings && v.is_string();
        need(strings, "identity.options." + flag + ": not a list of strings");
    }
    need(h.contains("steps_done") && h["steps_done"].is_number_unsigned() &&
             h["steps_done"].get<std::uint64_t>() <= static_cast<std::uint64_t>(kMaxSteps),
         "steps_done: not a step count in 0.." + std::to_string(kMaxSteps));
    need(h.contains("seconds") && h["seconds"].is_number() && h["seconds"].get<double>() >= 0.0 &&
             h["seconds"].get<double>() <= kMaxSeconds,
         "seconds: not a duration in 0.." + std::to_string(static_cast<long>(kMaxSeconds)));
    need(h.contains("rows") && h["rows"].is_array(), "rows: not a list");
    for (const auto& row : h["rows"]) need(row.is_object(), "rows: a row that is not an object");
}

}  // namespace

json run_identity(const json& options, const scenes::Scene& scene) {
    // The version and the exact painter's span kernels (AVX2 and the portable loops may
    // differ in a pixel pair where depths tie): a checkpoint goes on bit-identically only
    // on the same build and kernels.
    return {{"version", std::string(RAYBUNDLE_VERSION) + " (" + visibility::best_span_kernels().name + " kernels)"},
            {"scene", {{"name", scene.name}, {"patches", scene.patch_count()}, {"hash", scene_hash(scene)}}},
            {"options", options}};
}

std::uint64_t identity_hash(const json& identity) {
    const std::string bytes = identity.dump();
    Fnv f;
    f.bytes(bytes.data(), bytes.size());
    return f.h;
}

void write_checkpoint(const std::string& path, const Checkpoint& k, const TemporaryTracker& tracker) {
    std::string bytes = kMagic;
    bytes.append(reinterpret_cast<const char*>(&kByteOrder), sizeof kByteOrder);
    const json header = {{"identity", k.identity}, {"steps_done", k.steps_done}, {"seconds", k.seconds}, {"rows", k.rows}};
    put_block(bytes, header.dump());
    const std::uint64_t count = k.states.size();
    bytes.append(reinterpret_cast<const char*>(&count), sizeof count);
    for (const auto& state : k.states) put_block(bytes, state);
    Fnv f;
    f.bytes(bytes.data(), bytes.size());
    bytes.append(reinterpret_cast<const char*>(&f.h), sizeof f.h);

    const int slot = tracker.track ? tracker.track(path + ".partial-" + std::to_string(::getpid())) : -1;
    auto untrack = [&] {
        if (tracker.untrack) tracker.untrack(slot);
    };
    try {
        write_atomically(path, [&](const std::string& tmp) {
            std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(tmp.c_str(), "wb"), &std::fclose);
            if (!file) throw std::runtime_error(path + ": cannot write (" + std::strerror(errno) + ")");
            // On disk before the rename: a crash of the machine leaves the old checkpoint.
            if (std::fwrite(bytes.data(), 1, bytes.size(), file.get()) != bytes.size() || std::fflush(file.get()) != 0 ||
                ::fsync(::fileno(file.get())) != 0)
                throw std::runtime_error(path + ": write failed (" + std::strerror(errno) + ")");
        });
    } catch (...) {
        untrack();
        throw;
    }
    untrack();
}

Checkpoint read_checkpoint(const std::string& path, const scenes::MemoryShare& memory_share) {
    // Its first bytes and its size before the whole file: a file that is not a
    // checkpoint, or one this process could not hold (its share of the machine where
    // ranks share one), is refused without reading it.
    if (std::ifstream in(path, std::ios::binary); in) {
        std::string head(sizeof kMagicPrefix - 1, '\0');
        in.read(head.data(), static_cast<std::streamsize>(head.size()));
        if (head.compare(0, static_cast<std::size_t>(in.gcount()), kMagicPrefix) != 0 ||
            in.gcount() < static_cast<std::streamsize>(head.size()))
            throw bad(path, "not a raybundle checkpoint");
        std::error_code ec;
        const std::uintmax_t size = std::filesystem::file_size(path, ec);
        const std::uint64_t memory = memory_share.bytes;
        if (!ec && memory > 0 && size > memory / 2)
            throw bad(path, scenes::gigabytes(static_cast<double>(size)) + ", more than half of the " +
                                scenes::gigabytes(static_cast<double>(memory)) + " this process may hold (" +
                                memory_share.text() + "): not a checkpoint it could go on from");
    }
    std::string bytes;
    try {
        bytes = scenes::read_input_file(path, path, "checkpoint", kMaxCheckpointBytes);
    } catch (const scenes::SceneError& e) {
        throw CheckpointError(e.what());
    }
    return parse_checkpoint(std::move(bytes), path);
}

Checkpoint parse_checkpoint(std::string bytes, const std::string& path) {
    const std::size_t magic = sizeof kMagic - 1;
    if (bytes.compare(0, magic, kMagic) != 0) {
        const std::size_t prefix = sizeof kMagicPrefix - 1;
        if (bytes.compare(0, prefix, kMagicPrefix) != 0) throw bad(path, "not a raybundle checkpoint");
        const std::size_t end = bytes.find('\n', prefix);
        throw bad(path, "a checkpoint of format " + bytes.substr(prefix, std::min<std::size_t>(end, prefix + 8) - prefix) +
                            " (another raybundle); this one reads format " + std::string(kMagic + prefix, magic - prefix - 1));
    }
    std::size_t at = magic;
    auto take = [&](void* p, std::size_t n) {
        if (bytes.size() - at < n) throw bad(path, "the checkpoint ends early (a truncated or damaged file)");
        std::memcpy(p, bytes.data() + at, n);
        at += n;
    };
    std::uint32_t order = 0;
    take(&order, sizeof order);
    if (order != kByteOrder) throw bad(path, "written on a machine of another byte order");
    if (bytes.size() < at + sizeof(std::uint64_t)) throw bad(path, "the checkpoint ends early (a truncated or damaged file)");
    Fnv f;
    f.bytes(bytes.data(), bytes.size() - sizeof f.h);
    std::uint64_t sum = 0;
    std::memcpy(&sum, bytes.data() + bytes.size() - sizeof sum, sizeof sum);
    if (sum != f.h) throw bad(path, "its checksum does not match (a truncated or damaged file)");
    bytes.resize(bytes.size() - sizeof sum);
    auto block = [&] {
        std::uint64_t n = 0;
        take(&n, sizeof n);
        if (n > bytes.size() - at) throw bad(path, "the checkpoint ends early (a truncated or damaged file)");
        std::string b = bytes.substr(at, n);
        at += n;
        return b;
    };
    Checkpoint k;
    json header;
    try {
        header = json::parse(block());
    } catch (const json::exception& e) {
        throw bad(path, std::string("its header is damaged (") + e.what() + ")");
    }
    check_header(path, header);
    k.identity = header["identity"];
    k.steps_done = header["steps_done"].get<long>();
    k.seconds = header["seconds"].get<double>();
    k.rows = header["rows"];
    std::uint64_t count = 0;
    take(&count, sizeof count);
    if (count != 2) throw bad(path, "holds " + std::to_string(count) + " chains, a run has 2");
    for (std::uint64_t i = 0; i < count; ++i) k.states.push_back(block());
    if (at != bytes.size()) throw bad(path, "bytes after the last chain (a damaged file)");
    return k;
}

namespace {

// A number in one spelling ("02000", "2e3" and "2000.0" are "2000"); anything else as
// it is. Decimal spellings only: a name like "inf" or "0x10" stays a name.
std::string canonical_value(const std::string& value) {
    if (value.empty() || value.find_first_not_of("0123456789+-.eE") != std::string::npos) return value;
    const char* begin = value.c_str();
    char* end = nullptr;
    errno = 0;
    const double x = std::strtod(begin, &end);
    if (end != begin + value.size() || errno == ERANGE || !std::isfinite(x)) return value;
    char out[32];
    const auto written = std::to_chars(out, out + sizeof out, x == 0.0 ? 0.0 : x);  // -0 is 0
    return std::string(out, written.ptr);
}

// The options as the run means them: numbers in one spelling, -D's assignments in the
// order of their keys (a key given twice keeps its order: the last one counts).
json canonical_options(const json& options) {
    json out = options;
    for (auto& [flag, values] : out.items()) {
        if (!values.is_array()) continue;
        for (auto& v : values) {
            if (!v.is_string()) continue;
            const std::string s = v.get<std::string>();
            const std::size_t eq = s.find('=');
            v = flag == "-D" && eq != std::string::npos ? s.substr(0, eq + 1) + canonical_value(s.substr(eq + 1))
                                                          : canonical_value(s);
        }
        if (flag == "-D")
            std::stable_sort(values.begin(), values.end(), [](const json& a, const json& b) {
                const auto key = [](const json& v) {
                    const std::string s = v.is_string() ? v.get<std::string>() : v.dump();
                    return s.substr(0, s.find('='));
                };
                return key(a) < key(b);
            });
    }
    return out;
}

}  // namespace

void require_same_run(const std::string& path, const json& saved, const json& now) {
    const std::string prefix = "made by another run: ";
    if (saved.value("version", "") != now["version"])
        throw bad(path, prefix + "raybundle " + saved.value("version", "?") + ", this is " +
                            now["version"].get<std::string>());
    // The scene by what was loaded (its patches and their hash), not by how its file was
    // named: ./s.json and s.json are one scene.
    const json& a = saved.value("scene", json::object());
    const json& b = now["scene"];
    if (a.value("patches", std::size_t{0}) != b["patches"].get<std::size_t>() || a.value("hash", "") != b["hash"])
        throw bad(path, prefix + "the scene differs (" + a.value("name", "?") + ", " +
                            std::to_string(a.value("patches", 0)) + " patches, hash " + a.value("hash", "?") +
                            "; now " + b["name"].get<std::string>() + ", " +
                            std::to_string(b["patches"].get<std::size_t>()) + " patches, hash " +
                            b["hash"].get<std::string>() + ")");
    const json was = canonical_options(saved.value("options", json::object()));
    const json is = canonical_options(now["options"]);
    auto shown = [](const json& v) {
        std::string s;
        for (const auto& x : v) s += (s.empty() ? "" : " ") + x.get<std::string>();
        return s;
    };
    for (const auto& [name, value] : is.items())
        if (!was.contains(name))
            throw bad(path, prefix + name + " " + shown(value) + " is given now, not then");
        else if (was[name] != value)
            throw bad(path, prefix + name + " was " + shown(was[name]) + ", now " + shown(value));
    for (const auto& [name, value] : was.items())
        if (!is.contains(name)) throw bad(path, prefix + name + " " + shown(value) + " was given then, not now");
}

}  // namespace raybundle::render
