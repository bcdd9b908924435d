// Surfaces that touch inside one another's patches are cut apart (scenes/contacts.h):
// no patch lies on both sides of a contact, and nothing else is cut.
#include "scenes/builtin.h"
#include "scenes/contacts.h"
#include "scenes/loader.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

using namespace raybundle;
using scenes::Vec3;

namespace {

// A team of threads in one process, standing in for MPI ranks (render/ranks.h): every
// member's bytes reach every member when the last one arrives.
class ThreadTeam {
public:
    explicit ThreadTeam(int size) : size_(size), slots_(static_cast<std::size_t>(size)) {}

    struct Member final : scenes::PreparationTeam {
        Member(ThreadTeam& team, int rank) : team_(team), rank_(rank) {}
        int rank() const override { return rank_; }
        int size() const override { return team_.size_; }
        std::vector<std::vector<char>> gather_all(const std::vector<char>& mine) const override {
            return team_.exchange(rank_, mine);
        }
        ThreadTeam& team_;
        int rank_;
    };

private:
    std::vector<std::vector<char>> exchange(int rank, const std::vector<char>& mine) {
        std::unique_lock<std::mutex> lock(mutex_);
        const int round = round_;
        slots_[static_cast<std::size_t>(rank)] = mine;
        if (++arrived_ == size_) {
            // The round's result apart from the slots: the first member back may fill
            // its slot for the next round before the others have woken. The result is
            // replaced only when that round completes, which needs every member.
            result_ = slots_;
            arrived_ = 0;
            ++round_;
            done_.notify_all();
        } else {
            done_.wait(lock, [&] { return round_ != round; });
        }
        return result_;
    }

