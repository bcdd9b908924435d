#pragma once
// The exact painter: the global painter's algorithm (004 section 5.1.3) made exact per
// pixel. The default backend.
//
// Parameters (BackendOptions): resolution (int, pixels per side of the visibility map;
// default: default_resolution(scene)), jitter (bool, default true), sky (bool).
//
// Patches are drawn in the painter's order (sorted along w by their centres) into the
// painter's jittered map, but every pixel keeps, besides the patch drawn there last
// (its occupant A), A's exact depth at the pixel centre and the patch before A (B).
//
//   - A patch arriving downstream of A, the usual case, is drawn as by the painter:
//     a receiver reads A when A is a source, then it becomes the occupant.
//   - One arriving between B and A (the centre order is wrong at this pixel: a panel
//     hanging under a ceiling, a block standing on a floor, two walls meeting,
//     patches crossing) is inserted there, and the pixel's pairs are repaired: A no
//     longer sees B but the new patch, which sees B.
//   - One arriving upstream of B as well (a third patch out of order at one pixel;
//     rare) marks the pixel. After the pass, the patches over marked pixels are
//     drawn once more into per-pixel lists: the pairs the pass gave those pixels are
//     taken back (by replaying it), and the lists, sorted by exact depth, are paired
//     as by the global z-buffer.
//
// So every receiver is paired with the surface really in front of it at the pixel
// centre, whatever the patches' sizes, contacts or overlaps: the global z-buffer's
// matrix (section 5.1.5) at nearly the painter's cost.
//
// For speed (docs/benchmarks.md): the map is drawn in bands of rows that fit in a
// core's L2 cache, each band's patches in the painter's order (a receiver that reaches
// into a later band keeps its counts pending until then); the fast path runs in span
// kernels (exact_spans.h), 8 pixels a step with AVX2; per-patch records are made in
// index order and prefetched ahead of their turn.
//
// Depths are the patches' planes evaluated at the pixel centre, quantised to 31 bits
// over the bounding sphere's diameter (steps of 2^-30 of its radius) and clamped to the
// patch's own depth range. Depths within kTie steps are a tie, ordered as by every
// backend (pixel_pairs.h, order_ties): receivers first (a two-sided panel of two
// coincident opposite triangles never lets light through, however their depths round),
// then the higher index in front. Only coplanar overlapping patches facing the same way
// tie over an area; scenes::coplanar_overlaps() finds them.
#include "visibility/backend.h"
#include "visibility/exact_spans.h"
#include "visibility/map_grid.h"
#include "visibility/patch_arrays.h"

#include <cstdint>
#include <unordered_map>
#include <vector>

namespace raybundle::visibility {

class ExactPainterBackend final : public Backend {
public:
    // `arrays`: the scene's patch arrays shared with the other backends of a set (made
    // here where none is given).
    ExactPainterBackend(const scenes::Scene& scene, const BackendOptions& options,
                        std::shared_ptr<const PatchArrays> arrays = nullptr);
    std::string name() const override { return "exact-painter"; }
    int resolution() const override { return grid_.resolution(); }
    void transfer(const Vec3& direction, const Eigen::Vector2d& jitter, GeometryMatrix& out) override;
    std::string details() const override { return std::string("span kernels: ") + kernels_->name; }

    // The inner loops in use (best_span_kernels() unless told otherwise: tests compare them).
    void use_kernels(const SpanKernels& kernels) { kernels_ = &kernels; }

    // How the last transfer's out-of-order pixels were repaired: by insertion between
    // the occupant and the one before it, or (marked) from a sorted per-pixel list.
    struct Repairs {
        std::size_t inserted = 0;
        std::size_t listed = 0;           // marked pixels
        std::size_t listed_fragments = 0;  // patch fragments drawn again for them
    };
    const Repairs& repairs() const { return repairs_; }

