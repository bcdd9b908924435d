#include "scenes/contacts.h"

#include "scenes/errors.h"
#include "scenes/sorted_cells.h"
#include "scenes/subdivide.h"
#include "scenes/threads.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <stdexcept>
#include <string>
#include <limits>
#include <optional>
#include <vector>

namespace raybundle::scenes {

namespace {

// An axis-aligned box (Eigen's AlignedBox writes itself empty when made: this one is
// left unwritten until filled, see scenes/buffer.h).
struct Box {
    Vec3 lo, hi;
    bool meets(const Box& b) const { return (lo.array() <= b.hi.array()).all() && (b.lo.array() <= hi.array()).all(); }
};

struct Tri {
    std::array<Vec3, 3> p;
    Vec3 n;          // unit
    double offset;   // plane: n . x = offset
    double size;     // longest edge
    std::array<bool, 3> region_edge;  // edge p[k] -> p[k+1] ends its planar region
};

// A contact in a patch's plane: the segment from `at` along `along` (unit) for
// `length`; `cut`: it runs through the patch's inside (cut the patch along it), else
// along an edge the patch shares with a coplanar neighbour (mark it only).
struct Line {
    Vec3 at, along;
    double length;
    bool cut;
};

// Where segment a-b (in u's plane) meets triangle u: its part inside u, through u's
// inside or along an edge of u that a coplanar neighbour shares; nothing else (a
// corner, an edge of the region, outside).
std::optional<Line> contact_in(const Tri& u, const Vec3& a, const Vec3& b, double tol) {
    double lo = 0.0, hi = 1.0;
    const Vec3 d = b - a;
    std::array<Vec3, 3> inward;
    for (int k = 0; k < 3; ++k) {
        const Vec3 e = u.p[(k + 1) % 3] - u.p[k];
        inward[k] = u.n.cross(e).normalized();  // counter-clockwise about n: the inside is to the left
        // Keep the part with inward . (x - p_k) >= -tol.
        const double s0 = inward[k].dot(a - u.p[k]) + tol, sd = inward[k].dot(d);
        if (std::abs(sd) < 1e-300) {
            if (s0 < 0.0) return std::nullopt;
            continue;
        }
        const double t = -s0 / sd;
        if (sd > 0.0)
            lo = std::max(lo, t);
        else
            hi = std::min(hi, t);
    }
    const double length = (hi - lo) * d.norm();
    if (!(length > tol)) return std::nullopt;
    const Vec3 mid = a + 0.5 * (lo + hi) * d;
    Line line{a + lo * d, d.normalized(), length, true};
    for (int k = 0; k < 3; ++k)
        if (inward[k].dot(mid - u.p[k]) <= tol) {  // along edge k
            if (u.region_edge[k]) return std::nullopt;
            line.cut = false;
        }
    return line;
}

// The contact lines that triangle t makes in triangle u (see the header), surfaces
// nearer than `contact` touching.
void contacts(const Tri& u, const Tri& t, double contact, double tol, std::vector<Line>& out) {
    std::array<double, 3> d;
    for (int k = 0; k < 3; ++k) d[k] = u.n.dot(t.p[k]) - u.offset;
    const double lo = std::min({d[0], d[1], d[2]}), hi = std::max({d[0], d[1], d[2]});
    if (lo > contact || hi < -contact) return;
    auto project = [&](const Vec3& x) -> Vec3 { return x - (u.n.dot(x) - u.offset) * u.n; };
    auto add = [&](const Vec3& a, const Vec3& b) {
        if (const auto line = contact_in(u, a, b, tol)) out.push_back(*line);
    };
    if (lo >= -contact && hi <= contact) {
        // Parallel: t lies at u's plane; its region's end edges cut u.
        for (int k = 0; k < 3; ++k)
            if (t.region_edge[k]) add(project(t.p[k]), project(t.p[(k + 1) % 3]));
        return;
    }
    // Transversal: the vertices near the plane and the edges' crossings of it.
    std::vector<Vec3> points;
    for (int k = 0; k < 3; ++k) {
        const int j = (k + 1) % 3;
        if (std::abs(d[k]) <= contact) points.push_back(project(t.p[k]));
        if (std::abs(d[k]) > contact && std::abs(d[j]) > contact && d[k] * d[j] < 0.0)
            points.push_back(project(t.p[k] + d[k] / (d[k] - d[j]) * (t.p[j] - t.p[k])));
    }
    if (points.size() < 2) return;
    std::size_t a = 0, b = 1;  // the two farthest apart
    for (std::size_t i = 0; i < points.size(); ++i)
        for (std::size_t j = i + 1; j < points.size(); ++j)
            if ((points[i] - points[j]).squaredNorm() > (points[a] - points[b]).squaredNorm()) a = i, b = j;
    add(points[a], points[b]);
}

// Whether a triangle meets the box of centre `centre` and half-size `half` (separating
// axes: the box's three, the triangle's normal, the nine crosses of an edge with an
// axis), slightly grown so that rounding never drops a triangle that touches it.
bool meets_box(const std::array<Vec3, 3>& p, const Vec3& centre, const Vec3& half) {
    const std::array<Vec3, 3> v = {p[0] - centre, p[1] - centre, p[2] - centre};
    const double slack = 1e-9 * (half.maxCoeff() + v[0].cwiseAbs().maxCoeff());
    auto separates = [&](const Vec3& axis) {
        const double r = half.dot(axis.cwiseAbs()) + slack * axis.cwiseAbs().sum();
        const double a = axis.dot(v[0]), b = axis.dot(v[1]), c = axis.dot(v[2]);
        return std::min({a, b, c}) > r || std::max({a, b, c}) < -r;
    };
    for (int k = 0; k < 3; ++k)
        if (separates(Vec3::Unit(k))) return false;
    const std::array<Vec3, 3> e = {v[1] - v[0], v[2] - v[1], v[0] - v[2]};
    if (separates(e[0].cross(e[1]))) return false;
    for (const Vec3& edge : e)
        for (int k = 0; k < 3; ++k)
            if (separates(edge.cross(Vec3::Unit(k)))) return false;
    return true;
}

using Cell = Eigen::Array<long, 3, 1>;  // a grid cell's integer coordinates

// The cells (integer coordinates) of the block lo..hi (inclusive) whose boxes, grown by
// `grow`, the triangle meets: the block's box tested first, then its halves, so that a
// sliver across many cells costs tests along it, not over its bounding box.
void list_cells(const std::array<Vec3, 3>& p, const Cell& lo, const Cell& hi, double cell,
                double grow, std::vector<Cell>& out) {
    const Vec3 a = lo.cast<double>().matrix() * cell, b = (hi + 1).cast<double>().matrix() * cell;
    if (!meets_box(p, 0.5 * (a + b), 0.5 * (b - a) + Vec3::Constant(grow))) return;
    Eigen::Index axis = 0;
    if ((hi - lo).maxCoeff(&axis) == 0) {
        out.push_back(lo);
        return;
    }
    const long mid = lo[axis] + (hi[axis] - lo[axis]) / 2;
    Cell split = hi;
    split[axis] = mid;
    list_cells(p, lo, split, cell, grow, out);
    split = lo;
    split[axis] = mid + 1;
    list_cells(p, split, hi, cell, grow, out);
}

// Bytes for PreparationTeam::gather_all: each of a member's items in turn, as its count
// and its values (plain data: every member runs the same binary).
template <class T>
void pack(std::vector<char>& out, const std::vector<T>& values) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto count = static_cast<std::uint32_t>(values.size());
    const auto* c = reinterpret_cast<const char*>(&count);
    out.insert(out.end(), c, c + sizeof count);
    const auto* v = reinterpret_cast<const char*>(values.data());
    out.insert(out.end(), v, v + values.size() * sizeof(T));
}

template <class T>
void unpack(const std::vector<char>& in, std::size_t& at, std::vector<T>& values, const char* what) {
    static_assert(std::is_trivially_copyable_v<T>);
    std::uint32_t count = 0;
    if (in.size() - at < sizeof count) throw std::runtime_error(std::string("contact search: ") + what + " cut short");
    std::memcpy(&count, in.data() + at, sizeof count);
    at += sizeof count;
    if ((in.size() - at) / sizeof(T) < count) throw std::runtime_error(std::string("contact search: ") + what + " cut short");
    values.resize(count);
    if (count > 0) std::memcpy(static_cast<void*>(values.data()), in.data() + at, count * sizeof(T));
    at += count * sizeof(T);
}

// A line as plain numbers (a Vec3 is not plain data everywhere): at, along, length, cut.
using PackedLine = std::array<double, 8>;
PackedLine packed(const Line& l) {
    return {l.at.x(), l.at.y(), l.at.z(), l.along.x(), l.along.y(), l.along.z(), l.length, l.cut ? 1.0 : 0.0};
}
Line unpacked(const PackedLine& p) { return {Vec3(p[0], p[1], p[2]), Vec3(p[3], p[4], p[5]), p[6], p[7] != 0.0}; }

// What a member's shares begin with: its triangle count and a fingerprint of their
// corners, or kNoSearch where its scene is not cut at contacts. Members whose scenes
// differ (another file on another node) stop, each with the same line (SceneError
// naming `shown`), before any of them cuts with another's lines.
struct ShareHeader {
    std::uint64_t triangles;
    std::uint64_t fingerprint;
};
constexpr std::uint64_t kNoSearch = ~std::uint64_t{0};

std::uint64_t fingerprint(const Buffer<Tri>& tris) {
    std::uint64_t h = 0x9E3779B97F4A7C15ull;
    for (const Tri& t : tris)
        for (const Vec3& p : t.p)
            for (int k = 0; k < 3; ++k) {
                std::uint64_t bits = 0;
                const double x = p[k];
                std::memcpy(&bits, &x, sizeof bits);
                h = (h ^ bits) * 0x100000001B3ull;
                h ^= h >> 29;
            }
    return h;
}

void check_headers(const std::vector<std::vector<char>>& all, const std::string& shown) {
    auto header = [&all](std::size_t k) {
        ShareHeader h{0, 0};
        if (all[k].size() >= sizeof h) std::memcpy(&h, all[k].data(), sizeof h);
        return h;
    };
    const ShareHeader first = header(0);
    for (std::size_t k = 1; k < all.size(); ++k) {
        const ShareHeader h = header(k);
        if (h.triangles == first.triangles && h.fingerprint == first.fingerprint) continue;
        const auto says = [](std::size_t r, const ShareHeader& x) {
            return x.triangles == kNoSearch ? "rank " + std::to_string(r) + " does not cut at contacts (\"cut_contacts\")"
                                            : "rank " + std::to_string(r) + " has " + std::to_string(x.triangles) +
                                                  " triangles to search for contacts";
        };
        const std::string what = h.triangles != first.triangles
                                     ? says(k, h) + ", " + says(0, first)
                                     : "rank " + std::to_string(k) + "'s triangles lie elsewhere than rank 0's";
        throw SceneError(shown, "", "the ranks' scenes differ: " + what +
                                        "; every node must read the same scene file and be given the same options");
    }
}

// Every member's share of per-triangle lists (member k: triangles k, k + R, ...) on every
// member, after the headers agree.
template <class T>
void swap_shares(const PreparationTeam& team, const ShareHeader& header, std::vector<std::vector<T>>& lists,
                 const char* what, const std::string& shown) {
    const auto R = static_cast<std::size_t>(team.size());
    std::vector<char> mine(sizeof header);
    std::memcpy(mine.data(), &header, sizeof header);
    for (std::size_t i = static_cast<std::size_t>(team.rank()); i < lists.size(); i += R) pack(mine, lists[i]);
    const auto all = team.gather_all(mine);
    check_headers(all, shown);
    for (std::size_t k = 0; k < all.size(); ++k) {
        if (static_cast<int>(k) == team.rank()) continue;
        std::size_t at = sizeof header;
        for (std::size_t i = k; i < lists.size(); i += R) unpack(all[k], at, lists[i], what);
    }
}

// The contact lines of every triangle (see the header), surfaces nearer than `widest`
// (and 1e-2 of the smaller triangle's size) touching.
//
// Partners: triangles whose boxes, each grown by its reach (below), intersect, and that meet a common
// cell of a hashed grid (each triangle listed in the cells it meets once they are grown,
// not in every cell of its box: a sliver across the scene meets a line of cells, its box
// a block of them). The cells are the median triangle's size (at least `widest`, at
// most 1/32 of the scene), or larger where the surface would cover more than 4 of them
// per triangle; triangles larger than 4 cells go to a second, coarser grid (below). A
// triangle's lines come from its partners in index order, whatever the cells' size.
// Triangles on the threads; on a team, each member lists the cells of its share of the
// triangles and finds their lines, and the shares (and the pairs of the two grids) are
// swapped.
std::vector<std::vector<Line>> contact_lines(const Buffer<Tri>& tris, double widest, double radius, double tol,
                                             int threads, const PreparationTeam* team, const std::string& shown) {
    const int n = static_cast<int>(tris.size());
    if (n == 0) return {};  // (the loader refuses a scene without patches)
    const int members = team ? team->size() : 1, me = team ? team->rank() : 0;
    const int mine = (n - me + members - 1) / members;  // my triangles: me + k members
    auto triangle = [&](int k) { return static_cast<std::size_t>(me) + static_cast<std::size_t>(k) * members; };

    // The triangles' sizes and areas on the threads; the areas summed in order.
    Buffer<double> sizes(tris.size()), areas(tris.size());
    parallel_chunks(n, threads, [&](int i0, int i1) {
        for (int i = i0; i < i1; ++i) {
            const Tri& t = tris[static_cast<std::size_t>(i)];
            sizes[static_cast<std::size_t>(i)] = t.size;
            areas[static_cast<std::size_t>(i)] = 0.5 * (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).norm();
        }
    });
    std::nth_element(sizes.begin(), sizes.begin() + static_cast<long>(sizes.size() / 2), sizes.end());
    // At least so large that the surface covers about 4 cells per triangle: in cells of
    // 1/128 of the scene, each wall of a coarse room of a few dozen triangles was
    // listed in some 16k cells (0.6 s of the Cornell box's preparation).
    double area = 0.0;
    for (const double a : areas) area += a;
    const double by_area = std::sqrt(area / (4.0 * static_cast<double>(std::max<std::size_t>(1, tris.size()))));
    const double cell = std::max(std::clamp(sizes[sizes.size() / 2], std::max(widest, 1e-12 * radius), radius / 32.0),
                                 std::min(by_area, radius));
    Buffer<Box> boxes(tris.size());  // each written by its band
    // A triangle's reach: two touch where one lies within min(widest, 1e-2 of the
    // smaller's size) of the other's plane and inside it within tol (contacts()), so each
    // grown by its own min(widest, 1e-2 of its size) + tol meet in a box and a cell. Grown
    // by `widest` alone, a statue's 5 mm triangles in a room of 3 m radius reached 3 mm
    // around them, into 27 cells each and their neighbours' neighbours.
    auto grow = [&](std::size_t i) { return std::min(widest, 1e-2 * tris[i].size) + tol; };
    // The grown boxes, and the block they span, per band of triangles on the threads.
    const int bands = std::max(1, std::min(threads, n));
    std::vector<Vec3> band_lo(static_cast<std::size_t>(bands), Vec3::Constant(std::numeric_limits<double>::infinity()));
    std::vector<Vec3> band_hi(static_cast<std::size_t>(bands), Vec3::Constant(-std::numeric_limits<double>::infinity()));
    run_threads(bands, [&](int t) {
        const auto b = static_cast<std::size_t>(t);
        const auto i0 = static_cast<std::size_t>(static_cast<long long>(n) * t / bands);
        const auto i1 = static_cast<std::size_t>(static_cast<long long>(n) * (t + 1) / bands);
        Vec3 lo = band_lo[b], hi = band_hi[b];  // (in registers: the bands' entries share a cache line)
        for (std::size_t i = i0; i < i1; ++i) {
            const auto& p = tris[i].p;
            Box& box = boxes[i];
            const double g = grow(i);
            box.lo = (p[0].cwiseMin(p[1]).cwiseMin(p[2]).array() - g).matrix();
            box.hi = (p[0].cwiseMax(p[1]).cwiseMax(p[2]).array() + g).matrix();
            lo = lo.cwiseMin(box.lo);
            hi = hi.cwiseMax(box.hi);
        }
        band_lo[b] = lo;
        band_hi[b] = hi;
    });
    Vec3 scene_lo = band_lo[0], scene_hi = band_hi[0];
    for (int b = 1; b < bands; ++b) scene_lo = scene_lo.cwiseMin(band_lo[b]), scene_hi = scene_hi.cwiseMax(band_hi[b]);

    // Two grids: the small triangles in cells of `cell`, and the triangles larger than 4
    // of them in cells of the large ones' median size (at least 4 small cells). One grid
    // of the small size listed each 0.16 m patch of a room in a thousand cells around a
    // statue of 5 mm triangles (a third of its preparation). A small triangle finds its
    // small partners in the first grid and its large ones in the second, where it is
    // listed after the large (its cells' runs: the large first, in index order); a large
    // triangle finds the large in the second, and the small ones find it.
    const double large_above = 4.0 * cell;
    std::vector<std::uint32_t> large, small;  // the triangles of each kind, ascending
    std::vector<std::uint32_t> index_in(tris.size());  // a triangle's place in its kind's list
    for (std::size_t i = 0; i < tris.size(); ++i) {
        auto& kind = tris[i].size > large_above ? large : small;
        index_in[i] = static_cast<std::uint32_t>(kind.size());
        kind.push_back(static_cast<std::uint32_t>(i));
    }
    auto is_large = [&](std::size_t i) { return tris[i].size > large_above; };
    double large_cell = large_above;
    if (!large.empty()) {
        std::vector<double> large_sizes(large.size());
        for (std::size_t j = 0; j < large.size(); ++j) large_sizes[j] = tris[large[j]].size;
        std::nth_element(large_sizes.begin(), large_sizes.begin() + static_cast<long>(large_sizes.size() / 2),
                         large_sizes.end());
        large_cell = std::clamp(large_sizes[large_sizes.size() / 2], large_above, std::max(large_above, radius / 4.0));
    }
    // A grid's cells numbered densely over the scene's block where the count stays below
    // 2^53 (a short key sorts in few passes); else 21 bits per axis (cells that share a
    // key by a wrap of its bits only add partners whose boxes are then tested).
    struct Grid {
        double cell;
        Cell lo;
        Eigen::Array3d extent;
        bool dense;
        std::uint64_t key(const Cell& c) const {
            if (dense) {
                const Cell d = c - lo;
                return (static_cast<std::uint64_t>(d.x()) * static_cast<std::uint64_t>(extent.y()) +
                        static_cast<std::uint64_t>(d.y())) *
                           static_cast<std::uint64_t>(extent.z()) +
                       static_cast<std::uint64_t>(d.z());
            }
            return (static_cast<std::uint64_t>(c.x() & 0x1fffff) << 42) |
                   (static_cast<std::uint64_t>(c.y() & 0x1fffff) << 21) | static_cast<std::uint64_t>(c.z() & 0x1fffff);
        }
        // The keys of the cells triangle t meets once they are grown by `reach`.
        void list(const Tri& t, const Box& box, double reach, std::vector<Cell>& met, std::vector<std::uint64_t>& out) const {
            met.clear();
            list_cells(t.p, (box.lo.array() / cell).floor().cast<long>(), (box.hi.array() / cell).floor().cast<long>(),
                       cell, reach, met);
            out.resize(met.size());
            std::transform(met.begin(), met.end(), out.begin(), [this](const Cell& c) { return key(c); });
        }
    };
    auto grid = [&](double side) {
        Grid g{side, (scene_lo.array() / side).floor().cast<long>(), {}, false};
        g.extent = ((scene_hi.array() / side).floor().cast<long>() - g.lo).cast<double>() + 1.0;
        g.dense = n > 0 && g.extent.prod() < 0x1p53;
        return g;
    };
    const Grid fine = grid(cell), coarse = grid(large_cell);
    // The small triangles' cells in the first grid (a large one's list empty), and in the
    // second every large triangle's cells, then every small one's (items: large[0 ..],
    // then small[0 ..]). A member lists its share of each; the shares are swapped.
    std::vector<std::vector<std::uint64_t>> listed(tris.size());
    parallel_chunks(mine, threads, [&](int k0, int k1) {
        std::vector<Cell> met;
        for (int k = k0; k < k1; ++k) {
            const std::size_t i = triangle(k);
            if (!is_large(i)) fine.list(tris[i], boxes[i], grow(i), met, listed[i]);
        }
    });
    const std::size_t L = large.size();
    std::vector<std::vector<std::uint64_t>> listed_coarse(L > 0 ? tris.size() : 0);
    auto item_triangle = [&](std::size_t j) { return j < L ? large[j] : small[j - L]; };
    if (L > 0) {
        const int items = (n - me + members - 1) / members;
        parallel_chunks(items, threads, [&](int k0, int k1) {
            std::vector<Cell> met;
            for (int k = k0; k < k1; ++k) {
                const std::size_t j = static_cast<std::size_t>(me) + static_cast<std::size_t>(k) * members;
                const std::size_t i = item_triangle(j);
                coarse.list(tris[i], boxes[i], grow(i), met, listed_coarse[j]);
            }
        });
    }
    const ShareHeader header{tris.size(), members > 1 ? fingerprint(tris) : 0};
    if (members > 1) {
        swap_shares(*team, header, listed, "cells", shown);
        if (L > 0) swap_shares(*team, header, listed_coarse, "cells", shown);
    }
    const SortedCells cells(listed, threads);
    const SortedCells coarse_cells(listed_coarse, threads);
    listed = {};
    listed_coarse = {};

    std::vector<std::vector<Line>> lines(tris.size());
    auto find_lines = [&](std::uint32_t u, const std::vector<std::uint32_t>& partners) {
        const Tri& a = tris[u];
        for (const std::uint32_t v : partners) {
            const Tri& b = tris[v];
            const double contact = std::min(widest, 1e-2 * std::min(a.size, b.size));
            contacts(a, b, contact, tol, lines[u]);
        }
    };
    // Per thread, which triangle last took each partner (each pair tested once a side),
    // the (large, small) pairs its small triangles found, and its large triangles' large
    // partners (their lines come after the pairs are in).
    const int T = std::max(1, std::min(threads, mine));
    std::vector<std::vector<std::uint32_t>> stamps(static_cast<std::size_t>(T));
    std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> found_by(static_cast<std::size_t>(T));
    std::vector<std::vector<std::uint32_t>> large_partners(L);
    parallel_chunks(mine, threads, [&](int k0, int k1, int t) {
        auto& stamp = stamps[static_cast<std::size_t>(t)];
        if (stamp.empty()) stamp.assign(tris.size(), std::numeric_limits<std::uint32_t>::max());
        auto& found = found_by[static_cast<std::size_t>(t)];
        std::vector<std::uint32_t> partners;
        // The large triangles in the coarse runs of item j (first in each run).
        auto large_in_runs = [&](std::uint32_t u, std::size_t j, const auto& take) {
            for (std::size_t s = coarse_cells.first[j]; s < coarse_cells.first[j + 1]; ++s) {
                const std::uint32_t r = coarse_cells.run_of[s];
                for (std::size_t c = coarse_cells.run_start[r]; c < coarse_cells.run_start[r + 1]; ++c) {
                    const std::uint32_t item = coarse_cells.members[c];
                    if (item >= L) break;
                    if (const std::uint32_t v = large[item]; v != u && stamp[v] != u) {
                        stamp[v] = u;
                        if (boxes[u].meets(boxes[v])) take(v);
                    }
                }
            }
        };
        for (int k = k0; k < k1; ++k) {
            const auto u = static_cast<std::uint32_t>(triangle(k));
            partners.clear();
            if (is_large(u)) {
                large_in_runs(u, index_in[u], [&](std::uint32_t v) { large_partners[index_in[u]].push_back(v); });
                continue;
            }
            for (std::size_t s = cells.first[u]; s < cells.first[u + 1]; ++s) {
                const std::uint32_t r = cells.run_of[s];
                for (std::size_t j = cells.run_start[r]; j < cells.run_start[r + 1]; ++j)
                    if (const std::uint32_t v = cells.members[j]; v != u && stamp[v] != u) {
                        stamp[v] = u;
                        if (boxes[u].meets(boxes[v])) partners.push_back(v);
                    }
            }
            if (L > 0)
                large_in_runs(u, L + index_in[u], [&](std::uint32_t v) {
                    partners.push_back(v);
                    found.emplace_back(v, u);
                });
            std::sort(partners.begin(), partners.end());
            find_lines(u, partners);
        }
    });
    if (L > 0) {
        // The (large, small) pairs, every member's on every member (plain data), in order.
        std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
        for (const auto& f : found_by) pairs.insert(pairs.end(), f.begin(), f.end());
        found_by = {};
        if (members > 1) {
            std::vector<std::vector<std::uint32_t>> flat(static_cast<std::size_t>(members));
            for (const auto& [v, u] : pairs) flat[static_cast<std::size_t>(me)].insert(flat[static_cast<std::size_t>(me)].end(), {v, u});
            swap_shares(*team, header, flat, "pairs", shown);
            pairs.clear();
            for (const auto& f : flat)
                for (std::size_t k = 0; k + 1 < f.size(); k += 2) pairs.emplace_back(f[k], f[k + 1]);
        }
        std::sort(pairs.begin(), pairs.end());
        // The large triangles' lines: their large partners and the small ones that found them.
        std::vector<std::size_t> from(L + 1, 0);
        for (const auto& pair : pairs) ++from[index_in[pair.first] + 1];
        for (std::size_t j = 0; j < L; ++j) from[j + 1] += from[j];
        std::vector<std::uint32_t> mine_large;
        for (const std::uint32_t u : large)
            if (static_cast<int>(u % static_cast<std::uint32_t>(members)) == me) mine_large.push_back(u);
        parallel_chunks(static_cast<int>(mine_large.size()), threads, [&](int k0, int k1) {
            std::vector<std::uint32_t> partners;
            for (int k = k0; k < k1; ++k) {
                const std::uint32_t u = mine_large[static_cast<std::size_t>(k)];
                const std::size_t j = index_in[u];
                partners = large_partners[j];
                for (std::size_t q = from[j]; q < from[j + 1]; ++q) partners.push_back(pairs[q].second);
                std::sort(partners.begin(), partners.end());
                find_lines(u, partners);
            }
        });
    }
    if (members > 1) {
        std::vector<std::vector<PackedLine>> plain(lines.size());
        for (std::size_t k = static_cast<std::size_t>(me); k < lines.size(); k += static_cast<std::size_t>(members))
            for (const Line& l : lines[k]) plain[k].push_back(packed(l));
        swap_shares(*team, header, plain, "lines", shown);
        for (std::size_t k = 0; k < lines.size(); ++k)
            if (static_cast<int>(k % static_cast<std::size_t>(members)) != me)
                for (const PackedLine& p : plain[k]) lines[k].push_back(unpacked(p));
    }
    return lines;
}

}  // namespace

