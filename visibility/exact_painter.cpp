#include "visibility/exact_painter.h"

#include "visibility/centre_sort.h"
#include "visibility/exact_spans.h"
#include "visibility/pixel_pairs.h"
#include "visibility/raster.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace raybundle::visibility {

namespace {

using Backend_ = ExactPainterBackend;

constexpr double kKeySteps = 2147483648.0;  // depth keys over the bounding sphere's diameter
// Patch depths are clamped to [kLowest, kHighest]: 0 stays for "upstream of
// everything" (nothing, the sky), and a key + kTie never overflows an int32.
constexpr double kLowest = 2.0 * Backend_::kTie + 1.0;
constexpr double kHighest = 2147483647.0 - 2.0 * Backend_::kTie - 1.0;
constexpr std::int32_t kMarkedKey = 2147483647 - Backend_::kTie;  // no fragment is clearly downstream of it
constexpr int kTile = 16;                      // marked pixels are looked up by tiles of kTile^2
constexpr std::size_t kLookahead = 8;          // patches prefetched ahead of the one drawn
constexpr std::size_t kBandBytes = 512 << 10;  // a band of the map stays in a core's L2 cache

inline bool is_source(std::uint32_t id) { return (id & Backend_::kSource) != 0; }
// A receiver patch (not "nothing", not a marked pixel).
inline bool is_receiver(std::uint32_t id) { return !is_source(id) && id < Backend_::kMarked; }

}  // namespace

ExactPainterBackend::ExactPainterBackend(const scenes::Scene& scene, const BackendOptions& options,
                                         std::shared_ptr<const PatchArrays> arrays)
    : arrays_(patch_arrays(scene, std::move(arrays))),
      grid_(scene, arrays_, options.resolution > 0 ? options.resolution : default_resolution(scene), options.jitter),
      sky_(options.sky),
      kernels_(&best_span_kernels()) {
    const std::size_t n = arrays_->patches();
    if (n + 2 >= kMarked) throw std::length_error("exact-painter: more patches than ids");
    counts_.assign(n + 2, 0);
    sky_counts_.assign(n, 0);
    range_begin_.assign(n, 0);
    range_end_.assign(n, 0);
    const int W = grid_.width();
    // Rows per band: a power of two (a row's band is a shift) within the cache budget.
    const std::size_t budget = std::max<std::size_t>(1, kBandBytes / (3 * sizeof(std::uint32_t) * W));
    while ((std::size_t{2} << band_shift_) <= budget) ++band_shift_;
    band_rows_ = 1 << band_shift_;
    const std::size_t band_pixels = static_cast<std::size_t>(band_rows_) * W + kSpanSlack;
    a_.assign(band_pixels, kNone);  // never cleared: a pixel of depth key 0 holds `initial_` (see Band)
    k_.assign(band_pixels, 0);
    b_.assign(band_pixels, kNone);  // written before it is read: on a pixel's first fragment
    touched_.resize(n + 2);
    items_.resize(n);
    rows_.resize(n);
}

std::uint32_t ExactPainterBackend::key_of(std::uint32_t id, int x, int y) const {
    const std::uint32_t i = id & kIndex;
    return i < arrays_->patches() ? span_key(items_[i].plane, x, y) : 0;  // nothing, the sky: upstream of all
}

bool ExactPainterBackend::after(std::uint32_t g, std::uint32_t kg, std::uint32_t a, std::uint32_t ka) {
    if (kg > ka + kTie) return true;
    if (kg + kTie < ka) return false;
    // A tie (pixel_pairs.h, order_ties): receivers first; of two facing the same way,
    // the higher index in front: upstream among receivers, downstream among sources.
    if (is_source(g) != is_source(a)) return is_source(g);
    return is_source(g) ? (g & kIndex) > (a & kIndex) : (g & kIndex) < (a & kIndex);
}

