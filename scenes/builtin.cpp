#include "scenes/builtin.h"

#include "scenes/errors.h"
#include "scenes/contacts.h"
#include "scenes/subdivide.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <sstream>

namespace raybundle::scenes {
namespace {

Material make_material(const std::string& name, Rgb albedo, Rgb emission = Rgb::Zero()) {
    Material m;
    m.name = name;
    m.albedo = albedo;
    m.emission = emission;
    return m;
}

// The unit cube as one welded, closed mesh with inward-facing triangles.
Scene homogeneous_box() {
    Scene s;
    s.name = "homogeneous-box";
    const int mat = s.add_material(make_material("homogeneous", Rgb::Constant(0.5), Rgb::Constant(0.5)));
    std::vector<Vec3> v;
    for (int i = 0; i < 8; ++i) v.emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
    // Each face as a quad (corner indices round it), then oriented towards the centre.
    const int quads[6][4] = {{0, 1, 3, 2}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 3, 7, 5}};
    const Vec3 center(0.5, 0.5, 0.5);
    std::vector<std::array<int, 3>> tris;
    for (const auto& q : quads) {
        std::array<int, 3> t1{q[0], q[1], q[2]}, t2{q[0], q[2], q[3]};
        const Vec3 n = (v[q[1]] - v[q[0]]).cross(v[q[2]] - v[q[0]]);
        if (n.dot(center - v[q[0]]) < 0) {
            std::swap(t1[1], t1[2]);
            std::swap(t2[1], t2[2]);
        }
        tris.push_back(t1);
        tris.push_back(t2);
    }
    s.add_object(v, tris, mat, "box");
    s.camera.eye = Vec3(0.5, 0.5, 0.02);
    s.camera.target = Vec3(0.5, 0.5, 1.0);
    s.camera.up = Vec3(0, 1, 0);
    s.camera.fov_y = 90.0;
    s.camera.width = 256;
    s.camera.height = 256;
    // Le = 0.5 and albedo 0.5 everywhere in a closed box: L = 0.5 + 0.5 L, so L = 1.
    s.exact_radiance = 1.0;
    s.homogeneous_albedo = 0.5;
    return s;
}

// A floor (a convex quad in the plane y = const) with the blocks' footprints cut out:
// the quad is split by the lines through every footprint edge (a line arrangement,
// so the pieces meet edge to edge, without T-junctions), the pieces inside a
// footprint are dropped, and the rest are triangulated as fans. No patch straddles a
// block's base, where sorting patches by their centres would go wrong, and no patch
// hides under a block.
void add_floor(Scene& s, const Vec3 corners[4], const std::vector<std::array<Vec3, 4>>& footprints, int material,
               const Vec3& towards) {
    using P = Eigen::Vector2d;  // (x, z)
    using Poly = std::vector<P>;
    auto cross = [](const P& a, const P& b) { return a.x() * b.y() - a.y() * b.x(); };
    // Keeps the part of a convex polygon on the side of line (a, b) where side * cross >= 0.
    auto clip = [&](const Poly& poly, const P& a, const P& b, double side) {
        Poly out;
        for (std::size_t k = 0; k < poly.size(); ++k) {
            const P& p = poly[k];
            const P& q = poly[(k + 1) % poly.size()];
            const double dp = side * cross(b - a, p - a), dq = side * cross(b - a, q - a);
            if (dp >= 0) out.push_back(p);
            if ((dp > 0 && dq < 0) || (dp < 0 && dq > 0)) out.push_back(p + (q - p) * (dp / (dp - dq)));
        }
        return out;
    };
    auto area = [&](const Poly& poly) {
        double a = 0;
        for (std::size_t k = 0; k < poly.size(); ++k) a += cross(poly[k], poly[(k + 1) % poly.size()]);
        return 0.5 * a;
    };
    std::vector<Poly> cells{{}};
    for (int k = 0; k < 4; ++k) cells[0].emplace_back(corners[k].x(), corners[k].z());
    for (const auto& fp : footprints)
        for (int k = 0; k < 4; ++k) {
            const P a(fp[k].x(), fp[k].z()), b(fp[(k + 1) % 4].x(), fp[(k + 1) % 4].z());
            std::vector<Poly> next;
            for (const auto& c : cells)
                for (double side : {1.0, -1.0}) {
                    Poly part = clip(c, a, b, side);
                    if (part.size() >= 3 && std::abs(area(part)) > 1e-9) next.push_back(std::move(part));
                }
            cells.swap(next);
        }
    auto inside_footprint = [&](const P& q) {
        for (const auto& fp : footprints) {
            int sign = 0;
            bool in = true;
            for (int k = 0; k < 4 && in; ++k) {
                const P a(fp[k].x(), fp[k].z()), b(fp[(k + 1) % 4].x(), fp[(k + 1) % 4].z());
                const int sk = cross(b - a, q - a) > 0 ? 1 : -1;
                if (sign == 0) sign = sk;
                in = sk == sign;
            }
            if (in) return true;
        }
        return false;
    };
    // Weld the pieces' corners (the same intersection computed from two pieces may
    // differ in the last bits) and fan-triangulate the pieces outside the footprints.
    const double y = corners[0].y();
    std::vector<Vec3> vertices;
    std::map<std::pair<long long, long long>, int> index;
    auto vertex = [&](const P& p) {
        const std::pair<long long, long long> key{std::llround(p.x() * 1e6), std::llround(p.y() * 1e6)};
        const auto it = index.find(key);
        if (it != index.end()) return it->second;
        vertices.emplace_back(p.x(), y, p.y());
        return index[key] = static_cast<int>(vertices.size()) - 1;
    };
    std::vector<std::array<int, 3>> tris;
    for (const auto& c : cells) {
        P centroid = P::Zero();
        for (const auto& p : c) centroid += p / static_cast<double>(c.size());
        if (inside_footprint(centroid)) continue;
        std::vector<int> ids;
        for (const auto& p : c) {
            const int id = vertex(p);
            if (ids.empty() || ids.back() != id) ids.push_back(id);
        }
        while (ids.size() > 1 && ids.back() == ids.front()) ids.pop_back();
        for (std::size_t k = 1; k + 1 < ids.size(); ++k) {
            std::array<int, 3> t{ids[0], ids[k], ids[k + 1]};
            const Vec3 n = (vertices[t[1]] - vertices[t[0]]).cross(vertices[t[2]] - vertices[t[0]]);
            if (n.norm() < 1e-9) continue;
            if (n.dot(towards - vertices[t[0]]) < 0) std::swap(t[1], t[2]);
            tris.push_back(t);
        }
    }
    s.add_object(vertices, tris, material, "floor");
}

// A block (box with a top and four sides, no bottom) given its four bottom
// corners and its height; faces point away from its axis.
void add_block(Scene& s, const Vec3 base[4], double height, int material, const std::string& name) {
    Vec3 axis = Vec3::Zero();
    for (int i = 0; i < 4; ++i) axis += base[i] / 4.0;
    axis.y() = height / 2.0;
    const Vec3 up(0, height, 0);
    // Welded: 4 bottom + 4 top corners, so the block's edges stay conforming.
    std::vector<Vec3> v;
    for (int i = 0; i < 4; ++i) v.push_back(base[i]);
    for (int i = 0; i < 4; ++i) v.push_back(base[i] + up);
    std::vector<std::array<int, 3>> tris;
    auto quad = [&](int a, int b, int c, int d) {
        std::array<int, 3> t1{a, b, c}, t2{a, c, d};
        const Vec3 n = (v[b] - v[a]).cross(v[c] - v[a]);
        const Vec3 mid = (v[a] + v[b] + v[c] + v[d]) / 4.0;
        if (n.dot(mid - axis) < 0) {
            std::swap(t1[1], t1[2]);
            std::swap(t2[1], t2[2]);
        }
        tris.push_back(t1);
        tris.push_back(t2);
    };
    quad(4, 5, 6, 7);
    for (int i = 0; i < 4; ++i) quad(i, (i + 1) % 4, 4 + (i + 1) % 4, 4 + i);
    s.add_object(v, tris, material, name);
}

// The Cornell box (the Cornell program of computer graphics' measured geometry, in
// millimetres) with the usual RGB approximations of its materials.
//
// By default modelled as people model it: one full floor quad with the two blocks
// standing on it, one full ceiling quad with the light panel hanging 0.1 mm below it.
// Surfaces touch or nearly touch, so sorting patches by their centres (the painter)
// goes wrong there; the exact backends do not. `cut`: the version cut to fit the
// painter, with the floor cut around the blocks' footprints and the light set into
// the ceiling (a welded 3 x 3 grid whose centre cell is the light), so nothing overlaps.
Scene cornell_box(bool cut) {
    Scene s;
    s.name = cut ? "cornell-box-cut" : "cornell-box";
    const int white = s.add_material(make_material("white", Rgb(0.725, 0.71, 0.68)));
    const int red = s.add_material(make_material("red", Rgb(0.63, 0.065, 0.05)));
    const int green = s.add_material(make_material("green", Rgb(0.14, 0.45, 0.091)));
    const int light = s.add_material(make_material("light", Rgb(0.78, 0.78, 0.78), Rgb(17.0, 12.0, 4.0)));
    const Vec3 inside(278, 274, 280);

    const Vec3 floor_[4] = {{552.8, 0, 0}, {0, 0, 0}, {0, 0, 559.2}, {549.6, 0, 559.2}};
    const Vec3 back[4] = {{549.6, 0, 559.2}, {0, 0, 559.2}, {0, 548.8, 559.2}, {556, 548.8, 559.2}};
    const Vec3 right[4] = {{0, 0, 559.2}, {0, 0, 0}, {0, 548.8, 0}, {0, 548.8, 559.2}};
    const Vec3 left[4] = {{552.8, 0, 0}, {549.6, 0, 559.2}, {556, 548.8, 559.2}, {556, 548.8, 0}};
    add_quad(s, back, white, inside, "back wall");
    add_quad(s, right, green, inside, "right wall");
    add_quad(s, left, red, inside, "left wall");

    const double xs[4] = {0, 213, 343, 556}, zs[4] = {0, 227, 332, 559.2};
    if (cut) {
        // Ceiling: grid lines at the light's edges.
        std::vector<Vec3> cv;
        for (double z : zs)
            for (double x : xs) cv.emplace_back(x, 548.8, z);
        std::vector<std::array<int, 3>> ct;
        std::vector<int> cm;
        for (int j = 0; j < 3; ++j)
            for (int i = 0; i < 3; ++i) {
                const int a = j * 4 + i, b = a + 1, c = a + 5, d = a + 4;
                // Counter-clockwise seen from below (normal -y).
                ct.push_back({a, b, c});
                ct.push_back({a, c, d});
                const int m = (i == 1 && j == 1) ? light : white;
                cm.push_back(m);
                cm.push_back(m);
            }
        if ((cv[ct[0][1]] - cv[ct[0][0]]).cross(cv[ct[0][2]] - cv[ct[0][0]]).y() > 0)
            for (auto& t : ct) std::swap(t[1], t[2]);
        s.add_object(cv, ct, cm, "ceiling and light");
    } else {
        const Vec3 ceiling[4] = {{xs[0], 548.8, zs[0]}, {xs[3], 548.8, zs[0]}, {xs[3], 548.8, zs[3]},
                                 {xs[0], 548.8, zs[3]}};
        const Vec3 panel[4] = {{xs[1], 548.7, zs[1]}, {xs[2], 548.7, zs[1]}, {xs[2], 548.7, zs[2]},
                               {xs[1], 548.7, zs[2]}};
        add_quad(s, ceiling, white, inside, "ceiling");
        add_quad(s, panel, light, inside, "light");
    }

    const Vec3 short_block[4] = {{130, 0, 65}, {82, 0, 225}, {240, 0, 272}, {290, 0, 114}};
    const Vec3 tall_block[4] = {{423, 0, 247}, {265, 0, 296}, {314, 0, 456}, {472, 0, 406}};
    add_block(s, short_block, 165, white, "short block");
    add_block(s, tall_block, 330, white, "tall block");
    if (cut)
        add_floor(s, floor_,
                  {{short_block[0], short_block[1], short_block[2], short_block[3]},
                   {tall_block[0], tall_block[1], tall_block[2], tall_block[3]}},
                  white, inside);
    else
        add_quad(s, floor_, white, inside, "floor");

    s.camera.eye = Vec3(278, 273, -800);
    s.camera.target = Vec3(278, 273, 0);
    s.camera.up = Vec3(0, 1, 0);
    s.camera.fov_y = 39.3;
    s.camera.width = 512;
    s.camera.height = 512;
    return s;
}

// A fractal terrain (the paper's section 10 scenes, without the lake): a 16 km wide
// height field by midpoint displacement (diamond-square, fixed seed, roughness 0.5),
// sampled on a grid of cells about patch_size wide, lit by an emissive "moon" square
// hanging over it. The grid is built at the target size (conforming by construction),
// so the patch count follows the patch size: 2 * (16000 / patch_size)^2 triangles.
Scene fractal_terrain(double patch_size) {
    Scene s;
    s.name = "fractal-terrain";
    const int ground = s.add_material(make_material("ground", Rgb(0.45, 0.42, 0.35)));
    const int moon = s.add_material(make_material("moon", Rgb(0.5, 0.5, 0.5), Rgb(12.0, 11.4, 10.2)));
    constexpr int kLevels = 9, N = (1 << kLevels) + 1;  // 513 x 513 height samples
    constexpr double kSide = 16000.0, kRelief = 3000.0;
    std::vector<double> h(static_cast<std::size_t>(N) * N, 0.0);
    auto at = [&](int i, int j) -> double& { return h[static_cast<std::size_t>(j) * N + i]; };
    std::uint64_t state = 0x7e11a1;
    auto random = [&]() {  // splitmix64 in [-1, 1): fixed, platform-independent
        std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1.0p-52 - 1.0;
    };
    double amplitude = kRelief;
    for (int step = N - 1; step > 1; step /= 2, amplitude *= 0.5) {
        const int half = step / 2;
        for (int j = half; j < N; j += step)  // diamond
            for (int i = half; i < N; i += step)
                at(i, j) = 0.25 * (at(i - half, j - half) + at(i + half, j - half) + at(i - half, j + half) +
                                   at(i + half, j + half)) + amplitude * random();
        for (int j = 0; j < N; j += half)  // square
            for (int i = (j / half) % 2 == 0 ? half : 0; i < N; i += step) {
                double sum = 0.0;
                int count = 0;
                if (i >= half) sum += at(i - half, j), ++count;
                if (i + half < N) sum += at(i + half, j), ++count;
                if (j >= half) sum += at(i, j - half), ++count;
                if (j + half < N) sum += at(i, j + half), ++count;
                at(i, j) = sum / count + amplitude * random();
            }
    }
    auto height = [&](double x, double z) {  // bilinear in the sample grid
        const double fx = std::clamp(x / kSide, 0.0, 1.0) * (N - 1), fz = std::clamp(z / kSide, 0.0, 1.0) * (N - 1);
        const int i = std::min(static_cast<int>(fx), N - 2), j = std::min(static_cast<int>(fz), N - 2);
        const double tx = fx - i, tz = fz - j;
        return (1 - tx) * (1 - tz) * at(i, j) + tx * (1 - tz) * at(i + 1, j) + (1 - tx) * tz * at(i, j + 1) +
               tx * tz * at(i + 1, j + 1);
    };
    // Cells of side at most patch_size / sqrt(2), so that the diagonals respect it too.
    const int cells = std::max(1, static_cast<int>(std::ceil(kSide * std::sqrt(2.0) / patch_size)));
    std::vector<Vec3> v;
    for (int j = 0; j <= cells; ++j)
        for (int i = 0; i <= cells; ++i) {
            const double x = kSide * i / cells, z = kSide * j / cells;
            v.emplace_back(x, height(x, z), z);
        }
    std::vector<std::array<int, 3>> tris;
    for (int j = 0; j < cells; ++j)
        for (int i = 0; i < cells; ++i) {
            const int a = j * (cells + 1) + i, b = a + 1, c = a + cells + 2, d = a + cells + 1;
            // Counter-clockwise seen from above (+y): a, d, c and a, c, b.
            tris.push_back({a, d, c});
            tris.push_back({a, c, b});
        }
    s.add_object(v, tris, ground, "terrain");
    double top = -1e30;
    for (const auto& p : v) top = std::max(top, p.y());
    const Vec3 m0(5500, top + 2500, 5500), m1(7500, top + 2500, 5500), m2(7500, top + 2500, 7500),
        m3(5500, top + 2500, 7500);
    const Vec3 moon_quad[4] = {m0, m1, m2, m3};
    add_quad(s, moon_quad, moon, Vec3(6500, 0, 6500), "moon");
    s.camera.eye = Vec3(-6000, top + 6000, -6000);
    s.camera.target = Vec3(8000, 0, 8000);
    s.camera.up = Vec3(0, 1, 0);
    s.camera.fov_y = 45.0;
    s.camera.width = 640;
    s.camera.height = 480;
    s.finalize();
    return s;
}

}  // namespace