void skip_contact_search(const Scene& scene, const PreparationTeam* team) {
    if (!team || team->size() <= 1) return;
    const ShareHeader header{kNoSearch, 0};
    std::vector<char> mine(sizeof header);
    std::memcpy(mine.data(), &header, sizeof header);
    check_headers(team->gather_all(mine), scene.name);
}

ContactCuts cut_at_contacts(Scene& scene, int threads, const PreparationTeam* team) {
    TriMesh& mesh = scene.mesh;
    const double radius = scene.bounds_radius();
    const double tol = 1e-7 * radius;

    // The triangles, and which of their edges end a planar region (faces on the threads;
    // finalize() leaves them 0 .. n_faces() - 1).
    Buffer<Tri> tris(mesh.n_faces());  // each written by its thread (scenes/buffer.h)
    parallel_chunks(static_cast<int>(mesh.n_faces()), threads, [&](int f0, int f1) {
        for (int i = f0; i < f1; ++i) {
            Tri& t = tris[static_cast<std::size_t>(i)];
            int k = 0;
            std::array<TriMesh::HalfedgeHandle, 3> hs;
            for (auto h : mesh.fh_range(TriMesh::FaceHandle(i))) {
                hs[k] = h;
                t.p[k++] = to_eigen(mesh.point(mesh.from_vertex_handle(h)));
            }
            t.n = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]).normalized();
            t.offset = t.n.dot(t.p[0]);
            t.size = std::max({(t.p[1] - t.p[0]).norm(), (t.p[2] - t.p[1]).norm(), (t.p[0] - t.p[2]).norm()});
            for (int e = 0; e < 3; ++e) {
                const auto g = mesh.opposite_face_handle(hs[e]);
                bool coplanar = false;
                if (g.is_valid()) {
                    auto it = mesh.cfv_iter(g);
                    const Vec3 a = to_eigen(mesh.point(*it++)), b = to_eigen(mesh.point(*it++)), c = to_eigen(mesh.point(*it));
                    const Vec3 n = (b - a).cross(c - a).normalized();
                    // Within 1.4e-4 rad and 1e-6 of the scene: float meshes' flat floors stay one region.
                    coplanar = n.dot(t.n) > 1.0 - 1e-8 && std::abs(n.dot(a) - t.offset) <= 10.0 * tol;
                }
                t.region_edge[e] = !coplanar;
            }
        }
    });

    // The contact lines of every triangle. Surfaces touch when nearer than 1e-3 of the
    // scene's radius and 1e-2 of the smaller triangle's size: a table top 0.75 above a
    // large ground plane does not, a light panel 1e-4 under a ceiling does.
    const std::vector<std::vector<Line>> lines =
        contact_lines(tris, 1e-3 * radius, radius, tol, threads, team && team->size() > 1 ? team : nullptr, scene.name);

    // Cut each triangle along its lines, then split the cut edges where the contacts
    // end and mark the edges on the contacts. A vertex nearer a line than 1e-3 of its
    // face's size (or the tolerance) lies on it: no slivers thinner than that.
    ContactCuts cuts;
    OpenMesh::FPropHandleT<int> origin;
    mesh.add_property(origin, "contact origin");
    for (auto f : mesh.faces()) mesh.property(origin, f) = f.idx();
    std::vector<TriMesh::FaceHandle> faces, work;
    std::vector<std::uint32_t> seen;  // per face: the last visit that reached it
    std::uint32_t visit = 0;          // (one per triangle and cutting line: far fewer than 2^32)
    auto faces_of = [&](std::size_t u, TriMesh::VertexHandle v) {  // the faces of origin u around v
        for (auto f : mesh.vf_range(v))
            if (mesh.property(origin, f) == static_cast<int>(u)) work.push_back(f);
    };
    // The faces of origin u now: the connected pieces of the original triangle.
    auto find_pieces = [&](std::size_t u) {
        faces.clear();
        ++visit;  // the faces marked with it are seen
        seen.resize(mesh.n_faces(), 0);
        std::vector<TriMesh::FaceHandle> stack(1, TriMesh::FaceHandle(static_cast<int>(u)));
        while (!stack.empty()) {
            const auto f = stack.back();
            stack.pop_back();
            if (seen[static_cast<std::size_t>(f.idx())] == visit) continue;
            seen[static_cast<std::size_t>(f.idx())] = visit;
            faces.push_back(f);
            for (auto g : mesh.ff_range(f))
                if (mesh.property(origin, g) == static_cast<int>(u)) stack.push_back(g);
        }
    };
    for (std::size_t u = 0; u < tris.size(); ++u) {
        if (lines[u].empty()) continue;
        const double near = std::max(tol, 1e-3 * tris[u].size);
        // Every piece from the start: an earlier triangle's cut may have split this one
        // along their shared edge (its first line once met only the piece that kept
        // the face's handle, and was lost where it lay in another).
        find_pieces(u);  // faces holds every piece from here on
        for (const Line& line : lines[u]) {
            if (!line.cut) continue;
            const Vec3 across = tris[u].n.cross(line.along);
            bool cut = false;
            work = faces;
            while (!work.empty()) {
                const auto f = work.back();
                work.pop_back();
                std::array<TriMesh::HalfedgeHandle, 3> hs;
                std::array<double, 3> s;
                int k = 0, on = 0;
                for (auto h : mesh.fh_range(f)) {
                    hs[k] = h;
                    s[k] = across.dot(to_eigen(mesh.point(mesh.from_vertex_handle(h))) - line.at);
                    if (std::abs(s[k]) <= near) ++on;
                    ++k;
                }
                // The halfedges from a vertex on one side to one strictly on the other.
                std::vector<std::pair<TriMesh::HalfedgeHandle, double>> crossings;
                for (int e = 0; e < 3; ++e) {
                    const double a = s[e], b = s[(e + 1) % 3];
                    if (std::abs(a) > near && std::abs(b) > near && a * b < 0.0) crossings.emplace_back(hs[e], a / (a - b));
                }
                if (on >= 2 || crossings.empty() || (on == 0 && crossings.size() != 2)) continue;
                // Only a piece the contact's segment reaches, not every piece its line
                // crosses: a large patch (patch_size "none", a floor under a finely
                // meshed statue) cut across by the line of every short contact grew
                // like the square of their count.
                double lo = std::numeric_limits<double>::infinity(), hi = -lo;
                for (int e = 0; e < 3; ++e) {
                    if (std::abs(s[e]) > near) continue;
                    const double x = line.along.dot(to_eigen(mesh.point(mesh.from_vertex_handle(hs[e]))) - line.at);
                    lo = std::min(lo, x), hi = std::max(hi, x);
                }
                for (const auto& [h, t] : crossings) {
                    const Vec3 p = to_eigen(mesh.point(mesh.from_vertex_handle(h)));
                    const Vec3 q = to_eigen(mesh.point(mesh.to_vertex_handle(h)));
                    const double x = line.along.dot(p + t * (q - p) - line.at);
                    lo = std::min(lo, x), hi = std::max(hi, x);
                }
                if (hi <= tol || lo >= line.length - tol) continue;
                for (const auto& [h, t] : crossings) {
                    const auto v = split_edge(scene, h, t);
                    ++cuts.splits;
                    faces_of(u, v);  // its pieces: cut again if the line crosses them
                }
                cut = true;
            }
            if (!cut) continue;  // the pieces as the last search found them
            ++cuts.lines;
            find_pieces(u);
        }
        // Where a contact ends inside an edge on its line, split the edge there; then
        // mark the edges on the contact.
        for (const Line& line : lines[u]) {
            const Vec3 across = tris[u].n.cross(line.along);
            auto on_line = [&](const Vec3& p) { return std::abs(across.dot(p - line.at)) <= near; };
            for (const double end : {0.0, line.length}) {
                bool split = false;
                for (const auto f : faces) {
                    for (auto h : mesh.fh_range(f)) {
                        const Vec3 p = to_eigen(mesh.point(mesh.from_vertex_handle(h)));
                        const Vec3 q = to_eigen(mesh.point(mesh.to_vertex_handle(h)));
                        if (!on_line(p) || !on_line(q)) continue;
                        const double a = line.along.dot(p - line.at), b = line.along.dot(q - line.at);
                        if (std::min(a, b) + near < end && end < std::max(a, b) - near) {
                            split_edge(scene, h, (end - a) / (b - a));
                            ++cuts.splits;
                            split = true;
                            break;
                        }
                    }
                    if (split) break;  // one edge holds the point
                }
                // The faces again, in order: those around the faces' corners where a split
                // made new ones.
                if (!split) {
                    std::sort(faces.begin(), faces.end());
                    continue;
                }
                work.clear();
                for (const auto f : faces)
                    for (auto v : mesh.fv_range(f)) faces_of(u, v);
                std::sort(work.begin(), work.end());
                work.erase(std::unique(work.begin(), work.end()), work.end());
                faces = work;
            }
            for (const auto f : faces)
                for (auto h : mesh.fh_range(f)) {
                    const Vec3 p = to_eigen(mesh.point(mesh.from_vertex_handle(h)));
                    const Vec3 q = to_eigen(mesh.point(mesh.to_vertex_handle(h)));
                    const double a = line.along.dot(p - line.at), b = line.along.dot(q - line.at);
                    if (!on_line(p) || !on_line(q) || std::min(a, b) < -near || std::max(a, b) > line.length + near)
                        continue;
                    const auto e = mesh.edge_handle(h);
                    if (mesh.property(scene.contact_edge_handle, e)) continue;
                    mesh.property(scene.contact_edge_handle, e) = true;
                    ++cuts.edges;
                }
        }
    }
    mesh.remove_property(origin);
    if (cuts.splits > 0 || cuts.edges > 0 || scene.patch_list().size() != mesh.n_faces()) scene.finalize(threads);
    scene.contact_lines += cuts.lines;
    scene.contact_splits += cuts.splits;
    scene.contact_edges += cuts.edges;
    return cuts;
}

}  // namespace raybundle::scenes