    int size_;
    std::vector<std::vector<char>> slots_, result_;
    std::mutex mutex_;
    std::condition_variable done_;
    int arrived_ = 0, round_ = 0;
};

// The same prepared scene, bit for bit: contacts, vertices, patches (corners, areas,
// normals, corner normals), total area and bounds.
void check_same_scene(const scenes::Scene& many, const scenes::Scene& one) {
    CHECK(many.contact_lines == one.contact_lines);
    CHECK(many.contact_splits == one.contact_splits);
    CHECK(many.contact_edges == one.contact_edges);
    REQUIRE(many.patch_count() == one.patch_count());
    CHECK(many.vertex_positions() == one.vertex_positions());
    bool same = true;
    for (std::size_t p = 0; p < one.patch_count(); ++p) {
        for (int k = 0; k < 3; ++k) same = same && many.patch_list()[p].v[k] == one.patch_list()[p].v[k];
        same = same && many.patch_list()[p].area == one.patch_list()[p].area &&
               many.patch_list()[p].normal == one.patch_list()[p].normal &&
               many.corner_normals()[p] == one.corner_normals()[p];
    }
    CHECK(same);
    CHECK(many.total_area() == one.total_area());
    CHECK(many.bounds_radius() == one.bounds_radius());
}

// body(member, rank) on each of `size` threads, as the members of one team; an
// exception a member throws is its entry of the result ("" where none).
std::vector<std::string> on_team(int size, const std::function<void(const ThreadTeam::Member&, std::size_t)>& body) {
    ThreadTeam team(size);
    std::vector<std::string> errors(static_cast<std::size_t>(size));
    std::vector<std::thread> members;
    for (int r = 0; r < size; ++r)
        members.emplace_back([&, r] {
            const ThreadTeam::Member me(team, r);
            try {
                body(me, static_cast<std::size_t>(r));
            } catch (const std::exception& e) {
                errors[static_cast<std::size_t>(r)] = e.what();
            }
        });
    for (auto& m : members) m.join();
    return errors;
}

// parse_scene on every member of a team of threads, each with its own scene text.
std::vector<std::string> load_together(const std::vector<std::string>& texts) {
    return on_team(static_cast<int>(texts.size()), [&](const ThreadTeam::Member& me, std::size_t r) {
        scenes::LoadLimits limits;
        limits.team = &me;
        scenes::parse_scene(texts[r], "s.json", ".", {}, limits);
    });
}

// parse_scene of one text on every member of a team of `size` threads (2 threads each).
std::vector<scenes::Scene> parse_together(const std::string& text, int size) {
    std::vector<scenes::Scene> scenes(static_cast<std::size_t>(size));
    for (const auto& e : on_team(size, [&](const ThreadTeam::Member& me, std::size_t r) {
             scenes::LoadLimits limits;
             limits.team = &me;
             limits.threads = 2;
             scenes[r] = scenes::parse_scene(text, "s.json", ".", {}, limits);
         }))
        CHECK(e.empty());
    return scenes;
}

// make_builtin on every member of a team of `size` threads, each with its own patch size.
std::vector<scenes::Scene> prepare_together(const std::vector<double>& patch_sizes, std::vector<std::string>& errors) {
    std::vector<scenes::Scene> scenes(patch_sizes.size());
    errors = on_team(static_cast<int>(patch_sizes.size()), [&](const ThreadTeam::Member& me, std::size_t r) {
        scenes[r] = scenes::make_builtin("cornell-box", patch_sizes[r], 2, &me);
    });
    return scenes;
}

// Patches of `object` whose inside the contact segment a-b runs through: a point of
// it (of 199 along it, ends excluded) strictly inside the patch (every barycentric
// coordinate above 1e-6), on its plane.
int crossed(const scenes::Scene& scene, const std::string& object, const Vec3& a, const Vec3& b) {
    int count = 0;
    const auto& pos = scene.vertex_positions();
    for (const auto& p : scene.patch_list()) {
        if (scene.object_names[p.object] != object) continue;
        const Vec3 &p0 = pos[p.v[0]], &p1 = pos[p.v[1]], &p2 = pos[p.v[2]];
        const Vec3 n = (p1 - p0).cross(p2 - p0);
        bool inside = false;
        for (int k = 1; k < 200 && !inside; ++k) {
            const Vec3 x = a + (b - a) * (k / 200.0);
            if (std::abs(p.normal.dot(x - p0)) > 1e-6) continue;
            const double w0 = n.dot((p2 - p1).cross(x - p1)) / n.squaredNorm();
            const double w1 = n.dot((p0 - p2).cross(x - p2)) / n.squaredNorm();
            inside = w0 > 1e-6 && w1 > 1e-6 && 1.0 - w0 - w1 > 1e-6;
        }
        count += inside;
    }
    return count;
}

double area_of(const scenes::Scene& scene, const std::string& object) {
    double a = 0.0;
    for (const auto& p : scene.patch_list())
        if (scene.object_names[p.object] == object) a += p.area;
    return a;
}

const char* kRooms = R"({
  "camera": {"eye": [1, 1.5, 1], "target": [6, 1, 2]},
  "materials": {"w": {"albedo": [0.5, 0.5, 0.5]}, "p": {"albedo": [0.5, 0.5, 0.5], "two_sided": true},
                "lamp": {"albedo": [0, 0, 0], "emission": [5, 5, 5]}},
  "objects": [
    {"quad": [[0, 0, 0], [0, 0, 4], [8, 0, 4], [8, 0, 0]], "material": "w", "name": "floor"},
    {"quad": [[0, 3, 0], [8, 3, 0], [8, 3, 4], [0, 3, 4]], "material": "w", "name": "ceiling"},
    {"quad": [[0, 0, 0], [8, 0, 0], [8, 3, 0], [0, 3, 0]], "material": "w", "name": "wall"},
    {"quad": [[4, 0, 0], [4, 0, 1.5], [4, 3, 1.5], [4, 3, 0]], "material": "p", "name": "partition"},
    {"quad": [[5.5, 2.999, 1.5], [6.5, 2.999, 1.5], [6.5, 2.999, 2.5], [5.5, 2.999, 2.5]], "material": "lamp", "name": "lamp"}
  ]%s
})";

scenes::Scene rooms(const std::string& extra = ", \"patch_size\": \"none\"") {
    char text[2048];
    std::snprintf(text, sizeof text, kRooms, extra.c_str());
    return scenes::parse_scene(text, "rooms.json", ".");
}

}  // namespace

