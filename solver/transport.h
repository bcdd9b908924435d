#pragma once
// What every solver does with a geometry matrix: per-patch constants, the radiance a
// patch sends along a direction, and one bounce of light along A(w) (and -w).
//
// Vectors indexed by patch have two extra slots after the n patches, for the sky
// (004 section 6): slot n is the sky as a source along w (entries (i, n): receiver i
// sees open sky upstream), slot n+1 the sky as a source along -w (entries (n+1, j):
// nothing downstream of source j, so along -w it sees the sky). Their areas are zero,
// so what arrives there is dropped. Backends emit sky entries only when asked
// (BackendOptions::sky); a scene without sky never has them.
//
// Emission is the patches' own plus, with point or directional lights, the first shot: what they
// reflect of the lights' direct light (FirstShot). The lights then leave the
// iteration (004 section 9). With the diffuse shot (section 9.1) the direct light of
// the emissive patches is computed once, too: the patches' own emission is then only
// shown, and what moves along the geometry matrices starts from its reflection.
#include "sampling/run.h"
#include "solver/first_shot.h"
#include "solver/radiance_field.h"
#include "visibility/backend.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <vector>

namespace raybundle::solver {

using scenes::Rgb;
using scenes::Vec3;

struct ShotOptions {
    bool diffuse_shot = false;  // diffuse scenes only
};

class Transport {
public:
    // Computes the first shot when the scene has point or directional lights (building a ray caster),
    // and skips it when it has none; the diffuse shot when asked (throws
    // OptionError("diffuse_shot") for a scene with glossy materials), on run.threads
    // with progress through `run`. The shots cast their rays with `caster` where one is
    // given (the run's), else with one of their own.
    explicit Transport(const scenes::Scene& scene, ShotOptions options = {}, const sampling::RunOptions& run = {},
                       const scenes::RayCaster* caster = nullptr);

    // What the first shot did: point and directional lights, shadow rays, seconds
    // (zeros: skipped), and the same for the diffuse shot.
    struct ShotStats {
        std::size_t lights = 0, directional = 0;
        long shadow_rays = 0;
        double seconds = 0.0;
        std::size_t emitters = 0;  // diffuse shot
        std::size_t emitter_groups = 0;  // the groups sharing their shadow rays (solver/first_shot.h)
        long diffuse_rays = 0;
        double diffuse_seconds = 0.0;
    };
    const ShotStats& shot_stats() const { return shot_stats_; }
    // The decisions about the shots, for the run's record: "first_shot", "diffuse_shot".
    nlohmann::json decisions() const;

    std::size_t patches() const { return n_; }
    std::size_t slots() const { return n_ + 2; }  // patches and the two sky slots
    std::size_t sky_front() const { return n_; }
    std::size_t sky_back() const { return n_ + 1; }
    bool glossy() const { return glossy_; }
    // Whether the area lights' direct light was computed once (the maps carry the rest).
    bool diffuse_shot() const { return diffuse_shot_; }
    bool is_glossy(std::size_t j) const { return patch_glossy_[j] != 0; }
    const scenes::Scene& scene() const { return scene_; }

    // The direction of travel along which patch i receives when the matrix is used for
    // w alone (w) or for both w and -w (whichever of the two it faces).
    Vec3 arrival(std::size_t i, const Vec3& w, bool both) const {
        return both && normal_[i].dot(w) > 0.0 ? Vec3(-w) : w;
    }
    // The direction patch j sends along (the same rule from the source side).
    Vec3 departure(std::size_t j, const Vec3& w, bool both) const {
        return both && normal_[j].dot(w) < 0.0 ? Vec3(-w) : w;
    }

