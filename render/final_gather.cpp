#include "render/final_gather.h"

#include "render/gather_estimator.h"
#include "render/gbuffer.h"
#include "sampling/rng.h"
#include "sampling/strata.h"
#include "sampling/streams.h"
#include "scenes/errors.h"
#include "scenes/threads.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <utility>

namespace raybundle::render {

using scenes::Rgb;
using scenes::Vec3;
using Clock = std::chrono::steady_clock;

int most_similar_guide(const Vec3& normal, double depth, const std::vector<Vec3>& normals,
                       const std::vector<double>& depths) {
    const std::size_t n = normals.size();
    if (n == 0) return -1;
    double max_dn = 0.0, max_dd = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        max_dn = std::max(max_dn, (normal - normals[i]).squaredNorm());
        max_dd = std::max(max_dd, std::abs(depth - depths[i]));
    }
    int best = 0;
    double best_s = -1.0;
    for (std::size_t i = 0; i < n; ++i) {
        // A term whose maximum is zero does not discriminate: similarity 1.
        const double sn = max_dn > 0.0 ? 1.0 - (normal - normals[i]).squaredNorm() / max_dn : 1.0;
        const double sd = max_dd > 0.0 ? 1.0 - std::abs(depth - depths[i]) / max_dd : 1.0;
        const double s = sn * sd;
        if (s > best_s) {
            best_s = s;
            best = static_cast<int>(i);
        }
    }
    return best;
}

DirectLight parse_direct_light(const std::string& name) {
    for (std::size_t k = 0; k < kDirectLightNames.size(); ++k)
        if (name == kDirectLightNames[k]) return static_cast<DirectLight>(k);
    throw scenes::OptionError("direct", "unknown direct light method '" + name + "' (analytic | sampled)");
}

const char* direct_light_name(DirectLight d) { return kDirectLightNames[static_cast<std::size_t>(d)]; }

namespace {

void put(Image& img, int x, int y, const Rgb& c) {
    float* p = img.at(x, y);
    for (int k = 0; k < 3; ++k) p[k] = static_cast<float>(c[k]);
}
Rgb get(const Image& img, int x, int y) {
    const float* p = img.at(x, y);
    return {p[0], p[1], p[2]};
}

// Whether guide g (shading normal gn) lies on the surface of a sample at `point`
// (shading normal n, depth t): the same normal within 2.6 degrees, and g within 1e-3
// of the depth from the sample's tangent plane.
bool on_surface(const GSample& g, const Vec3& gn, const Vec3& point, const Vec3& n, double t) {
    return gn.dot(n) > 0.999 && std::abs(n.dot(g.point - point)) <= 1e-3 * t;
}

// The rows this process computes: all of them, or its share where the run is spread
// over a team (sampling::Team: rows rank, rank + size, ...); share() then hands every
// member the others' rows of per-row data (H rows of equal size).
class RowShare {
public:
    RowShare(const sampling::Team* team, int rows)
        : team_(team && team->size() > 1 ? team : nullptr), rows_(rows), first_(team_ ? team_->rank() : 0),
          stride_(team_ ? team_->size() : 1), count_(team_ ? team_->rows_of(team_->rank(), rows) : rows) {}
    int count() const { return count_; }
    // The i-th of this process's rows.
    int row(int i) const { return first_ + i * stride_; }
    template <class T, class Allocator>
    void share(std::vector<T, Allocator>& rows) const {
        if (team_) team_->share_rows(rows.data(), sizeof(T) * (rows.size() / static_cast<std::size_t>(rows_)), rows_);
    }
    void share(Image& image) const { share(image.rgb); }

private:
    const sampling::Team* team_;
    int rows_, first_, stride_, count_;
};

}  // namespace