TEST_CASE("contacts: a partition on a floor, against a wall and a ceiling cuts them along its edges",
          "[scenes][contacts]") {
    for (const std::string extra : {", \"patch_size\": \"none\"", ", \"patch_size\": 0.7"}) {
        const auto scene = rooms(extra);
        INFO(extra);
        CHECK(scene.contact_edges > 0);  // refined, the floor may already have edges at x = 4: marked, not cut
        // The partition's edges on the floor, the ceiling and the wall run along patch
        // edges, through no patch.
        CHECK(crossed(scene, "floor", {4, 0, 0}, {4, 0, 1.5}) == 0);
        CHECK(crossed(scene, "ceiling", {4, 3, 0}, {4, 3, 1.5}) == 0);
        CHECK(crossed(scene, "wall", {4, 0, 0}, {4, 3, 0}) == 0);
        // The lamp's outline on the ceiling (0.001 under it: a contact).
        const Vec3 lamp[4] = {{5.5, 3, 1.5}, {6.5, 3, 1.5}, {6.5, 3, 2.5}, {5.5, 3, 2.5}};
        for (int k = 0; k < 4; ++k) CHECK(crossed(scene, "ceiling", lamp[k], lamp[(k + 1) % 4]) == 0);
        // Cuts keep every surface whole: same areas, the partition and the lamp not cut.
        CHECK(area_of(scene, "floor") == Approx(32.0));
        CHECK(area_of(scene, "ceiling") == Approx(32.0));
        CHECK(area_of(scene, "wall") == Approx(24.0));
        if (extra.empty()) {
            CHECK(area_of(scene, "partition") == Approx(2 * 4.5));  // both sides
            int partition = 0, lamps = 0;
            for (const auto& p : scene.patch_list()) {
                partition += scene.object_names[p.object] == "partition";
                lamps += scene.object_names[p.object] == "lamp";
            }
            CHECK(partition == 4);  // two triangles, and their twins
            CHECK(lamps == 2);
        }
    }
    // Without the cut, a floor patch runs on under the partition.
    const auto kept = rooms(", \"cut_contacts\": false, \"patch_size\": \"none\"");
    CHECK(kept.contact_lines == 0);
    CHECK(crossed(kept, "floor", {4, 0, 0}, {4, 0, 1.5}) > 0);
}

TEST_CASE("contacts: the Cornell box as modelled is cut around its blocks and its light", "[scenes][contacts]") {
    const auto box = scenes::make_builtin("cornell-box");
    CHECK(box.contact_lines > 0);
    // The light panel's outline on the ceiling.
    const auto& pos = box.vertex_positions();
    double x0 = 1e300, x1 = -1e300, z0 = 1e300, z1 = -1e300;
    for (const auto& p : box.patch_list())
        if (box.object_names[p.object] == "light")
            for (int v : p.v) {
                x0 = std::min(x0, pos[v].x()), x1 = std::max(x1, pos[v].x());
                z0 = std::min(z0, pos[v].z()), z1 = std::max(z1, pos[v].z());
            }
    const double y = 548.8;  // the ceiling's height
    const Vec3 outline[4] = {{x0, y, z0}, {x1, y, z0}, {x1, y, z1}, {x0, y, z1}};
    for (int k = 0; k < 4; ++k) CHECK(crossed(box, "ceiling", outline[k], outline[(k + 1) % 4]) == 0);
    // The walls meet at the box's edges only: they are not cut.
    const auto cut_box = scenes::make_builtin("homogeneous-box");
    CHECK(cut_box.contact_lines == 0);
}

// A 10 x 10 floor of two triangles in a grey material `w` (material 0), not finalized.
scenes::Scene grey_floor() {
    scenes::Scene s;
    scenes::Material m;
    m.name = "w";
    m.albedo = scenes::Rgb::Constant(0.5);
    s.add_material(m);
    s.add_object({{0, 0, 0}, {0, 0, 10}, {10, 0, 10}, {10, 0, 0}}, {{{0, 1, 2}}, {{0, 2, 3}}}, 0, "floor");
    return s;
}

