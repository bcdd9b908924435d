#pragma once
// What `raybundle check` shows of a scene, without solving it: its size and contents,
// what the camera sees, and the signs of surfaces modelled the wrong way round.
//
// Two signs of inverted winding, per object (two-sided materials never count):
//  - the camera sees the object's back side in more of its pixels than its front
//    (a closed mesh turned inside out: the camera looks at the backs of its far side);
//  - the front side of most of its area sees nothing: rays into its front hemisphere
//    all leave the scene (and there is no sky to see there), and the camera does not
//    see that front either (a floor or a wall facing out of the room): no pixel centre
//    meets it, and its centroid is out of the image, behind it or hidden from the eye
//    (so that a finely refined quad in view is seen, pixel centres or not).
// A front that lies face to face on another surface (a box's bottom on the floor, within
// the contact distance of scenes/contacts.h) is hidden, not inverted: it is counted as
// covered, not as unseen. But a light whose front is mostly covered sends its light into
// that surface (a lamp under a ceiling, facing up): a warning of its own. So is a camera
// whose eye is inside a closed object (it sees that object's back sides only).
#include "scenes/diagnostics.h"
#include "scenes/ray_caster.h"
#include "scenes/scene.h"

#include <string>
#include <vector>

namespace raybundle::render {

struct SceneSummary {
    std::size_t patches = 0, vertices = 0;
    scenes::Vec3 lo = scenes::Vec3::Zero(), hi = scenes::Vec3::Zero();  // bounding box
    double area = 0.0;
    std::size_t emissive_patches = 0, glossy_patches = 0, two_sided_patches = 0, coloured_patches = 0;
    double emissive_area = 0.0;
    std::size_t facing_camera = 0;   // patches whose front faces the eye
    std::size_t seen_by_camera = 0;  // patches whose front some camera ray meets first
    std::size_t unseen = 0;          // patches whose front sees nothing (see above)
    std::size_t covered = 0;         // patches whose front lies on another surface
    struct Object {
        std::string name;
        std::size_t patches = 0;
        double area = 0.0, unseen_area = 0.0, covered_area = 0.0;
        // A light's front just behind a one-sided surface (its back within the contact
        // distance, facing the same way: a lamp placed above its ceiling).
        double behind_area = 0.0;
        int behind = -1;  // that surface's object
        long front_pixels = 0, back_pixels = 0;  // camera rays meeting its front or back first
        bool two_sided = false;
        bool emissive = false;
        int covered_by = -1;  // the object whose surface its first covered patch lies on
    };
    std::vector<Object> objects;
    scenes::CoplanarOverlaps overlaps;
    // The camera's eye lies outside the bounding box, and the box's centre inside a shell
    // whose fronts face it (every ray from it in 26 directions meets a front): a room
    // closed on all sides seen from outside, or a closed object turned inside out.
    bool room_from_outside = false;
    // The object the eye is inside: of 26 rays from it, 18 or more meet a back side of
    // that object's one-sided patches first and none its front (-1: none).
    int camera_inside = -1;
    // Per directional light: the patches whose front faces it, and those it reaches
    // (their centroid unshadowed; where none is, the patches some point of which the
    // first shot finds lit: solver::sunlit_share).
    struct Sun {
        std::size_t facing = 0, reached = 0;
    };
    std::vector<Sun> suns;
};

// `max_pixels` > 0 casts the camera rays on a coarser grid of about that many pixels
// (the same image, fewer rays: for the warnings before a solve).
SceneSummary summarize(const scenes::Scene& scene, const scenes::RayCaster& caster, int threads = 1,
                       long max_pixels = 0);

// Whether anything lights the scene: an emissive patch, a point or directional light
// or a sky of positive radiance; kNoLight says why the image is black otherwise.
bool has_light(const scenes::Scene& scene);
inline constexpr const char* kNoLight =
    "no light (no emissive patch, point or directional light or sky above zero): the image is black";

// One line per directional light that no patch faces (it travels up, from below the
// ground?) or that reaches no patch (walls all round keep a sun out).
std::vector<std::string> light_warnings(const scenes::Scene& scene, const SceneSummary& summary);

// The coplanar overlaps' example by the objects' names: "'floor' (patch 18) and 'rug'
// (patch 452)", or "patches 3 and 9 of 'floor'".
std::string overlap_example(const scenes::Scene& scene, const scenes::CoplanarOverlaps& overlaps);

// One line per object that shows a sign of inverted winding.
std::vector<std::string> winding_warnings(const SceneSummary& summary);

// What `raybundle check` prints: the scene's patches, contacts, bounds, materials,
// lights, sky, camera, what the camera and the patches see, its objects and warnings.
std::string describe(const scenes::Scene& scene, const SceneSummary& summary);

}  // namespace raybundle::render
