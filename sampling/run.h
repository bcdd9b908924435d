#pragma once
// What every long computation of a run shares (the solvers, the diffuse shot, the
// final gather): its seed and random streams, its threads, and how it reports
// progress. Passed down, never re-declared.
#include <cstddef>
#include <cstdint>
#include <algorithm>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace raybundle::sampling {

// Where a computation stands: `done` of `total` units of `phase`, `seconds` since it
// began. A computation calls the callback every RunOptions::progress_every units
// (about 100 times when 0) and once at the end; the callback must not throw.
struct Progress {
    const char* phase;  // "diffuse shot", "solve", "final gather", "filter", ...
    long done, total;
    double seconds;
    long round = 0;          // the round of a run made in rounds (render/progressive.h); 0: none
    double estimate = -1.0;  // the image's estimated relative error so far; negative: none yet
};
using ProgressCallback = std::function<void(const Progress&)>;

// The processes a run is spread over (MPI ranks, render/ranks.h), as the computations
// that split their work by rows see them (the final gather). Member k owns the rows
// k, k + size, k + 2 size, ... (dealt out in turn: neighbouring rows cost alike, so
// every member gets a like share of the sky, the floor, the light).
class Team {
public:
    virtual ~Team() = default;
    virtual int rank() const = 0;
    virtual int size() const = 0;
    // How many of `rows` rows member k owns.
    int rows_of(int member, int rows) const { return (rows - member + size() - 1) / size(); }
    // Every member calls it at the same point with the same `rows` and `row_bytes`,
    // its own rows of `data` filled; on return every member holds every row. Throws
    // (render/ranks.h: RankFailed) where another member failed before it got there.
    virtual void share_rows(void* data, std::size_t row_bytes, int rows) const = 0;
    // The collectives of a run spread over the team (render/run.h), each called by every
    // member at the same point: sums and maxima over the members, member 0's value, and
    // sum_k n_k v_k / sum_k n_k over members, summed in member order, in `values` on
    // every member (zeros where every n_k is 0). A team that shares rows only (a test's
    // threads) keeps these defaults, which are right for a team of one and refuse more.
    virtual long sum(long value) const { return alone(value); }
    virtual double sum(double value) const { return alone(value); }
    virtual int max(int value) const { return alone(value); }
    virtual std::uint64_t from_leader(std::uint64_t value) const { return alone(value); }
    virtual void weighted_mean(std::vector<double>& values, long n) const {
        if (alone(n) == 0) std::fill(values.begin(), values.end(), 0.0);
    }
    // The last exchange of a run: after it only member 0 works (writes the outputs).
    virtual void finish() const {}

private:
    template <class T>
    T alone(T value) const {
        if (size() > 1) throw std::logic_error("sampling::Team: a team of " + std::to_string(size()) + " without collectives");
        return value;
    }
};

struct RunOptions {
    std::uint64_t seed = 1;           // the same seed gives bit-identical results
    std::uint64_t jitter_stream = 0;  // which stream of map jitters (streams::kMapJitters)
    // Which independent chain of the run a solver is (its own directions, walks and
    // jitters; below streams::kMaxChains): the two halves of a run are chains 0 and 1.
    std::uint64_t chain = 0;
    int threads = 1;                  // results do not depend on it
    long progress_every = 0;          // units between progress calls (0: about 100 per phase)
    ProgressCallback progress;        // may be empty
    // Where the run is spread over processes: each computes its block of rows of the
    // final gather (more than one member; null: this process alone).
    const Team* team = nullptr;

    // Calls progress for unit `done` of `total` when the cadence says so.
    void report(const char* phase, long done, long total, double seconds) const {
        if (!progress) return;
        const long every = progress_every > 0 ? progress_every : (total >= 100 ? total / 100 : 1);
        if (done % every == 0 || done == total) progress({phase, done, total, seconds});
    }
};

}  // namespace raybundle::sampling