TEST_CASE("contacts: a block through a floor, a decal on a wall", "[scenes][contacts]") {
    scenes::Scene s = grey_floor();
    const int w = 0;
    // A vertical square crossing the floor (from y = -1 to 1) along z = 3, x 2..8.
    s.add_object({{2, -1, 3}, {8, -1, 3}, {8, 1, 3}, {2, 1, 3}}, {{{0, 1, 2}}, {{0, 2, 3}}}, w, "fin");
    // A decal 1e-6 above the floor, x 6..7, z 6..7.
    s.add_object({{6, 1e-6, 6}, {6, 1e-6, 7}, {7, 1e-6, 7}, {7, 1e-6, 6}}, {{{0, 1, 2}}, {{0, 2, 3}}}, w, "decal");
    s.finalize();
    const auto cuts = scenes::cut_at_contacts(s);
    CHECK(cuts.lines > 0);
    CHECK(crossed(s, "floor", {2, 0, 3}, {8, 0, 3}) == 0);
    CHECK(crossed(s, "fin", {2, 0, 3}, {8, 0, 3}) == 0);  // the fin is cut by the floor too
    const Vec3 decal[4] = {{6, 0, 6}, {6, 0, 7}, {7, 0, 7}, {7, 0, 6}};
    for (int k = 0; k < 4; ++k) CHECK(crossed(s, "floor", decal[k], decal[(k + 1) % 4]) == 0);
    CHECK(area_of(s, "floor") == Approx(100.0));
    CHECK(area_of(s, "fin") == Approx(12.0));
    // A second pass finds nothing left to cut.
    CHECK(scenes::cut_at_contacts(s).lines == 0);
}

TEST_CASE("contacts: many short contacts on one large patch cut it near them only", "[scenes][contacts]") {
    // 60 fins 0.1 long standing at scattered places and angles on a floor of two
    // triangles (patch_size "none"): each fin's contact cuts the pieces it reaches, not
    // every piece its line crosses, so the floor grows with the fins' count, not its
    // square (7,857 patches when each line crossed the whole floor). And every foot is
    // cut: the feet of fins 1, 43, 49 and 55 were not, where the other floor triangle's
    // cuts had split theirs along the diagonal before their turn.
    scenes::Scene s = grey_floor();
    const int fins = 60;
    std::vector<std::pair<Vec3, Vec3>> feet;  // each fin's ends on the floor
    for (int k = 0; k < fins; ++k) {
        const double x = 1.0 + 8.0 * std::fmod(0.618034 * k, 1.0), z = 1.0 + 8.0 * std::fmod(0.414214 * k + 0.1, 1.0);
        const double a = 2.399963 * k;
        const Vec3 half(0.05 * std::cos(a), 0, 0.05 * std::sin(a)), up(0, 0.2, 0);
        feet.emplace_back(Vec3(x, 0, z) - half, Vec3(x, 0, z) + half);
        const auto& [p, q] = feet.back();
        s.add_object({p, q, q + up, p + up}, {{{0, 1, 2}}, {{0, 2, 3}}}, 0, "fin");
    }
    s.finalize();
    scenes::cut_at_contacts(s);
    std::size_t floor = 0;
    for (const auto& p : s.patch_list()) floor += s.object_names[p.object] == "floor";
    INFO("floor patches " << floor);
    CHECK(floor < 12 * fins);
    CHECK(area_of(s, "floor") == Approx(100.0));
    // Every fin's foot is still a cut: each point of it lies on a floor patch's edge,
    // within the cut's snapping (vertices within 1e-3 of the patch's size, 0.0142 here,
    // count as on the line).
    const auto& pos = s.vertex_positions();
    const auto off_edges = [&](const Vec3& x) {  // the farthest x is inside a floor patch from its edges
        double worst = 0.0;
        for (const auto& p : s.patch_list()) {
            if (s.object_names[p.object] != "floor") continue;
            const Vec3 c[3] = {pos[p.v[0]], pos[p.v[1]], pos[p.v[2]]};
            const Vec3 n = (c[1] - c[0]).cross(c[2] - c[0]);
            double edge = std::numeric_limits<double>::infinity();
            bool inside = true;
            for (int e = 0; e < 3; ++e) {
                const Vec3 along = (c[(e + 1) % 3] - c[e]).normalized();
                const double d = n.normalized().cross(along).dot(x - c[e]);  // inward distance
                inside = inside && d > -1e-12;
                edge = std::min(edge, d);
            }
            if (inside) worst = std::max(worst, edge);
        }
        return worst;
    };
    for (int k = 0; k < fins; ++k) {
        const auto& [p, q] = feet[static_cast<std::size_t>(k)];
        double worst = 0.0;
        for (int j = 1; j < 20; ++j) worst = std::max(worst, off_edges(p + (q - p) * (j / 20.0)));
        INFO("fin " << k);
        CHECK(worst < 0.0142);
        CHECK(crossed(s, "floor", p, q) == 0);
    }
}

