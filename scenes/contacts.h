#pragma once
// Surfaces that touch inside one another's patches, cut apart.
//
// A patch carries one radiance. Where another surface touches it inside (a partition
// standing on a floor that runs on under it into the next room, a block on a full
// floor, a light panel a hair under a full ceiling), one patch lies on both sides of
// the contact: it gathers light on the lit side and shows it on the dark one (light
// leaks through the partition), or averages the hidden floor under a block into the
// visible floor beside it (too dark). Modelling avoids this by cutting the floor at
// every wall; people do not model that way. So after refinement every patch is cut
// along its contact lines:
//
//   - transversal contacts: the segment where another triangle crosses or touches the
//     patch's plane (vertices that near it count as on it), clipped to the patch;
//   - parallel contacts: another triangle that lies that near the patch's plane (a
//     panel under a ceiling, a block's bottom on the floor, a decal, a rug): the edges
//     where its planar region ends (no coplanar neighbour across them), projected
//     onto the patch and clipped to it.
//
// Near: within 1e-3 of the scene's bounding radius and 1e-2 of the smaller triangle's
// size (a table top above a large ground plane does not touch it).
//
// A contact that crosses the patch's inside (not only its edges or corners) cuts the
// pieces of the patch its segment reaches along the line through it (not every piece
// the line crosses: a large patch under many short contacts would grow like the square
// of their count); the edges the line crosses are split with the patches on their
// other side, so the mesh stays conforming; an edge on the line is split
// where the contact ends inside it. Vertices nearer a line than 1e-3 of the patch's
// size count as on it, so no sliver is thinner than that. The edges on a contact
// segment (those of the cuts, and edges a contact already ran along) become contact
// edges: the patches on either side get vertices of their own there
// (Scene::contact_edge_handle), so that smooth shading, the final gather's
// interpolation and the linear basis do not carry light across. Neighbouring patches
// of one mesh (their contact is a shared edge) and the twin faces of two-sided
// materials are not cut: their contacts lie on patch edges. Cuts are local (only the
// patches a contact crosses), so the patch count grows with the contacts' length over
// the patch size.
#include "scenes/scene.h"
#include "scenes/team.h"

#include <cstddef>

namespace raybundle::scenes {

struct ContactCuts {
    std::size_t lines = 0;   // contact lines that cut a patch
    std::size_t splits = 0;  // edges split along them
    std::size_t edges = 0;   // mesh edges marked as contact edges (Scene::contact_edge_handle)
};

// Cuts the scene's patches along their contact lines and marks the contact edges;
// calls scene.finalize() when it changed anything or the mesh has faces the flat
// arrays do not (subdivide() with Finish::leave_mesh). The scene must be finalized
// before (bounds), and refined if it is to be (the loaders cut after subdivide()).
// The contact search runs on `threads` threads and, given a team of more than one, is
// split among its members (scenes/team.h), who must all call it at the same point with
// the same scene: the same cuts for any count of either.
ContactCuts cut_at_contacts(Scene& scene, int threads = 1, const PreparationTeam* team = nullptr);

// A scene not cut at contacts, on a team: its members meet where cut_at_contacts would
// exchange (so that members whose scenes differ in whether they cut stop with one line,
// not in mismatched exchanges). Nothing without a team of more than one.
void skip_contact_search(const Scene& scene, const PreparationTeam* team);

}  // namespace raybundle::scenes
