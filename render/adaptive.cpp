#include "render/adaptive.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <queue>
#include <tuple>
#include <utility>

namespace raybundle::render {

namespace {

constexpr double kSameSurface = 0.8660254037844386;  // cos 30 degrees

// Per patch, its edge neighbours on the same surface: patches sharing two flat vertices
// (a contact edge gives each side vertices of its own, so it is never shared) whose
// normals are within 30 degrees. Compressed rows: neighbours of i at [start[i], start[i+1]).
struct Neighbours {
    std::vector<std::size_t> start;
    std::vector<std::uint32_t> of;
};

Neighbours neighbours(const scenes::Scene& scene) {
    const auto& patches = scene.patch_list();
    const std::size_t n = patches.size();
    std::vector<std::tuple<int, int, std::uint32_t>> edges;
    edges.reserve(3 * n);
    for (std::size_t i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) {
            const int a = patches[i].v[k], b = patches[i].v[(k + 1) % 3];
            edges.emplace_back(std::min(a, b), std::max(a, b), static_cast<std::uint32_t>(i));
        }
    std::sort(edges.begin(), edges.end());
    std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
    for (std::size_t s = 0; s < edges.size();) {
        std::size_t e = s;
        while (e < edges.size() && std::get<0>(edges[e]) == std::get<0>(edges[s]) &&
               std::get<1>(edges[e]) == std::get<1>(edges[s]))
            ++e;
        for (std::size_t x = s; x < e; ++x)
            for (std::size_t y = x + 1; y < e; ++y) {
                const auto i = std::get<2>(edges[x]), j = std::get<2>(edges[y]);
                if (patches[i].normal.dot(patches[j].normal) < kSameSurface) continue;
                pairs.emplace_back(i, j);
                pairs.emplace_back(j, i);
            }
        s = e;
    }
    std::sort(pairs.begin(), pairs.end());
    Neighbours out;
    out.start.assign(n + 1, 0);
    for (const auto& p : pairs) ++out.start[p.first + 1];
    for (std::size_t i = 0; i < n; ++i) out.start[i + 1] += out.start[i];
    out.of.reserve(pairs.size());
    for (const auto& p : pairs) out.of.push_back(p.second);
    return out;
}

double luminance(const scenes::Rgb& c) { return c.mean(); }

}  // namespace

std::vector<double> variation(const scenes::Scene& scene, const solver::RadianceField& a,
                              const solver::RadianceField& b) {
    const std::size_t n = scene.patch_count();
    const Neighbours nb = neighbours(scene);
    std::vector<double> mean(n), noise(n), out(n, 0.0);
    // The mean of the two chains, and the variance of that mean as their difference
    // shows it: E[(a - b)^2] / 4 = Var(a) / 2 for independent chains of equal variance.
    for (std::size_t i = 0; i < n; ++i) {
        const double ya = luminance(a.radiance[i]), yb = luminance(b.radiance[i]);
        mean[i] = 0.5 * (ya + yb);
        noise[i] = 0.25 * (ya - yb) * (ya - yb);
    }
    // One difference is one degree of freedom: pooled over the patch and its neighbours.
    std::vector<double> pooled(n);
    for (std::size_t i = 0; i < n; ++i) {
        double sum = noise[i];
        for (std::size_t k = nb.start[i]; k < nb.start[i + 1]; ++k) sum += noise[nb.of[k]];
        pooled[i] = sum / static_cast<double>(1 + nb.start[i + 1] - nb.start[i]);
    }
    // E[(m_i - m_j)^2] = (true difference)^2 + Var(m_i) + Var(m_j).
    for (std::size_t i = 0; i < n; ++i) {
        const std::size_t count = nb.start[i + 1] - nb.start[i];
        if (count == 0) continue;
        double sum = 0.0;
        for (std::size_t k = nb.start[i]; k < nb.start[i + 1]; ++k) {
            const std::size_t j = nb.of[k];
            const double d = mean[i] - mean[j];
            sum += d * d - pooled[i] - pooled[j];
        }
        out[i] = std::sqrt(std::max(0.0, sum / static_cast<double>(count)));
    }
    return out;
}

RefinePlan plan_refinement(const scenes::Scene& scene, const std::vector<double>& variation, double growth) {
    const auto& patches = scene.patch_list();
    const auto& pos = scene.vertex_positions();
    const std::size_t n = patches.size();
    RefinePlan plan;
    plan.max_edge.assign(n, std::numeric_limits<double>::infinity());
    // The error a patch holds (area x variation), and the cut that removes the most of it
    // per new patch first: level L -> L + 1 halves the A v / 2^L left, for 3 x 4^L patches.
    struct Cut {
        double gain;  // error removed per new patch
        std::uint32_t patch;
        int level;    // the level it cuts to
        bool operator<(const Cut& o) const { return gain < o.gain || (gain == o.gain && patch > o.patch); }
    };
    std::priority_queue<Cut> cuts;
    double total = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        const double e = patches[i].area * variation[i];
        total += e;
        if (e > 0.0) cuts.push({e / 2.0 / 3.0, static_cast<std::uint32_t>(i), 1});
    }
    const double budget = growth * static_cast<double>(n);
    std::vector<int> level(n, 0);
    double added = 0.0;
    while (!cuts.empty()) {
        const Cut c = cuts.top();
        cuts.pop();
        const double cost = 3.0 * std::pow(4.0, c.level - 1);
        if (added + cost > budget) continue;  // a cheaper cut may still fit
        added += cost;
        level[c.patch] = c.level;
        if (c.level < RefineOptions::kMaxLevels) cuts.push({c.gain / 8.0, c.patch, c.level + 1});
    }
    double covered = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        if (level[i] == 0) continue;
        double longest = 0.0;
        for (int k = 0; k < 3; ++k) longest = std::max(longest, (pos[patches[i].v[k]] - pos[patches[i].v[(k + 1) % 3]]).norm());
        // Two bisections halve a right isosceles triangle's longest edge; other shapes take
        // more, which the run's second plan allows for (render/run.cpp). The slack keeps
        // round-off from asking one more.
        plan.max_edge[i] = longest * std::ldexp(1.0, -level[i]) * (1.0 + 1e-9);
        ++plan.marked;
        plan.deepest = std::max(plan.deepest, level[i]);
        covered += patches[i].area * variation[i];
    }
    plan.planned = static_cast<std::size_t>(added);
    plan.covered = total > 0.0 ? covered / total : 0.0;
    return plan;
}

}  // namespace raybundle::render