    // A pixel's state: occupant, its depth key, the patch before it. Ids carry the
    // patch index and kSource for patches facing w.
    struct PixelState {
        std::uint32_t a, ka, b;
    };
    static constexpr std::uint32_t kSource = kSourceBit;
    static constexpr std::uint32_t kIndex = kSource - 1;
    static constexpr std::uint32_t kNone = kIndex;        // nothing (upstream of everything, no sky)
    static constexpr std::uint32_t kMarked = kIndex - 1;  // resolved from a list after the pass
    static constexpr std::uint32_t kTie = kDepthTie;      // depth steps within which two depths tie

private:
    std::uint32_t key_of(std::uint32_t id, int x, int y) const;
    // Whether g (depth kg) goes downstream of a (depth ka) at one pixel.
    static bool after(std::uint32_t g, std::uint32_t kg, std::uint32_t a, std::uint32_t ka);
    // Places fragment g (depth kg) at pixel (x, y) with state s, calling
    // emit(receiver, source, +-1) for the pairs it makes or undoes. False: g lies
    // upstream of B too, and the pixel must be resolved from its list.
    template <class Emit>
    bool place(PixelState& s, std::uint32_t g, std::uint32_t kg, int x, int y, Emit&& emit) const;
    void place_slow(std::size_t p, int x, int y, std::uint32_t g, std::uint32_t kg);
    void draw_band(int band, GeometryMatrix& out);
    void resolve_marked(int band);
    void correct(std::uint32_t receiver, std::uint32_t source, int delta);
    void count_sky_back(std::uint32_t source);
    void finish_entries(GeometryMatrix& out);

    std::shared_ptr<const PatchArrays> arrays_;  // read only
    MapGrid grid_;
    bool sky_;
    const SpanKernels* kernels_;
    int band_shift_ = 0, band_rows_;  // rows per band of the map: 2^band_shift_

    // Per direction.
    std::uint32_t initial_ = kNone;  // what a pixel starts with: nothing, or the open sky
    std::vector<double> vertex_keys_;
    std::vector<std::uint64_t> keys_, scratch_;
    // What drawing a patch needs, per patch (made in index order, read in the painter's).
    struct Item {
        DepthPlane plane;                  // its depth key over the map
        std::int32_t X[3], Y[3];           // projected corners, sub-pixel units
        std::uint32_t id;                  // patch index | kSource for a source
        std::uint32_t pending_begin, pending_end;  // a receiver's counts from earlier bands
    };
    std::vector<Item> items_;
    std::vector<std::pair<std::int32_t, std::int32_t>> rows_;  // first and last row per patch (first > last: none)
    std::vector<std::size_t> band_start_, band_fill_;
    std::vector<std::uint32_t> band_items_;  // per band, its patches in the painter's order
    // One band of the map: occupant, its depth, the one before (kSpanSlack spare).
    std::vector<std::uint32_t> a_;
    std::vector<std::int32_t> k_;
    std::vector<std::uint32_t> b_;
    std::vector<SlowPixel> slow_;  // the pixels a triangle hands back
    std::vector<std::uint32_t> counts_, touched_;  // the receiver being drawn: pixels per source
    std::vector<std::pair<std::uint32_t, std::uint32_t>> pending_;  // (source, pixels) of unfinished receivers
    std::vector<std::uint32_t> range_begin_, range_end_;  // each receiver's entries
    std::vector<std::uint32_t> sky_counts_, sky_touched_;  // sources that see the sky along -w
    struct Correction {
        std::uint64_t pair;  // receiver << 32 | source
        int delta;
    };
    std::vector<Correction> corrections_;
    std::unordered_map<std::uint64_t, std::size_t> repaired_;  // pairs only the repairs made -> their entry
    std::vector<std::uint32_t> marked_;  // pixels of the band
    struct Fragment {
        std::uint32_t pixel, id, key, order;
    };
    std::vector<Fragment> fragments_;
    std::vector<std::uint8_t> marked_tiles_;
    Repairs repairs_;
};

}  // namespace raybundle::visibility