template <class Emit>
bool ExactPainterBackend::place(PixelState& s, std::uint32_t g, std::uint32_t kg, int x, int y, Emit&& emit) const {
    if (after(g, kg, s.a, s.ka)) {
        if (!is_source(g) && is_source(s.a)) emit(g, s.a, +1);
        s.b = s.a;
        s.a = g;
        s.ka = kg;
        return true;
    }
    if (!after(g, kg, s.b, key_of(s.b, x, y))) return false;
    // Between B and A: A now sees g instead of B, and g sees B.
    if (is_receiver(s.a) && is_source(s.b)) emit(s.a, s.b, -1);
    if (!is_source(g) && is_source(s.b)) emit(g, s.b, +1);
    if (is_receiver(s.a) && is_source(g)) emit(s.a, g, +1);
    s.b = g;
    return true;
}

void ExactPainterBackend::correct(std::uint32_t receiver, std::uint32_t source, int delta) {
    corrections_.push_back({static_cast<std::uint64_t>(receiver & kIndex) << 32 | (source & kIndex), delta});
}

void ExactPainterBackend::count_sky_back(std::uint32_t j) {
    if (sky_counts_[j] == 0) sky_touched_.push_back(j);
    ++sky_counts_[j];
}

// The slow path of the pass: a fragment not clearly downstream of the occupant. p is
// the pixel's index in the band, (x, y) the pixel.
void ExactPainterBackend::place_slow(std::size_t p, int x, int y, std::uint32_t g, std::uint32_t kg) {
    if (k_[p] == kMarkedKey) return;  // (never called for a pixel of key 0: any key is in order there)
    PixelState s{a_[p], static_cast<std::uint32_t>(k_[p]), b_[p]};
    const bool in_order = after(g, kg, s.a, s.ka);
    if (!place(s, g, kg, x, y, [&](std::uint32_t r, std::uint32_t src, int d) { correct(r, src, d); })) {
        a_[p] = kMarked;
        k_[p] = kMarkedKey;
        marked_.push_back(static_cast<std::uint32_t>(p));
        return;
    }
    if (!in_order) ++repairs_.inserted;
    a_[p] = s.a;
    k_[p] = static_cast<std::int32_t>(s.ka);
    b_[p] = s.b;
}