TEST_CASE("contacts: patches on either side of a contact share no vertex", "[scenes][contacts]") {
    const auto scene = rooms(", \"patch_size\": 0.5");
    // The floor's corners at the partition's foot (x = 4, 0 < z < 1.5): every flat
    // vertex there belongs to patches on one side only.
    const auto corners = scenes::vertex_corners(scene);
    const auto& pos = scene.vertex_positions();
    int on_contact = 0;
    for (std::size_t v = 0; v < pos.size(); ++v) {
        if (std::abs(pos[v].x() - 4.0) > 1e-9 || std::abs(pos[v].y()) > 1e-9 || pos[v].z() <= 1e-9 ||
            pos[v].z() >= 1.5 - 1e-9)
            continue;
        bool left = false, right = false;
        for (std::size_t c = corners.start[v]; c < corners.start[v + 1]; ++c) {
            const auto& p = scene.patch_list()[corners.corners[c] / 3];
            if (scene.object_names[p.object] != "floor") continue;
            (p.centroid.x() < 4.0 ? left : right) = true;
        }
        ++on_contact;
        CHECK_FALSE((left && right));
    }
    CHECK(on_contact >= 6);  // both sides' copies of the three vertices along it, at least
}

TEST_CASE("contacts: the sides part only along the contact, not along the rest of the cut", "[scenes][contacts]") {
    // A partition standing on the floor from z = 0 to 0.9 only: beyond it the floor is
    // open, and its vertices on the line x = 4 stay shared by both sides.
    std::string text = kRooms;
    text.replace(text.find("[4, 0, 1.5], [4, 3, 1.5]"), std::string("[4, 0, 1.5], [4, 3, 1.5]").size(),
                 "[4, 0, 0.9], [4, 3, 0.9]");
    char buf[2048];
    std::snprintf(buf, sizeof buf, text.c_str(), ", \"patch_size\": 0.25");
    const auto scene = scenes::parse_scene(buf, "rooms.json", ".");
    CHECK(crossed(scene, "floor", {4, 0, 0}, {4, 0, 0.9}) == 0);
    const auto corners = scenes::vertex_corners(scene);
    const auto& pos = scene.vertex_positions();
    int parted = 0, shared = 0;
    for (std::size_t v = 0; v < pos.size(); ++v) {
        if (std::abs(pos[v].x() - 4.0) > 1e-9 || std::abs(pos[v].y()) > 1e-9) continue;
        bool left = false, right = false;
        for (std::size_t c = corners.start[v]; c < corners.start[v + 1]; ++c) {
            const auto& p = scene.patch_list()[corners.corners[c] / 3];
            if (scene.object_names[p.object] == "floor") (p.centroid.x() < 4.0 ? left : right) = true;
        }
        const double z = pos[v].z();
        if (z > 0.05 && z < 0.85) {
            INFO("z = " << z << " on the contact");
            CHECK_FALSE((left && right));
            ++parted;
        }
        if (z > 0.95 && z < 3.9 && left && right) ++shared;
    }
    CHECK(parted >= 4);  // both sides' copies of the vertices at z = 0.25, 0.5, 0.75
    CHECK(shared >= 5);  // the open floor's vertices at z = 1, 1.25, ...
}

TEST_CASE("contacts: the search on several threads cuts the scene as one thread does", "[scenes][contacts]") {
    // The Cornell box refined, its blocks on the floor and its light under the
    // ceiling: every vertex, patch, area, corner normal and contact edge the same for 1,
    // 2 and 3 threads (Scene::finalize runs on them too).
    const auto one = scenes::make_builtin("cornell-box", 40.0, 1);
    REQUIRE(one.contact_lines > 0);
    for (const int threads : {2, 3}) {
        INFO(threads << " threads");
        check_same_scene(scenes::make_builtin("cornell-box", 40.0, threads), one);
    }
}