    // Radiance patch j emits towards `out` (front side) into the geometry matrices:
    // own emission plus the first shot's reflection (with the diffuse shot: its
    // reflection of the emitters' direct light instead of its own emission). For
    // diffuse patches it does not depend on `out`.
    Rgb emitted(std::size_t j, const Vec3& out) const {
        return !patch_glossy_[j] || hits_.empty() ? emitted_diffuse_[j] : emitted_glossy(j, out);
    }
    // What the image shows of patch j besides the reflection of the solved
    // irradiance: emitted(), plus the own emission with the diffuse shot.
    Rgb displayed(std::size_t j, const Vec3& out) const {
        return diffuse_shot_ ? emission_[j] + emitted(j, out) : emitted(j, out);
    }
    // The same, without the emitted radiance of the patches themselves (first shot only).
    Rgb shot_reflected(std::size_t j, const Vec3& out) const;
    // 4 pi f_j(in, out) irr: the radiance leaving j towards `out` due to irradiance
    // `irr` (cosine-weighted incoming radiance) that arrived travelling along `in`.
    Rgb reflected(std::size_t j, const Vec3& in, const Vec3& out, const Rgb& irr) const;
    // The diffuse 4 pi f = 4 albedo of patch j (what reflected() uses for diffuse patches).
    const Rgb& diffuse_reflectance(std::size_t j) const { return reflect_[j]; }

    // Per patch, the unit direction from its centroid to the camera (glossy scenes
    // accumulate the radiance sent that way).
    std::vector<Vec3> directions_to_eye() const;
    // The field from per-patch sums over `count` estimates: of irradiance in a
    // diffuse scene (L = shown + 4 albedo sum / count), of the radiance towards the
    // eye in a glossy one (L = shown towards the eye, front side only, + sum / count).
    // With a shot, the field's `direct` holds the shots' part of it.
    RadianceField field_from(const std::vector<Rgb>& sum, long count, const std::vector<Vec3>& to_eye,
                             int threads = 1) const;

    // Sets the two sky slots of an outgoing-radiance vector for direction w.
    void set_sky(const Vec3& w, std::vector<Rgb>& outgoing) const;

    // The cosine share of its incoming light that patch i is exposed to in one
    // gather() along w: |n_i . w| / 2 with `both` (each patch faces one of +-w, weight
    // 1/2), |n_i . w| when it faces against w alone, else 0. Over uniform directions its
    // mean is exactly 1/4. What the entries cover of it (exposure()) is this share in a
    // closed scene with exact visibility, less where the patch looks into the void or
    // where a rasterising backend's pixels miss.
    double receiving_share(std::size_t i, const Vec3& w, bool both) const {
        const double c = normal_[i].dot(w);
        return both ? 0.5 * std::abs(c) : std::max(0.0, -c);
    }
    // What one gather() along m exposes every patch to, as shares of its area times its
    // cosine (what gather() would give it of a radiance of 1): `lit[i]` over the entries
    // that bring it light (from a patch, or from the sky when the scene has one),
    // `seen[i]` over all its entries, the void's too (a sky slot in a scene without
    // sky: the backend emits them with BackendOptions::sky). Both are added to.
    void exposure(const visibility::GeometryMatrix& m, std::vector<double>& lit, std::vector<double>& seen, bool both,
                  double weight) const;
    // The patches' area-weighted mean emitted() radiance and diffuse albedo, per
    // channel (the ambient term's inputs).
    Rgb mean_emitted() const;
    Rgb mean_albedo() const;
    // The largest reflectance (diffuse albedo plus specular) of any patch in any channel:
    // what sets the burn-in and the high-albedo estimators (solver.h, kStableAlbedo).
    double max_reflectance() const;

    // next += weight * A(w) outgoing; with `both` also along -w (each entry carries
    // light from the receiver back to the source). Vectors have slots() entries.
    void gather(const visibility::GeometryMatrix& m, const std::vector<Rgb>& outgoing, std::vector<Rgb>& next,
                bool both, double weight) const;

private:
    void init(const FirstShot* shot, const std::vector<Rgb>* direct);
    Rgb emitted_glossy(std::size_t j, const Vec3& out) const;  // emitted() of a glossy patch lit by the first shot

    const scenes::Scene& scene_;
    std::size_t n_;
    bool glossy_;
    bool diffuse_shot_ = false;
    std::vector<double> inv_area_;  // slots(); zero at the sky slots
    std::vector<Vec3> normal_;
    std::vector<Rgb> emission_, shot_diffuse_, emitted_diffuse_, reflect_;
    // Per patch, the shots' direct light it reflects diffusely (RadianceField::direct);
    // empty without a shot.
    std::vector<Rgb> direct_reflected_;
    std::vector<char> patch_glossy_;
    // Glossy patches lit by point or directional lights: per patch, a range into hits_.
    std::vector<std::uint32_t> hit_begin_;
    std::vector<FirstShot::Hit> hits_;
    ShotStats shot_stats_;
};

}  // namespace raybundle::solver