void ExactPainterBackend::transfer(const Vec3& w, const Eigen::Vector2d& jitter, GeometryMatrix& out) {
    out.direction = w;
    out.entries.clear();
    corrections_.clear();
    pending_.clear();
    repairs_ = {};
    grid_.project(w, jitter);
    const int W = grid_.width();
    const std::size_t n = arrays_->patches();
    initial_ = sky_ ? static_cast<std::uint32_t>(n) | kSource : kNone;

    // Per patch, in index order (the arrays are read in sequence; drawing then visits
    // the items in the painter's order): which way it faces, its depth key as an affine
    // function of the pixel, its corners and the rows it covers. The ray of pixel (x, y)
    // is q + t w with q = origin + x du + y dv
    // on the map's plane through the scene's centre; the patch's plane n . x = c meets
    // it at t = (c - n . q) / (n . w), the depth from the centre. The patch's own depth
    // range clamps it: pixel centres of the snapped triangle may lie a hair outside the
    // real one, where a nearly edge-on plane runs far.
    const double radius = grid_.radius();
    const double scale = kKeySteps / (2.0 * radius);
    const Vec3 origin = grid_.pixel_point(0, 0);
    const Vec3 du = grid_.pixel_point(1, 0) - origin, dv = grid_.pixel_point(0, 1) - origin;
    const Vec3 center = grid_.center();
    const auto& [positions, corners, normals, centroids, offsets] = *arrays_;
    vertex_keys_.resize(positions.size());
    for (std::size_t v = 0; v < positions.size(); ++v)
        vertex_keys_[v] = (w.dot(positions[v] - center) + radius) * scale;
    for (std::uint32_t i = 0; i < n; ++i) {
        Item& it = items_[i];
        rows_[i] = {1, 0};  // none, unless it covers pixel centres
        const double nw = normals[i].dot(w);
        if (nw == 0.0) continue;  // edge-on: no projected area, blocks nothing
        DepthPlane& pl = it.plane;
        const double inv = scale / nw;
        pl.row0 = (offsets[i] - normals[i].dot(origin)) * inv + radius * scale;
        pl.dx = -normals[i].dot(du) * inv;
        pl.dy = -normals[i].dot(dv) * inv;
        const double k0 = vertex_keys_[corners[3 * i]], k1 = vertex_keys_[corners[3 * i + 1]],
                     k2 = vertex_keys_[corners[3 * i + 2]];
        // floor and ceil of the range, clamped (conversions truncate: no libm calls here)
        const double lo = std::max(std::min({k0, k1, k2}), kLowest), hi = std::min(std::max({k0, k1, k2}), kHighest);
        const auto lo_floor = static_cast<std::int64_t>(lo), hi_trunc = static_cast<std::int64_t>(hi);
        pl.lo = std::min(static_cast<double>(lo_floor), kHighest);
        pl.hi = std::max(static_cast<double>(hi_trunc + (static_cast<double>(hi_trunc) < hi ? 1 : 0)), kLowest);
        // Corners in sub-pixel units (integers >= 0), and the rows whose centres
        // (y + 1/2) lie within the triangle's extent.
        double X[3], Y[3];
        grid_.triangle(i, X, Y);
        for (int k = 0; k < 3; ++k) {
            it.X[k] = static_cast<std::int32_t>(X[k]);
            it.Y[k] = static_cast<std::int32_t>(Y[k]);
        }
        constexpr std::int32_t S = static_cast<std::int32_t>(kSubpixel);
        const std::int32_t ymin = std::min({it.Y[0], it.Y[1], it.Y[2]}) - S / 2;
        const std::int32_t ymax = std::max({it.Y[0], it.Y[1], it.Y[2]}) - S / 2;
        rows_[i] = {ymin <= 0 ? 0 : (ymin + S - 1) / S, std::min(ymax < 0 ? -1 : ymax / S, W - 1)};
        it.id = nw > 0.0 ? i | kSource : i;
        it.pending_begin = it.pending_end = 0;
    }
    sort_by_centre(w, normals, centroids, center, radius, keys_, scratch_);

    // Each band's patches, in the painter's order: a counting sort by band.
    const int bands = ((W - 1) >> band_shift_) + 1;
    band_start_.assign(static_cast<std::size_t>(bands) + 1, 0);
    for (const auto& [first, last] : rows_)
        if (first <= last)
            for (int b = first >> band_shift_; b <= last >> band_shift_; ++b) ++band_start_[b + 1];
    for (int b = 0; b < bands; ++b) band_start_[b + 1] += band_start_[b];
    band_items_.resize(band_start_.back());
    band_fill_.assign(band_start_.begin(), band_start_.end() - 1);
    for (const std::uint64_t key : keys_) {
        const std::uint32_t i = sorted_patch(key);
        const auto [first, last] = rows_[i];
        if (first > last) continue;
        for (int b = first >> band_shift_; b <= last >> band_shift_; ++b) band_items_[band_fill_[b]++] = i;
    }

    for (int b = 0; b < bands; ++b) draw_band(b, out);
    finish_entries(out);
}