namespace {

// The flat vertices as one union-find over all corners makes them (Scene::finalize
// groups each vertex's corners on the threads instead): corners joined across every
// edge that is neither a contact edge nor a boundary, all of a vertex's corners joined
// where it is on no contact edge, numbered where face order first meets a group.
std::pair<std::vector<Vec3>, std::vector<std::array<int, 3>>> flat_vertices_in_one_pass(const scenes::Scene& s) {
    const auto& mesh = s.mesh;
    std::vector<int> parent(mesh.n_halfedges());
    for (std::size_t k = 0; k < parent.size(); ++k) parent[k] = static_cast<int>(k);
    std::function<int(int)> find = [&](int x) { return parent[x] == x ? x : parent[x] = find(parent[x]); };
    auto unite = [&](auto a, auto b) { parent[find(a.idx())] = find(b.idx()); };
    for (auto e : mesh.edges()) {
        if (mesh.property(s.contact_edge_handle, e) || mesh.is_boundary(e)) continue;
        const auto h = mesh.halfedge_handle(e, 0), o = mesh.halfedge_handle(e, 1);
        unite(h, mesh.prev_halfedge_handle(o));
        unite(mesh.prev_halfedge_handle(h), o);
    }
    for (auto v : mesh.vertices()) {
        bool on_contact = false;
        for (auto e : mesh.ve_range(v)) on_contact = on_contact || mesh.property(s.contact_edge_handle, e);
        if (on_contact) continue;
        scenes::TriMesh::HalfedgeHandle first;
        for (auto h : mesh.vih_range(v))
            if (mesh.face_handle(h).is_valid()) {
                if (first.is_valid()) unite(h, first);
                else first = h;
            }
    }
    std::vector<int> index(mesh.n_halfedges(), -1);
    std::vector<Vec3> positions;
    std::vector<std::array<int, 3>> patches;
    for (auto f : mesh.faces()) {
        std::array<int, 3> v{};
        int k = 0;
        for (auto h : mesh.fh_range(f)) {
            int& i = index[static_cast<std::size_t>(find(h.idx()))];
            if (i < 0) {
                i = static_cast<int>(positions.size());
                const auto p = mesh.point(mesh.to_vertex_handle(h));
                positions.emplace_back(p[0], p[1], p[2]);
            }
            v[static_cast<std::size_t>(k++)] = i;
        }
        patches.push_back(v);
    }
    return {positions, patches};
}

}  // namespace

TEST_CASE("contacts: each vertex's corners grouped on the threads number the flat vertices as one pass does",
          "[scenes][contacts]") {
    // The Cornell box (blocks on the floor, the light under the ceiling; 30k patches,
    // numbered in 8 blocks) and rooms with a partition: vertices split along contacts,
    // joined elsewhere, open boundaries.
    std::vector<std::pair<std::string, std::function<scenes::Scene(int)>>> cases = {
        {"cornell-box", [](int threads) { return scenes::make_builtin("cornell-box", 20.0, threads); }},
        {"rooms", [](int threads) {
             scenes::LoadLimits limits;
             limits.threads = threads;
             char buf[2048];
             std::snprintf(buf, sizeof buf, kRooms, ", \"patch_size\": 0.25");
             return scenes::parse_scene(buf, "rooms.json", ".", {}, limits);
         }}};
    for (const auto& [name, make] : cases)
        for (const int threads : {1, 3}) {
            INFO(name << " on " << threads << " threads");
            const auto scene = make(threads);
            REQUIRE(scene.contact_edges > 0);
            const auto [positions, patches] = flat_vertices_in_one_pass(scene);
            CHECK(scene.vertex_positions() == positions);
            REQUIRE(scene.patch_count() == patches.size());
            std::size_t differ = 0;
            for (std::size_t p = 0; p < patches.size(); ++p)
                for (int k = 0; k < 3; ++k) differ += scene.patch_list()[p].v[k] != patches[p][static_cast<std::size_t>(k)];
            CHECK(differ == 0);
            CHECK(positions.size() > scene.mesh.n_vertices());  // some vertices split at contacts
        }
}

