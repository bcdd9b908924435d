#include "solver/first_shot.h"

#include "scenes/frame.h"
#include "scenes/threads.h"
#include "solver/form_factor.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <utility>
#include <vector>

namespace raybundle::solver {

using scenes::Rgb;
using scenes::Vec3;

namespace {

// Calls f(u, v) at the centroids of the N^2 congruent sub-triangles of the unit
// triangle: "upright" (s + t < N) and "inverted" (s + t < N - 1), all of area 1/N^2.
template <class F>
void subtriangle_centroids(int N, F&& f) {
    for (int s = 0; s < N; ++s)
        for (int t = 0; s + t < N; ++t) {
            f((s + 1.0 / 3.0) / N, (t + 1.0 / 3.0) / N);
            if (s + t < N - 1) f((s + 2.0 / 3.0) / N, (t + 2.0 / 3.0) / N);
        }
}

double longest_edge(const Vec3& a, const Vec3& b, const Vec3& c) {
    return std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
}

// The part of triangle tri in front of the plane n . (p - x) > 0, as a polygon
// (Sutherland-Hodgman against one plane: 0, 3 or 4 corners).
int clip_front(const std::array<Vec3, 3>& tri, const Vec3& x, const Vec3& n, std::array<Vec3, 4>& out) {
    int count = 0;
    for (int k = 0; k < 3; ++k) {
        const Vec3& p = tri[k];
        const Vec3& q = tri[(k + 1) % 3];
        const double dp = n.dot(p - x), dq = n.dot(q - x);
        if (dp > 0.0) out[count++] = p;
        if ((dp > 0.0) != (dq > 0.0) && dp != dq) {
            const Vec3 cut = p + (dp / (dp - dq)) * (q - p);
            if (count < 4) out[count++] = cut;
        }
    }
    return count;
}

// Many emitters (a light panel refined with the scene): coplanar emissive patches of one
// object and material form a group, whose shadow rays are shared (below).
constexpr std::size_t kGroupAbove = 64;  // emitters; at most this many, each is its own group
constexpr int kPenumbraRays = 256;        // a group's shadow rays from a point its first rays disagree on

struct EmitterGroup {
    std::vector<std::uint32_t> members;
    Vec3 centre = Vec3::Zero();  // of the members' vertices' bounding sphere
    double radius = 0.0;
    // The members' running sum of area, and their outline (scenes::plane_outline: a
    // form factor's edge sum over the members' edges is the sum over these, the inner
    // edges cancelling).
    std::vector<double> area;
    std::vector<std::array<Vec3, 2>> outline;
};

std::vector<EmitterGroup> group_emitters(const scenes::Scene& scene, const std::vector<std::uint32_t>& emitters) {
    const auto& patches = scene.patch_list();
    const auto& pos = scene.vertex_positions();
    std::vector<EmitterGroup> groups;
    if (emitters.size() <= kGroupAbove) {
        for (const std::uint32_t j : emitters) groups.push_back({{j}, Vec3::Zero(), 0.0, {}, {}});
    } else {
        // Bins of (object, material, plane), the plane's normal and offset rounded to
        // 1e-9 (of the bounds' radius): one look-up per emitter, so that a dense
        // emissive mesh of many planes costs no more than a refined panel. Coplanar
        // patches on either side of a rounding step make two groups: exact all the same.
        const double step = 1e-9 * scene.bounds_radius();
        std::map<std::array<long long, 6>, std::size_t> bins;
        for (const std::uint32_t j : emitters) {
            const auto& q = patches[j];
            const std::array<long long, 6> key = {q.object, q.material, std::llround(q.normal.x() * 1e9),
                                                  std::llround(q.normal.y() * 1e9), std::llround(q.normal.z() * 1e9),
                                                  std::llround(q.normal.dot(q.centroid) / step)};
            const auto [at, added] = bins.emplace(key, groups.size());
            if (added) groups.push_back({{j}, Vec3::Zero(), 0.0, {}, {}});
            else groups[at->second].members.push_back(j);
        }
    }
    for (auto& g : groups) {
        if (g.members.size() == 1) continue;  // the shot of one emitter needs none of this
        // Members in Morton order of their centroids in the group's plane, so that a
        // stretch of the running area is a compact piece of the group.
        {
            Vec3 u, v;
            scenes::orthonormal_basis(patches[g.members.front()].normal, u, v);
            double ulo = 1e300, uhi = -1e300, vlo = 1e300, vhi = -1e300;
            for (const std::uint32_t j : g.members) {
                const Vec3& c = patches[j].centroid;
                ulo = std::min(ulo, u.dot(c)), uhi = std::max(uhi, u.dot(c));
                vlo = std::min(vlo, v.dot(c)), vhi = std::max(vhi, v.dot(c));
            }
            const double span = std::max({uhi - ulo, vhi - vlo, 1e-300});
            auto code = [&](std::uint32_t j) {
                const Vec3& c = patches[j].centroid;
                const auto qu = static_cast<std::uint32_t>(65535.0 * (u.dot(c) - ulo) / span);
                const auto qv = static_cast<std::uint32_t>(65535.0 * (v.dot(c) - vlo) / span);
                std::uint64_t m = 0;
                for (int bit = 0; bit < 16; ++bit)
                    m |= (static_cast<std::uint64_t>((qu >> bit) & 1u) << (2 * bit)) |
                         (static_cast<std::uint64_t>((qv >> bit) & 1u) << (2 * bit + 1));
                return m;
            };
            std::vector<std::pair<std::uint64_t, std::uint32_t>> order;
            for (const std::uint32_t j : g.members) order.emplace_back(code(j), j);
            std::sort(order.begin(), order.end());
            for (std::size_t k = 0; k < order.size(); ++k) g.members[k] = order[k].second;
        }
        Vec3 lo = pos[patches[g.members.front()].v[0]], hi = lo;
        double area = 0.0;
        for (const std::uint32_t j : g.members) {
            for (const int v : patches[j].v) lo = lo.cwiseMin(pos[v]), hi = hi.cwiseMax(pos[v]);
            g.area.push_back(area += patches[j].area);
        }
        for (const auto& [from, to] : scenes::plane_outline(scene, g.members)) g.outline.push_back({pos[from], pos[to]});
        g.centre = 0.5 * (lo + hi);
        g.radius = 0.5 * (hi - lo).norm();
    }
    return groups;
}

}  // namespace

std::vector<Rgb> diffuse_shot(const scenes::Scene& scene, const scenes::RayCaster& caster, long& rays_out,
                              const sampling::RunOptions& run, std::size_t* groups_out) {
    const std::size_t n = scene.patch_count();
    const auto& patches = scene.patch_list();
    const auto& pos = scene.vertex_positions();
    std::vector<std::uint32_t> emitters;
    for (std::size_t j = 0; j < n; ++j)
        if (scene.material_of(j).emissive()) emitters.push_back(static_cast<std::uint32_t>(j));
    const std::vector<EmitterGroup> groups = group_emitters(scene, emitters);
    if (groups_out) *groups_out = groups.size();
    std::vector<Rgb> irradiance(n, Rgb::Zero());
    const double offset = 1e-6 * scene.bounds_radius();
    // Receivers are independent: chunks of them on the run's threads (those next to a
    // light cost the most, and lie together in patch order); every sum is made in the
    // same order whatever the split. Spread over a team, each member computes
    // receivers rank, rank + size, ... and the members share them (with the rays each
    // receiver cast), so that the shot is computed once, not once per member.
    const sampling::Team* team = run.team && run.team->size() > 1 ? run.team : nullptr;
    const int first = team ? team->rank() : 0, stride = team ? team->size() : 1;
    const int mine = team ? team->rows_of(first, static_cast<int>(n)) : static_cast<int>(n);
    std::vector<long> rays_of(team ? n : 0, 0);
    std::atomic<long> all_rays{0};
    std::mutex progress_lock;
    long done = 0;
    const auto start = std::chrono::steady_clock::now();
    // A group of emitters (group_emitters), at each receiver point: its unoccluded form
    // factor by Lambert's edge sum over its outline, clipped to the point's plane
    // (point_to_outline: the members clipped one by one give the same), times the
    // visible share of K shadow rays to members drawn by area (stratified, fixed:
    // (k + 1/2) / K along the running area), each ray weighed by the point-to-point
    // kernel cos cos / r^2 at its end; K = (4 r / d)^2 in 16..64 for a group of radius r
    // at distance d. Exact where the group is wholly seen or wholly hidden; a quadrature
    // of K points across a shadow's edge.
    auto shared_rays = [&](const EmitterGroup& group, std::size_t i, long& rays) -> Rgb {
        const auto& p = patches[i];
        const auto& normal = patches[group.members.front()].normal;
        const Vec3 a = pos[p.v[0]], b = pos[p.v[1]], c = pos[p.v[2]];
        const double edge_i = longest_edge(a, b, c);
        const double tiny = 1e-9 * scene.bounds_radius();
        const double near = std::max((group.centre - p.centroid).norm() - group.radius, 0.25 * group.radius + tiny);
        const int Ni = std::clamp(static_cast<int>(std::ceil(4.0 * edge_i / near)), 1, 16);
        const double ratio = 4.0 * group.radius / near;
        const int K = std::clamp(static_cast<int>(std::ceil(ratio * ratio)), 16, 64);
        const double total_area = group.area.back();
        double sum = 0.0;
        subtriangle_centroids(Ni, [&](double u, double v) {
            const Vec3 x = a + u * (b - a) + v * (c - a);
            // Behind the emitters, or in their plane (within 1e-9 of the scene: a member's
            // own points, which rounding puts on either side, would see the whole outline
            // around them, and the outline's clipping needs a point off the plane).
            if (normal.dot(x - group.outline.front()[0]) <= tiny) return;
            const double F = point_to_outline(x, p.normal, group.outline);
            if (F <= 0.0) return;
            const Vec3 from = x + offset * p.normal;
            double seen = 0.0, weight = 0.0;
            auto cast = [&](int count) {
                seen = weight = 0.0;
                std::size_t k = 0;
                for (int s = 0; s < count; ++s) {
                    const double at = (s + 0.5) / count * total_area;
                    while (k + 1 < group.members.size() && group.area[k] < at) ++k;
                    if (group.members[k] == i) continue;
                    const Vec3 d = patches[group.members[k]].centroid - from;
                    const double r2 = d.squaredNorm();
                    const double w = p.normal.dot(d) * -normal.dot(d) / (r2 * r2);
                    if (!(w > 0.0)) continue;
                    const double r = std::sqrt(r2);
                    ++rays;
                    weight += w;
                    if (!caster.occluded(from, d / r, 0.0, r * (1.0 - 1e-5))) seen += w;
                }
            };
            cast(K);
            if (seen > 0.0 && seen < weight) cast(kPenumbraRays);  // a shadow's edge: more rays
            // No ray with a weight (every drawn point behind the plane): the line to
            // the group's centre decides, as for a sliver of one emitter.
            if (weight <= 0.0) {
                const Vec3 d = group.centre - from;
                const double r = d.norm();
                ++rays;
                if (r > 0.0 && !caster.occluded(from, d / r, 0.0, r * (1.0 - 1e-5))) sum += M_PI * F;
                return;
            }
            sum += M_PI * F * seen / weight;
        });
        return scene.material_of(group.members.front()).emission * (sum / (static_cast<double>(Ni) * Ni));
    };
    // The receivers' order of work: costliest first, so that the threads end together
    // (a receiver beside a big light casts thousands of times the rays of one across
    // the room, and such receivers lie together in patch order). The cost is estimated
    // as the shadow rays the loop below casts without a penumbra, Ni^2 points times K
    // rays to a group or Nj^2 to one emitter, and sorted by its power of two (patch
    // order within one): the order decides only which thread computes a receiver.
    std::vector<int> order(static_cast<std::size_t>(mine));
    {
        std::vector<std::uint8_t> power(static_cast<std::size_t>(mine));
        parallel_chunks(mine, run.threads, [&](int k0, int k1) {
            for (int k = k0; k < k1; ++k) {
                const auto i = static_cast<std::size_t>(first) + static_cast<std::size_t>(k) * static_cast<std::size_t>(stride);
                const auto& p = patches[i];
                const double edge_i = longest_edge(pos[p.v[0]], pos[p.v[1]], pos[p.v[2]]);
                double rays = 1.0;
                for (const auto& group : groups) {
                    const auto& q = patches[group.members.front()];
                    if (group.members.size() > 1) {
                        const double near = std::max((group.centre - p.centroid).norm() - group.radius,
                                                     0.25 * group.radius + 1e-9 * scene.bounds_radius());
                        const double Ni = std::clamp(std::ceil(4.0 * edge_i / near), 1.0, 16.0);
                        const double ratio = 4.0 * group.radius / near;
                        rays += Ni * Ni * std::clamp(std::ceil(ratio * ratio), 16.0, 64.0);
                    } else {
                        const double dist = std::max((q.centroid - p.centroid).norm(), 1e-9 * scene.bounds_radius());
                        const double Ni = std::clamp(std::ceil(4.0 * edge_i / dist), 1.0, 16.0);
                        const double edge_j = longest_edge(pos[q.v[0]], pos[q.v[1]], pos[q.v[2]]);
                        const double Nj = std::clamp(std::ceil(2.0 * edge_j / dist), 1.0, 4.0);
                        rays += Ni * Ni * Nj * Nj;
                    }
                }
                power[static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(std::min(63, std::ilogb(rays)));
            }
        });
        std::array<int, 64> next{};  // a counting sort, highest power first: where each power's receivers go
        for (const std::uint8_t e : power) ++next[63 - e];
        for (int c = 0, at = 0; c < 64; ++c) at += std::exchange(next[c], at);
        for (int k = 0; k < mine; ++k) order[static_cast<std::size_t>(next[63 - power[static_cast<std::size_t>(k)]]++)] = k;
    }
    parallel_chunks(mine, run.threads, [&](int o0, int o1) {
        long rays = 0;
        std::vector<Vec3> targets;
        for (int o = o0; o < o1; ++o) {
            const int k = order[static_cast<std::size_t>(o)];
            const auto i = static_cast<std::size_t>(first) + static_cast<std::size_t>(k) * static_cast<std::size_t>(stride);
            const long rays_before = rays;
            if (run.progress) {
                const std::lock_guard<std::mutex> lock(progress_lock);
                run.report("diffuse shot", ++done, static_cast<long>(mine),
                           std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
            }
            const auto& p = patches[i];
            const Vec3 a = pos[p.v[0]], b = pos[p.v[1]], c = pos[p.v[2]];
            const double edge_i = longest_edge(a, b, c);
            for (const auto& group : groups) {
                if (group.members.size() > 1) {
                    irradiance[i] += shared_rays(group, i, rays);
                    continue;
                }
                const std::uint32_t j = group.members.front();
                if (j == i) continue;
                const auto& q = patches[j];
                const std::array<Vec3, 3> tri = {pos[q.v[0]], pos[q.v[1]], pos[q.v[2]]};
                // One-sided: the receiver must be (partly) in front of the emitter and see its front.
                const double dist = std::max((q.centroid - p.centroid).norm(), 1e-9 * scene.bounds_radius());
                const int Ni = std::clamp(static_cast<int>(std::ceil(4.0 * edge_i / dist)), 1, 16);
                const double edge_j = longest_edge(tri[0], tri[1], tri[2]);
                const int Nj = std::clamp(static_cast<int>(std::ceil(2.0 * edge_j / dist)), 1, 4);
                targets.clear();
                subtriangle_centroids(Nj, [&](double u, double v) {
                    targets.push_back(tri[0] + u * (tri[1] - tri[0]) + v * (tri[2] - tri[0]));
                });
                double sum = 0.0;
                subtriangle_centroids(Ni, [&](double u, double v) {
                    const Vec3 x = a + u * (b - a) + v * (c - a);
                    if (q.normal.dot(x - tri[0]) <= 0.0) return;  // behind the emitter
                    // The emitter's part in front of x's plane, and its form factor.
                    std::array<Vec3, 4> poly;
                    const int m = clip_front(tri, x, p.normal, poly);
                    if (m < 3) return;
                    double F = point_to_triangle(x, p.normal, {poly[0], poly[1], poly[2]});
                    if (m == 4) F += point_to_triangle(x, p.normal, {poly[0], poly[2], poly[3]});
                    if (F <= 0.0) return;
                    // Visibility: the fraction of shadow rays to the emitter's points that arrive.
                    const Vec3 from = x + offset * p.normal;
                    int seen = 0, cast = 0;
                    for (const Vec3& y : targets) {
                        const Vec3 d = y - from;
                        const double r = d.norm();
                        if (p.normal.dot(d) <= 0.0 || q.normal.dot(d) >= 0.0) continue;  // point not mutually visible
                        ++cast;
                        if (!caster.occluded(from, d / r, 0.0, r * (1.0 - 1e-5))) ++seen;
                    }
                    rays += cast;
                    if (cast == 0) {
                        // Every sample point lies behind a plane (a sliver in front): visible
                        // unless something blocks the line to the clipped polygon's centre.
                        Vec3 centre = Vec3::Zero();
                        for (int corner = 0; corner < m; ++corner) centre += poly[corner] / m;
                        const Vec3 d = centre - from;
                        const double r = d.norm();
                        ++rays;
                        if (r > 0.0 && !caster.occluded(from, d / r, 0.0, r * (1.0 - 1e-5))) sum += M_PI * F;
                        return;
                    }
                    sum += M_PI * F * seen / cast;
                });
                irradiance[i] += scene.material_of(j).emission * (sum / (static_cast<double>(Ni) * Ni));
            }
            if (team) rays_of[i] = rays - rays_before;
        }
        all_rays += rays;
    }, 256);
    if (team) {
        team->share_rows(irradiance.data(), sizeof(Rgb), static_cast<int>(n));
        team->share_rows(rays_of.data(), sizeof(long), static_cast<int>(n));
        for (const long r : rays_of) rays_out += r;
    } else {
        rays_out += all_rays;
    }
    return irradiance;
}

double sunlit_share(const scenes::Scene& scene, const scenes::RayCaster& caster, std::size_t patch,
                    const scenes::DirectionalLight& light, long& rays) {
    const auto& p = scene.patch_list()[patch];
    if (p.normal.dot(light.direction) >= 0.0) return 0.0;
    const auto& pos = scene.vertex_positions();
    const Vec3 a = pos[p.v[0]], b = pos[p.v[1]], c = pos[p.v[2]];
    const double radius = scene.bounds_radius();
    const Vec3 lift = 1e-6 * radius * p.normal;  // just off its front
    auto lit = [&](double u, double v) {
        return !caster.occluded(a + u * (b - a) + v * (c - a) + lift, -light.direction, 0.0,
                                std::numeric_limits<double>::infinity());
    };
    // Points no farther apart than R / 32 (a patch of the automatic size gets 4^2): a
    // pool of sunlight on a large patch as modelled falls between none of them.
    const int N = std::clamp(static_cast<int>(std::ceil(32.0 * longest_edge(a, b, c) / radius)), 4, 64);
    int seen = 0;
    subtriangle_centroids(N, [&](double u, double v) { seen += lit(u, v); });
    rays += static_cast<long>(N) * N;
    if (seen == 0 || seen == N * N) return seen == 0 ? 0.0 : 1.0;
    // A shadow's edge crosses it: (8 N)^2 points (at most 65,536) of the R2 sequence
    // (Roberts 2018), folded into the triangle. A regular grid would line up with a
    // shadow's straight edge along a patch edge and miss or count a whole row of it
    // (3 % of a window's pool on a floor as modelled); these points do not line up.
    const long K = std::min(65536L, 64L * N * N);
    const double g = 1.32471795724474602596;  // the plastic number: R2's generator
    const double a1 = 1.0 / g, a2 = 1.0 / (g * g);
    long in = 0;
    for (long k = 0; k < K; ++k) {
        double u = 0.5 + a1 * static_cast<double>(k), v = 0.5 + a2 * static_cast<double>(k);
        u -= std::floor(u), v -= std::floor(v);
        if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
        in += lit(u, v);
    }
    rays += K;
    return static_cast<double>(in) / static_cast<double>(K);
}

FirstShot first_shot(const scenes::Scene& scene, const scenes::RayCaster& caster, int threads) {
    FirstShot shot;
    const std::size_t n = scene.patch_count();
    shot.irradiance.assign(n, Rgb::Zero());
    const auto& patches = scene.patch_list();
    const auto& pos = scene.vertex_positions();
    const double eps = 1e-9 * scene.bounds_radius();
    // Receivers are independent: bands of them on the threads, each receiver's lights
    // in the scene's order; the bands' glossy hits joined in band order (patch order,
    // each patch's in light order) and their rays summed.
    const int bands = std::max(1, std::min(threads, static_cast<int>(n)));
    std::vector<std::vector<FirstShot::Hit>> hits(static_cast<std::size_t>(bands));
    std::vector<long> rays(static_cast<std::size_t>(bands), 0);
    run_threads(bands, [&](int t) {
        const auto i0 = static_cast<std::size_t>(static_cast<long long>(n) * t / bands);
        const auto i1 = static_cast<std::size_t>(static_cast<long long>(n) * (t + 1) / bands);
        for (std::size_t i = i0; i < i1; ++i) {
            const auto& p = patches[i];
            const Vec3 a = pos[p.v[0]], b = pos[p.v[1]], c = pos[p.v[2]];
            const double edge = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
            for (const auto& light : scene.point_lights) {
                const Vec3 to_centre = p.centroid - light.position;
                // The light must be in front of the patch's plane (emission and reception
                // are one-sided); a light on the plane gives nothing.
                if (p.normal.dot(light.position - a) <= 0.0) continue;
                const double dist = std::max(to_centre.norm(), eps);
                int N = std::clamp(static_cast<int>(std::ceil(8.0 * edge / dist)), 2, 64);
                // A spot's cone edge across the patch: four times the samples along it.
                // A cone that lands inside it (every corner outside): samples closer than
                // the cone's radius there.
                if (light.spot()) {
                    int full = 0, none = 0;
                    for (const Vec3& x : {a, b, c}) {
                        const double f = light.falloff((x - light.position).normalized());
                        full += f == 1.0, none += f == 0.0;
                    }
                    if (full < 3 && none < 3) N = std::min(64, 4 * N);
                    const double along = p.normal.dot(light.axis);
                    if (none == 3 && along < 0.0 && light.cos_outer > 0.0) {
                        const double reach = p.normal.dot(a - light.position) / along;  // to the plane on the axis
                        const Vec3 q = light.position + reach * light.axis;
                        const Vec3 across = (b - a).cross(c - a);
                        const bool inside = across.dot((b - a).cross(q - a)) >= 0.0 &&
                                            across.dot((c - b).cross(q - b)) >= 0.0 &&
                                            across.dot((a - c).cross(q - c)) >= 0.0;
                        const double radius = reach * std::sqrt(1.0 - light.cos_outer * light.cos_outer) / light.cos_outer;
                        if (inside && reach > 0.0 && radius > 0.0)  // (a patch or two: up to 256² samples)
                            N = static_cast<int>(std::clamp(std::ceil(4.0 * edge / radius), double(N), 256.0));
                    }
                }
                double sum = 0.0;
                auto sample = [&](double u, double v) {
                    const Vec3 x = a + u * (b - a) + v * (c - a);
                    const Vec3 d = x - light.position;
                    const double r = d.norm();
                    const double cos_theta = -p.normal.dot(d) / r;
                    if (cos_theta <= 0.0) return;
                    const double sent = light.falloff(d / r);  // a spot's cone
                    if (sent == 0.0) return;
                    ++rays[static_cast<std::size_t>(t)];
                    // Blocked if anything lies between the light and x (x's own patch is at r).
                    if (caster.occluded(light.position, d / r, 0.0, r * (1.0 - 1e-5))) return;
                    sum += sent * cos_theta / (r * r);
                };
                subtriangle_centroids(N, sample);
                const Rgb e = light.intensity * (sum / (static_cast<double>(N) * N));
                if ((e == 0.0).all()) continue;
                shot.irradiance[i] += e;
                if (scene.material_of(i).glossy())
                    hits[static_cast<std::size_t>(t)].push_back({static_cast<std::uint32_t>(i), to_centre / dist, e});
            }
            for (const auto& light : scene.directional_lights) {
                // Parallel light: E cos(theta) over the whole patch, times its unshadowed share.
                const double cos_theta = -p.normal.dot(light.direction);
                if (cos_theta <= 0.0) continue;
                const double share = sunlit_share(scene, caster, i, light, rays[static_cast<std::size_t>(t)]);
                if (share == 0.0) continue;
                const Rgb e = light.irradiance * (cos_theta * share);
                shot.irradiance[i] += e;
                if (scene.material_of(i).glossy())
                    hits[static_cast<std::size_t>(t)].push_back({static_cast<std::uint32_t>(i), light.direction, e});
            }
        }
    });
    for (std::size_t t = 0; t < hits.size(); ++t) {
        shot.glossy_hits.insert(shot.glossy_hits.end(), hits[t].begin(), hits[t].end());
        shot.shadow_rays += rays[t];
    }
    return shot;
}

}  // namespace raybundle::solver
