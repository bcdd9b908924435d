#pragma once
// Processes that prepare one scene together: MPI ranks (render/ranks.h), each holding the
// whole scene. Where a preparation step splits its items among them, member rank() of
// size() takes items rank(), rank() + size(), rank() + 2 size(), ... (dealt out in turn:
// neighbouring items cost alike) and the members then swap their results, so that every
// member ends with the same scene, bit for bit, as one process would make.
//
// The contact search (scenes/contacts.h) is split this way; the rest of the preparation
// (reading, refinement, the cuts themselves) is repeated by every member.
#include <vector>

namespace raybundle::scenes {

class PreparationTeam {
public:
    virtual ~PreparationTeam() = default;
    virtual int rank() const = 0;
    virtual int size() const = 0;
    // Every member calls it at the same point with its own bytes and gets every member's,
    // in member order. Throws where another member failed before it got there.
    virtual std::vector<std::vector<char>> gather_all(const std::vector<char>& mine) const = 0;
};

}  // namespace raybundle::scenes