// One band of rows: every patch over it drawn in the sorted order, then the band's
// marked pixels resolved and its sky pairs counted. Receivers that reach into a later
// band keep their counts pending until their last band.
void ExactPainterBackend::draw_band(int band, GeometryMatrix& out) {
    const int W = grid_.width();
    const int y_first = band * band_rows_, y_end = std::min(W, y_first + band_rows_);
    const std::size_t pixels = static_cast<std::size_t>(y_end - y_first) * W;
    std::fill(k_.begin(), k_.begin() + static_cast<std::ptrdiff_t>(pixels), 0);  // (A needs no clearing)
    marked_.clear();
    const SpanKernels& kernels = *kernels_;
    const Band map{a_.data(), k_.data(), b_.data(), W, y_first, y_end, initial_};

    const std::size_t end = band_start_[band + 1];
    for (std::size_t t = band_start_[band]; t < end; ++t) {
        // Patches come in depth order, scattered over memory: fetch one a few ahead.
        if (t + kLookahead < end) {
            const char* ahead = reinterpret_cast<const char*>(&items_[band_items_[t + kLookahead]]);
            __builtin_prefetch(ahead);
            __builtin_prefetch(ahead + sizeof(Item) - 1);
        }
        Item& item = items_[band_items_[t]];
        const Triangle tri{item.X, item.Y, item.plane, item.id};
        slow_.clear();
        if (is_source(item.id)) {
            // A source: it becomes what the next receiver downstream sees.
            kernels.source(map, tri, slow_);
            for (const SlowPixel& s : slow_) place_slow(s.p, s.x, s.y, tri.id, s.key);
            continue;
        }
        // A receiver: read what it sees, then become the occupant. Consecutive pixels
        // mostly see the same source: the kernels count runs.
        const std::uint32_t i = item.id;
        SourceCounts seen{counts_.data(), touched_.data(), 0, kNone, 0};
        for (std::uint32_t k = item.pending_begin; k < item.pending_end; ++k) {  // from earlier bands
            const auto [j, c] = pending_[k];
            seen.touched[seen.touched_count++] = j;
            counts_[j] = c;
        }
        item.pending_end = item.pending_begin;
        kernels.receiver(map, tri, seen, slow_);
        for (const SlowPixel& s : slow_) place_slow(s.p, s.x, s.y, i, s.key);
        flush_run(seen);
        const std::uint32_t* const touched = touched_.data();
        const std::uint32_t n_touched = seen.touched_count;
        if (rows_[i].second >= y_end) {
            // Pending until the receiver's last band.
            item.pending_begin = static_cast<std::uint32_t>(pending_.size());
            for (std::uint32_t k = 0; k < n_touched; ++k) {
                pending_.push_back({touched[k], counts_[touched[k]]});
                counts_[touched[k]] = 0;
            }
            item.pending_end = static_cast<std::uint32_t>(pending_.size());
        } else {
            range_begin_[i] = static_cast<std::uint32_t>(out.entries.size());
            for (std::uint32_t k = 0; k < n_touched; ++k) {
                out.entries.push_back({i, touched[k], static_cast<double>(counts_[touched[k]])});  // pixels until the end
                counts_[touched[k]] = 0;
            }
            range_end_[i] = static_cast<std::uint32_t>(out.entries.size());
        }
    }
    if (!marked_.empty()) resolve_marked(band);
    if (sky_) {
        // Sources left as occupants see the open sky along -w (marked pixels' in resolve_marked()).
        const std::size_t n = arrays_->patches();
        for (std::size_t p = 0; p < pixels; ++p)
            if (k_[p] != 0 && is_source(a_[p]) && (a_[p] & kIndex) < n) count_sky_back(a_[p] & kIndex);
    }
}