TEST_CASE("contacts: a team's members each search a share and make the scene one process makes", "[scenes][contacts]") {
    // Ranks split the contact search (scenes/team.h) and swap their lines: every member
    // must end with the scene one process makes, vertex for vertex.
    const auto one = scenes::make_builtin("cornell-box", 40.0, 1);
    for (const int size : {2, 3}) {
        INFO(size << " members");
        std::vector<std::string> errors;
        const auto all = prepare_together(std::vector<double>(static_cast<std::size_t>(size), 40.0), errors);
        for (int r = 0; r < size; ++r) {
            INFO("member " << r);
            REQUIRE(errors[static_cast<std::size_t>(r)].empty());
            check_same_scene(all[static_cast<std::size_t>(r)], one);
        }
    }
    // Members whose scenes differ (another file on another node) stop, each with a line
    // that says so, instead of cutting with another member's lines.
    std::vector<std::string> errors;
    prepare_together({40.0, 60.0}, errors);
    for (const auto& e : errors)
        CHECK_THAT(e, Catch::Contains("the ranks' scenes differ: rank 1 has") && Catch::Contains("rank 0"));
    // The same triangle count elsewhere, and a scene not cut at contacts beside one that
    // is: also one line each, not wrong cuts or exchanges that do not match.
    const auto scene = [](double x, bool cut) {
        return std::string(R"({"camera": {"eye": [0.5, 0.5, 3], "target": [0.5, 0.5, 0]}, "patch_size": "none",)") +
               (cut ? "" : R"("cut_contacts": false,)") +
               R"("materials": {"m": {"albedo": [0.5, 0.5, 0.5]}}, "objects": [{"quad": [[0, 0, 0], [)" +
               std::to_string(x) + R"(, 0, 0], [1, 1, 0], [0, 1, 0]], "material": "m"}]})";
    };
    for (const auto& e : load_together({scene(1.0, true), scene(1.5, true)}))
        CHECK_THAT(e, Catch::Contains("the ranks' scenes differ: rank 1's triangles lie elsewhere than rank 0's"));
    for (const auto& e : load_together({scene(1.0, true), scene(1.0, false)}))
        CHECK_THAT(e, Catch::Contains("rank 1 does not cut at contacts") && Catch::Contains("rank 0 has 2 triangles"));
    for (const auto& e : load_together({scene(1.0, false), scene(1.0, false)})) CHECK(e.empty());
    for (const auto& e : load_together({scene(1.0, true), scene(1.0, true)})) CHECK(e.empty());
}

TEST_CASE("contacts: large and small triangles (two grids) cut the same on any threads and teams", "[scenes][contacts]") {
    // A floor of two triangles 14 long with 40 fins of 0.1 x 0.2 standing on it and 10
    // leaning on a wall, as modelled: the floor and the wall are searched in the coarse
    // grid, the fins in the fine one, and the floor's and wall's lines come from the fins
    // that found them: the same for 1, 2 and 3 threads and for teams of 2 and 3.
    std::string objects = R"({"quad": [[0, 0, 0], [0, 0, 10], [10, 0, 10], [10, 0, 0]], "material": "m", "name": "floor"},
                             {"quad": [[0, 0, 0], [10, 0, 0], [10, 3, 0], [0, 3, 0]], "material": "m", "name": "wall"})";
    for (int k = 0; k < 50; ++k) {
        const double x = 1.0 + 8.0 * std::fmod(0.618034 * k, 1.0), z = 1.0 + 8.0 * std::fmod(0.414214 * k + 0.1, 1.0);
        const double a = 2.399963 * k, c = 0.05 * std::cos(a), d = 0.05 * std::sin(a);
        char fin[256];
        if (k < 40)  // standing on the floor
            std::snprintf(fin, sizeof fin, R"(, {"quad": [[%g, 0, %g], [%g, 0, %g], [%g, 0.2, %g], [%g, 0.2, %g]], "material": "m"})",
                          x - c, z - d, x + c, z + d, x + c, z + d, x - c, z - d);
        else  // against the wall
            std::snprintf(fin, sizeof fin, R"(, {"quad": [[%g, %g, 0], [%g, %g, 0], [%g, %g, 0.2], [%g, %g, 0.2]], "material": "m"})",
                          x - c, 1 + d, x + c, 1 - d, x + c, 1 - d, x - c, 1 + d);
        objects += fin;
    }
    const std::string text = R"({"camera": {"eye": [5, 1.5, 9], "target": [5, 0, 5]}, "patch_size": "none",
                                 "materials": {"m": {"albedo": [0.5, 0.5, 0.5]}}, "objects": [)" + objects + "]}";
    const scenes::Scene one = scenes::parse_scene(text, "s.json", ".");
    // Every fin's foot is a line on the floor or the wall (the fins' own sides end there:
    // no line on them), and fin 49's on each of the wall's two triangles (it crosses
    // their diagonal): 51.
    CHECK(one.contact_lines == 51);
    for (const int threads : {2, 3}) {
        INFO(threads << " threads");
        scenes::LoadLimits limits;
        limits.threads = threads;
        check_same_scene(scenes::parse_scene(text, "s.json", ".", {}, limits), one);
    }
    for (const int size : {2, 3}) {
        const auto all = parse_together(text, size);
        for (int r = 0; r < size; ++r) {
            INFO(size << " members, member " << r);
            check_same_scene(all[static_cast<std::size_t>(r)], one);
        }
    }
}