GatherResult final_gather(const scenes::Scene& scene, const scenes::RayCaster& caster,
                          const solver::RadianceField& field, const PinholeCamera& camera, const GatherOptions& o,
                          const sampling::RunOptions& run) {
    if (o.gather_rays < 1) throw scenes::OptionError("gather_rays", "must be >= 1, got " + std::to_string(o.gather_rays));
    if (o.direct_samples < 0)
        throw scenes::OptionError("direct_samples", "must be >= 0, got " + std::to_string(o.direct_samples));
    if (o.spp < 1) throw scenes::OptionError("spp", "must be >= 1, got " + std::to_string(o.spp));
    if (o.emission_samples < 0)
        throw scenes::OptionError("emission_samples", "must be >= 0, got " + std::to_string(o.emission_samples));
    if (!(o.correction >= 0.0 && o.correction <= 1.0))
        throw scenes::OptionError("correction", "must be in [0, 1], got " + std::to_string(o.correction));
    if (!(o.bias_probe >= 0.0 && o.bias_probe <= 1.0))
        throw scenes::OptionError("bias_probe", "must be in [0, 1], got " + std::to_string(o.bias_probe));
    if (o.glossy_rays < 0)
        throw scenes::OptionError("glossy_rays", "must be >= 0, got " + std::to_string(o.glossy_rays));
    const int W = camera.width(), H = camera.height();
    // From here the guides' phase: the estimator's corner values and marks, the
    // images, then the guide samples.
    const auto t0 = Clock::now();
    const GatherEstimator g(scene, caster, field, o, run.threads);
    const auto& patches = scene.patch_list();
    GatherResult r;
    r.direct_at_hits = g.direct_at_hits();
    r.image = Image(W, H);
    r.direct = Image(W, H);
    r.indirect = Image(W, H);
    r.normal = Image(W, H);
    r.depth = Image(W, H);
    r.position = Image(W, H);
    // The bias probe's estimate of the field's error in the indirect light (with the
    // correction on, the image has none to measure).
    const bool probe = o.bias_probe > 0.0 && o.correction == 0.0;
    Image field_error(W, H);
    std::vector<int> guide_patch(static_cast<std::size_t>(W) * H, -1);
    // A textured scene's albedo at each guide point (the texture's there); else the
    // guide patch's material's.
    const bool textured = scene.textured();
    Image guide_albedo = textured ? Image(W, H) : Image();
    auto albedo_at_guide = [&](int x, int y, int patch) -> Rgb {
        return textured ? get(guide_albedo, x, y) : Rgb(scene.material_of(static_cast<std::size_t>(patch)).albedo);
    };
    std::vector<long> camera_rays(H, 0), shadow_rays(H, 0), gather_rays(H, 0), bias_rays(H, 0), lookups(H, 0),
        across(H, 0);
    // Spread over a team, this process computes its rows in passes 1 and 3, and they
    // are shared after each: every member filters the whole image.
    const RowShare block(run.team, H);

    // Pass 1: the guide sample of every pixel: G-buffer, indirect light, and with
    // spp = 1 (where the guide is the pixel's only sample) direct light. With spp > 1
    // the guide lies anywhere in its pixel, drawn anew every pass.
    const GBuffer gbuffer = make_gbuffer(scene, caster, camera, run.threads, PixelPoints{o.spp > 1, run.seed, o.pass});
    long rows_done = 0;
    std::mutex progress_lock;
    auto row_done = [&](const char* phase, const Clock::time_point& start) {
        if (!run.progress) return;
        const std::lock_guard<std::mutex> lock(progress_lock);
        run.report(phase, ++rows_done, block.count(), std::chrono::duration<double>(Clock::now() - start).count());
    };
    parallel_rows(block.count(), run.threads, [&](int row) {
        const int y = block.row(row);
        // Counted here and stored once a row: rows side by side belong to different
        // threads, and counters next to each other in memory would share a cache line.
        long cam = 0, shadow = 0, gathered = 0, probed = 0;
        for (int x = 0; x < W; ++x) {
            const std::size_t p = static_cast<std::size_t>(y) * W + x;
            ++cam;
            const GSample& s = gbuffer.at(x, y);
            const Vec3& d = s.direction;
            if (s.patch < 0 && o.spp == 1) put(r.direct, x, y, background(scene, d));  // the sky, or black
            if (s.patch < 0 || !s.front) continue;                        // a back side: black
            sampling::Rng rng(run.seed, sampling::streams::kGuidePixels(o.pass, p, 32));
            guide_patch[p] = s.patch;
            if (textured) put(guide_albedo, x, y, scene.albedo_at(static_cast<std::size_t>(s.patch), s.point));
            const Vec3 n = g.shading_normal(s.patch, s.b1, s.b2, -d);
            put(r.normal, x, y, n);
            put(r.depth, x, y, Rgb::Constant(s.depth));
            put(r.position, x, y, s.point);
            if (o.spp == 1) {
                Rgb direct = scene.material_of(s.patch).emission +
                             g.direct(s.patch, s.point, n, -d, o.direct_samples, rng, shadow);
                if (scene.material_of(s.patch).glossy() && o.glossy_rays > 0)
                    direct += g.glossy(s.patch, s.point, n, -d, o.glossy_rays, rng, gathered);
                put(r.direct, x, y, direct);
            }
            if (!probe) {
                put(r.indirect, x, y, g.indirect(s.patch, s.point, n, -d, o.gather_rays, rng, gathered));
                continue;
            }
            sampling::Rng probe_rng(run.seed, sampling::streams::kBiasPixels(o.pass, p, 32));
            BiasProbe bp{o.bias_probe, probe_rng};
            put(r.indirect, x, y, g.indirect(s.patch, s.point, n, -d, o.gather_rays, rng, gathered, &bp));
            put(field_error, x, y, bp.error);
            probed += bp.rays;
        }
        camera_rays[y] = cam;
        shadow_rays[y] = shadow;
        gather_rays[y] = gathered;
        bias_rays[y] = probed;
        row_done("final gather", t0);
    });
    for (Image* image : {&r.direct, &r.indirect, &field_error, &r.normal, &r.depth, &r.position}) block.share(*image);
    block.share(guide_patch);
    if (textured) block.share(guide_albedo);
    const auto t1 = Clock::now();

    // Pass 2: filter the incident indirect light.
    const double depth_scale = 1.0 / ((camera.eye() - scene.bounds_center()).norm() + scene.bounds_radius());
    // Positions (for A-Trous) relative to the scene's centre, over the same scale as depth.
    if (run.progress) run.progress({"filter", 0, 1, 0.0});
    FilterOptions filter = o.filter;
    if (filter.radius == 0) filter.radius = auto_filter_radius(W, H, o.gather_rays);
    r.filter_radius = filter.radius;
    r.indirect_filtered = filter_indirect(r.indirect, r.normal, r.depth, r.position, scene.bounds_center(),
                                          depth_scale, depth_scale, filter, run.threads);
    // With the probe: E with its corrections, filtered (for a linear filter that is
    // filtered E plus the filtered corrections); the image adds the difference below.
    const bool corrected = probe && o.corrected_image;
    Image corrected_filtered, corrected_indirect;
    if (corrected) {
        corrected_indirect = r.indirect;
        for (std::size_t k = 0; k < corrected_indirect.rgb.size(); ++k) corrected_indirect.rgb[k] += field_error.rgb[k];
        corrected_filtered = filter_indirect(corrected_indirect, r.normal, r.depth, r.position, scene.bounds_center(),
                                             depth_scale, depth_scale, filter, run.threads);
        r.corrected_bias = Image(W, H);
    }
    // What the filter and the field take from the truth, as the image reads them.
    r.bias = Image(W, H);
    r.bias_probed = probe || o.correction > 0.0;
    parallel_bands(H, run.threads, [&](int y0, int y1) {
        for (int y = y0; y < y1; ++y)
            for (int x = 0; x < W; ++x) {
                const int patch = guide_patch[static_cast<std::size_t>(y) * W + x];
                if (patch < 0) continue;
                const Rgb albedo = albedo_at_guide(x, y, patch);
                put(r.bias, x, y,
                    albedo * (get(r.indirect_filtered, x, y) - get(r.indirect, x, y) - get(field_error, x, y)));
                if (corrected)
                    put(r.corrected_bias, x, y,
                        albedo * (get(corrected_filtered, x, y) - get(corrected_indirect, x, y)));
            }
    });
    // What the probe's corrections add to the guide's filtered E.
    auto added = [&](int x, int y) {
        return corrected ? Rgb(get(corrected_filtered, x, y) - get(r.indirect_filtered, x, y)) : Rgb(Rgb::Zero());
    };
    Image correction_added = corrected ? Image(W, H) : Image();
    if (run.progress) run.progress({"filter", 1, 1, std::chrono::duration<double>(Clock::now() - t1).count()});
    const auto t2 = Clock::now();

    // Pass 3: compose. With spp > 1 the pixel is the mean of spp camera samples (on a
    // jittered grid, sampling/strata.h) that compute their own direct light and look
    // the indirect light up at the guides, plus what the camera sees unlit (emission,
    // the sky) from their own rays or from `emission_samples` rays of their own; the
    // direct AOV is the pixel less its indirect light.
    rows_done = 0;
    const sampling::Strata strata(o.spp), emission_strata(std::max(1, o.emission_samples));
    const bool emission_apart = o.emission_samples > 0;
    parallel_rows(block.count(), run.threads, [&](int row) {
        const int y = block.row(row);
        std::vector<Vec3> cand_n;
        std::vector<double> cand_d;
        std::vector<std::pair<int, int>> cand_xy;
        long cam = 0, shadow = 0, gathered = 0, looked = 0, crossed = 0;  // stored once a row, as in pass 1
        for (int x = 0; x < W; ++x) {
            const std::size_t p = static_cast<std::size_t>(y) * W + x;
            Rgb sum = Rgb::Zero(), more = Rgb::Zero();  // more: the probe's corrections
            if (o.spp == 1) {
                sum = get(r.direct, x, y);  // the background's sky, if any, on a guide that met nothing
                if (guide_patch[p] >= 0) {
                    const Rgb albedo = albedo_at_guide(x, y, guide_patch[p]);
                    sum += albedo * get(r.indirect_filtered, x, y);
                    more = albedo * added(x, y);
                }
            } else {
                // A stream of its own, so that the guide pass is the same with any spp.
                sampling::Rng rng(run.seed, sampling::streams::kSamplePixels(o.pass, p, 32));
                Rgb direct = Rgb::Zero(), seen = Rgb::Zero();
                for (int s = 0; s < o.emission_samples; ++s) {
                    const double r1 = rng.uniform(), r2 = rng.uniform();
                    const auto [fx, fy] = emission_strata.point(s, r1, r2);
                    const Vec3 d = camera.direction(x + fx, y + fy);
                    ++cam;
                    const auto hit = caster.intersect(camera.eye(), d);
                    if (!hit.valid())
                        seen += background(scene, d);
                    else if (patches[hit.patch].normal.dot(d) < 0.0)
                        seen += scene.material_of(hit.patch).emission;
                }
                if (emission_apart) seen /= o.emission_samples;
                for (int s = 0; s < o.spp; ++s) {
                    const double r1 = rng.uniform(), r2 = rng.uniform();
                    auto [fx, fy] = strata.point(s, r1, r2);
                    fx += x;
                    fy += y;
                    const Vec3 d = camera.direction(fx, fy);
                    ++cam;
                    const auto hit = caster.intersect(camera.eye(), d);
                    if (!hit.valid() && !emission_apart) {
                        sum += background(scene, d);
                        direct += background(scene, d);
                    }
                    if (!hit.valid() || patches[hit.patch].normal.dot(d) >= 0.0) continue;
                    const Vec3 point = camera.eye() + hit.t * d;
                    const Vec3 n = g.shading_normal(hit.patch, hit.b1, hit.b2, -d);
                    Rgb L = g.direct(hit.patch, point, n, -d, o.direct_samples, rng, shadow);
                    if (!emission_apart) L += scene.material_of(hit.patch).emission;
                    if (scene.material_of(hit.patch).glossy() && o.glossy_rays > 0)
                        L += g.glossy(hit.patch, point, n, -d, o.glossy_rays, rng, gathered);
                    direct += L;
                    // The guide pixels of the block x0..x0+size-1, y0..y0+size-1.
                    auto candidates = [&](int x0, int y0, int size) {
                        cand_n.clear();
                        cand_d.clear();
                        cand_xy.clear();
                        for (int dy = 0; dy < size; ++dy)
                            for (int dx = 0; dx < size; ++dx) {
                                const int cx = std::clamp(x0 + dx, 0, W - 1), cy = std::clamp(y0 + dy, 0, H - 1);
                                if (guide_patch[static_cast<std::size_t>(cy) * W + cx] < 0) continue;
                                cand_n.push_back(get(r.normal, cx, cy).matrix());
                                cand_d.push_back(r.depth.at(cx, cy)[0]);
                                cand_xy.emplace_back(cx, cy);
                            }
                    };
                    auto across_depth = [&](int c) {
                        return std::abs(cand_d[static_cast<std::size_t>(c)] - hit.t) > 0.1 * hit.t;
                    };
                    // The pixel's own guide where it lies on the sample's surface (a point
                    // of the pixel drawn as the sample is: E there has the sample's E as
                    // its mean); else the nearest guide on that surface among the nine
                    // pixels around; else the most similar of the four guides around the
                    // sample point (003), and where that one lies across a depth
                    // discontinuity (near a thin object's edge), of the nine.
                    int best = -1;
                    if (guide_patch[p] >= 0 && on_surface(gbuffer.at(x, y), get(r.normal, x, y).matrix(), point, n, hit.t)) {
                        candidates(x, y, 1);
                        best = 0;
                    } else {
                        candidates(x - 1, y - 1, 3);
                        double nearest = std::numeric_limits<double>::infinity();
                        for (std::size_t c = 0; c < cand_xy.size(); ++c) {
                            const GSample& gs = gbuffer.at(cand_xy[c].first, cand_xy[c].second);
                            const double d2 = (gs.point - point).squaredNorm();
                            if (d2 < nearest && on_surface(gs, cand_n[c], point, n, hit.t)) {
                                nearest = d2;
                                best = static_cast<int>(c);
                            }
                        }
                        if (best < 0) {
                            candidates(static_cast<int>(std::floor(fx - 0.5)), static_cast<int>(std::floor(fy - 0.5)), 2);
                            best = most_similar_guide(n, hit.t, cand_n, cand_d);
                            if (best >= 0 && across_depth(best)) {
                                candidates(x - 1, y - 1, 3);
                                best = most_similar_guide(n, hit.t, cand_n, cand_d);
                            }
                        }
                    }
                    if (best >= 0) {
                        const auto [bx, by] = cand_xy[static_cast<std::size_t>(best)];
                        const Rgb albedo = scene.albedo_at(hit.patch, point);
                        L += albedo * get(r.indirect_filtered, bx, by);
                        more += albedo * added(bx, by);
                        ++looked;
                        if (across_depth(best)) ++crossed;
                    }
                    sum += L;
                }
                put(r.direct, x, y, direct / o.spp + seen);
                sum = sum / o.spp + seen;
                more /= o.spp;
            }
            put(r.image, x, y, sum);
            if (corrected) put(correction_added, x, y, more);
        }
        camera_rays[y] += cam;
        shadow_rays[y] += shadow;
        gather_rays[y] += gathered;
        lookups[y] = looked;
        across[y] = crossed;
        if (o.spp > 1) row_done("final gather (samples)", t2);
    });
    block.share(r.image);
    block.share(r.direct);
    if (corrected) {
        block.share(correction_added);
        r.corrected = r.image;
        for (std::size_t k = 0; k < r.corrected.rgb.size(); ++k) r.corrected.rgb[k] += correction_added.rgb[k];
    }
    for (auto* counts : {&camera_rays, &shadow_rays, &gather_rays, &bias_rays, &lookups, &across}) block.share(*counts);
    const auto t3 = Clock::now();
    for (int y = 0; y < H; ++y) {
        r.camera_rays += camera_rays[y];
        r.shadow_rays += shadow_rays[y];
        r.gather_rays += gather_rays[y];
        r.bias_rays += bias_rays[y];
        r.lookups += lookups[y];
        r.lookups_across += across[y];
    }
    r.seconds_guides = std::chrono::duration<double>(t1 - t0).count();
    r.seconds_filter = std::chrono::duration<double>(t2 - t1).count();
    r.seconds_samples = std::chrono::duration<double>(t3 - t2).count();
    return r;
}

}  // namespace raybundle::render
