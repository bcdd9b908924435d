#pragma once
// The continuous global visibility map (004 section 5.1.2) with CGAL planar
// arrangements: the reference the discrete backends are measured against.
//
// Parameters: none (BackendOptions are ignored: no pixels, no jitter).
//
// All patch edges are projected onto the plane perpendicular to w and inserted into a
// CGAL Arrangement_2 with the batch sweep-line insert, using the exact-constructions
// kernel (the inexact one crashes in arrangements). Every face of the planar
// subdivision is covered by a fixed set of patches, found by walking the faces from
// the unbounded one and toggling the patches whose edges each crossed halfedge lies
// on. In a face the covering patches are sorted by depth along w, and every source
// directly followed by a receiver adds the face's exact area (converted to double once
// per face) to A(receiver, source). The depth order is taken at one point inside the
// face; where patches cross each other in 3-D, their intersection segments (found
// once, when the backend is made) are inserted too, so that no face straddles a
// change of order. CGAL lives in this backend's own translation unit.
#include "visibility/backend.h"

#include <memory>

namespace raybundle::visibility {

class ArrangementBackend final : public Backend {
public:
    // sky: also the sky entries (see TransferEntry).
    explicit ArrangementBackend(const scenes::Scene& scene, bool sky = false);
    ~ArrangementBackend() override;
    std::string name() const override { return "arrangement"; }
    int resolution() const override { return 0; }
    void transfer(const Vec3& direction, const Eigen::Vector2d& jitter, GeometryMatrix& out) override;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace raybundle::visibility