TEST_CASE("memory: ranks on one machine share it, and every member takes the least share", "[scenes][team][memory]") {
    using scenes::memory_share;
    constexpr std::uint64_t GB = 1000000000;
    // Alone: the machine's memory.
    const scenes::MemoryShare alone = memory_share();
    CHECK(alone.bytes == scenes::memory_available());
    CHECK(alone.sharing == 1);
    CHECK_THAT(alone.text(), Catch::StartsWith("this machine has "));
    // Two ranks on a 16 GB machine (8 GB each) and one on a 6 GB machine: 6 GB for all.
    scenes::MemoryShare least = memory_share({{"a", 16 * GB}, {"b", 6 * GB}, {"a", 16 * GB}});
    CHECK(least.bytes == 6 * GB);
    CHECK(least.text() == "the machine b has 6.0 GB for 1 rank");
    // Three ranks on the 16 GB machine: 5.33 GB each, below the other's 6.
    least = memory_share({{"a", 16 * GB}, {"b", 6 * GB}, {"a", 16 * GB}, {"a", 16 * GB}});
    CHECK(least.bytes == 16 * GB / 3);
    CHECK(least.sharing == 3);
    CHECK(least.text() == "the machine a has 16.0 GB for 3 ranks");
    // Members of one machine that read different limits (their own control groups): the
    // least of them, shared.
    CHECK(memory_share({{"a", 16 * GB}, {"a", 12 * GB}}).bytes == 6 * GB);
    // A machine whose memory cannot be read bounds nothing; none readable: no bound.
    CHECK(memory_share({{"a", 0}, {"b", 4 * GB}}).bytes == 4 * GB);
    CHECK(memory_share({{"a", 0}, {"b", 0}}).bytes == 0);
    // A team of threads in one process is on one machine: each member gets a third,
    // every member the same.
    std::vector<scenes::MemoryShare> shares(3);
    for (const auto& e : on_team(3, [&](const ThreadTeam::Member& me, std::size_t r) { shares[r] = memory_share(&me); }))
        CHECK(e.empty());
    for (const auto& share : shares) {
        CHECK(share.bytes == scenes::memory_available() / 3);
        CHECK(share.sharing == 3);
        CHECK(share.host == shares[0].host);
    }
    // The patch limit says whose memory bounds it.
    scenes::LoadLimits limits;
    limits.memory = {100 * 1200, 300 * 1200, 3, "node1"};
    const std::string quad = R"({"camera": {"eye": [0.5, 0.5, 3], "target": [0.5, 0.5, 0]},
        "materials": {"w": {"albedo": [0.5, 0.5, 0.5], "emission": [1, 1, 1]}},
        "objects": [{"quad": [[0,0,0], [1,0,0], [1,1,0], [0,1,0]], "material": "w"}], "patch_size": 0.05})";
    CHECK_THROWS_WITH(scenes::parse_scene(quad, "s.json", ".", {}, limits),
                      Catch::Contains("(limit 100: about 1.2 KB each while the scene is prepared, and the machine node1 has 360 KB for 3 ranks)"));
}