void add_quad(Scene& scene, const Vec3 corners[4], int material, const Vec3& towards, const std::string& name) {
    std::vector<Vec3> v(corners, corners + 4);
    std::array<int, 3> t1{0, 1, 2}, t2{0, 2, 3};
    const Vec3 n = (v[1] - v[0]).cross(v[2] - v[0]);
    if (n.dot(towards - v[0]) < 0) {
        std::swap(t1[1], t1[2]);
        std::swap(t2[1], t2[2]);
    }
    scene.add_object(v, {t1, t2}, material, name);
}

std::vector<BuiltinInfo> builtin_scenes() {
    return {
        {"homogeneous-box", "unit cube, albedo 0.5 and emission 0.5 everywhere: exact radiance 1", 0.2},
        {"cornell-box", "the Cornell box (mm) modelled as usual: blocks on a full floor, light panel under a full ceiling", 53.0},
        {"cornell-box-cut", "the Cornell box cut to fit the painter: floor cut around the blocks, light set into the ceiling", 53.0},
        {"fractal-terrain", "a 16 km fractal mountain range under an emissive square 'moon' (m)", 265.0},
    };
}

Scene make_builtin(const std::string& name, std::optional<double> patch_size, int threads,
                   const PreparationTeam* team, const MemoryShare& memory) {
    double default_size = 0.0;
    for (const auto& info : builtin_scenes())
        if (info.name == name) default_size = info.default_patch_size;
    const double size = patch_size.value_or(default_size);
    std::ostringstream line;
    line << "patch size " << size << (size == default_size ? " (the built-in scene's default)" : " (given)");
    // The scene made in place (a Scene assigned is its mesh copied: OpenMesh's kernel
    // has no move).
    auto made = [&]() -> Scene {
        if (name == "fractal-terrain") {
            if (!(size > 0.0) || !std::isfinite(size) || 2.0 * std::pow(16000.0 * std::sqrt(2.0) / size, 2) > 2e7)
                throw SceneError(name, "patch_size", "must be a positive number giving at most 20 million patches, got " +
                                                         std::to_string(size));
            return fractal_terrain(size);  // made at its patch size
        }
        if (name == "homogeneous-box") return homogeneous_box();
        if (name == "cornell-box" || name == "cornell-box-cut") return cornell_box(name == "cornell-box-cut");
        std::string known;
        for (const auto& info : builtin_scenes()) known += (known.empty() ? "" : ", ") + info.name;
        throw SceneError("", "", "unknown built-in scene '" + name + "' (known: " + known + ")");
    };
    Scene s = made();
    if (name == "fractal-terrain") {
        s.refinement = line.str();
        return s;
    }
    s.finalize(threads);
    refine_within(s, size, name, patch_budget(kMaxPatches, memory), threads, Finish::leave_mesh);  // the cuts finalize
    s.refinement = line.str();
    cut_at_contacts(s, threads, team);
    return s;
}

}  // namespace raybundle::scenes