// The band's marked pixels: every patch over them drawn once more into per-pixel lists
// (in the pass's order), the pass's pairs there taken back by replaying it, and the
// lists sorted by depth and paired.
void ExactPainterBackend::resolve_marked(int band) {
    const int W = grid_.width();
    const int y_first = band * band_rows_, y_end = std::min(W, y_first + band_rows_);
    const int tiles_x = (W + kTile - 1) / kTile, tiles_y = (y_end - y_first + kTile - 1) / kTile;
    marked_tiles_.assign(static_cast<std::size_t>(tiles_x) * tiles_y, 0);
    for (const std::uint32_t p : marked_) marked_tiles_[(p / W / kTile) * tiles_x + (p % W) / kTile] = 1;
    repairs_.listed += marked_.size();

    fragments_.clear();
    std::uint32_t order = 0;
    for (std::size_t t = band_start_[band]; t < band_start_[band + 1]; ++t) {
        const Item& item = items_[band_items_[t]];
        const double X[3] = {double(item.X[0]), double(item.X[1]), double(item.X[2])};
        const double Y[3] = {double(item.Y[0]), double(item.Y[1]), double(item.Y[2])};
        // Tiles under the triangle's bounding box.
        auto tile = [&](double v, int first, int count) {
            return std::clamp((static_cast<int>(v / kSubpixel) - first) / kTile, 0, count - 1);
        };
        const int tx0 = tile(std::min({X[0], X[1], X[2]}), 0, tiles_x), tx1 = tile(std::max({X[0], X[1], X[2]}), 0, tiles_x);
        const int ty0 = tile(std::min({Y[0], Y[1], Y[2]}), y_first, tiles_y),
                  ty1 = tile(std::max({Y[0], Y[1], Y[2]}), y_first, tiles_y);
        bool hit = false;
        for (int ty = ty0; ty <= ty1 && !hit; ++ty)
            for (int tx = tx0; tx <= tx1 && !hit; ++tx) hit = marked_tiles_[static_cast<std::size_t>(ty) * tiles_x + tx];
        if (!hit) continue;
        rasterize_triangle(X, Y, 0, W, y_first, y_end, [&](int y, int x0, int x1) {
            const std::size_t row = static_cast<std::size_t>(y - y_first) * W;
            for (int x = x0; x < x1; ++x)
                if (k_[row + x] == kMarkedKey)
                    fragments_.push_back(
                        {static_cast<std::uint32_t>(row + x), item.id, span_key(item.plane, x, y), order++});
        });
    }
    repairs_.listed_fragments += fragments_.size();
    std::sort(fragments_.begin(), fragments_.end(), [](const Fragment& f, const Fragment& g) {
        return f.pixel < g.pixel || (f.pixel == g.pixel && f.order < g.order);
    });

    const std::size_t n = arrays_->patches();
    for (std::size_t f0 = 0; f0 < fragments_.size();) {
        std::size_t f1 = f0;
        while (f1 < fragments_.size() && fragments_[f1].pixel == fragments_[f0].pixel) ++f1;
        Fragment* first = fragments_.data() + f0;
        Fragment* last = fragments_.data() + f1;
        const int x = static_cast<int>(first->pixel % W), y = y_first + static_cast<int>(first->pixel / W);
        // Take back what the pass gave this pixel before it was marked.
        PixelState s{initial_, 0, kNone};
        for (Fragment* f = first; f != last; ++f)
            if (!place(s, f->id, f->key, x, y, [&](std::uint32_t r, std::uint32_t src, int d) { correct(r, src, -d); }))
                break;
        // Sort by depth (ties as everywhere: after()) and pair.
        for (Fragment* f = first + 1; f < last; ++f)
            for (Fragment* g = f; g > first && !after(g->id, g->key, g[-1].id, g[-1].key); --g) std::swap(*g, g[-1]);
        pairs_along(first, last, [](const Fragment& f) { return f.id & kIndex; },
                    [](const Fragment& f) { return is_source(f.id); }, sky_, static_cast<std::uint32_t>(n),
                    [&](std::uint32_t r, std::uint32_t src) {
                        if (r == n + 1)
                            count_sky_back(src);
                        else
                            correct(r, src, +1);
                    });
        f0 = f1;
    }
}

// The sky pairs of the sources nothing covers downstream, the corrections merged into
// their receivers' entries, and pixel counts turned into areas.
void ExactPainterBackend::finish_entries(GeometryMatrix& out) {
    const std::size_t n = arrays_->patches();
    std::sort(sky_touched_.begin(), sky_touched_.end());
    for (const std::uint32_t j : sky_touched_) {
        out.entries.push_back({static_cast<std::uint32_t>(n + 1), j, static_cast<double>(sky_counts_[j])});
        sky_counts_[j] = 0;
    }
    sky_touched_.clear();
    // Corrections, in pixels: each to its receiver's entry (a receiver's few sources,
    // searched linearly), or to a pair only the repairs made (looked up by the pair: on
    // a mesh of mixed sizes they run to thousands a direction).
    bool emptied = false;
    repaired_.clear();
    for (const Correction& c : corrections_) {
        const auto r = static_cast<std::uint32_t>(c.pair >> 32), src = static_cast<std::uint32_t>(c.pair);
        auto* first = out.entries.data() + range_begin_[r];
        auto* last = out.entries.data() + range_end_[r];
        auto* e = std::find_if(first, last, [&](const TransferEntry& x) { return x.source == src; });
        if (e == last) {
            const auto [at, added] = repaired_.try_emplace(c.pair, out.entries.size());
            if (added) {
                out.entries.push_back({r, src, static_cast<double>(c.delta)});
                continue;
            }
            e = out.entries.data() + at->second;
        }
        e->area += c.delta;
        emptied |= e->area == 0.0;
    }
    if (emptied)
        out.entries.erase(std::remove_if(out.entries.begin(), out.entries.end(),
                                         [](const TransferEntry& e) { return e.area == 0.0; }),
                          out.entries.end());
    const double pixel_area = grid_.pixel_area();
    for (auto& e : out.entries) e.area *= pixel_area;
}

}  // namespace raybundle::visibility
