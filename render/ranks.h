#pragma once
// The processes of one run under mpirun (docs/ranks.md): MPI ranks, each with the whole
// scene, each running its own deterministic share.
//
// Who does what:
//   - solve: rank r runs chains 2r and 2r + 1 (RunOptions::chain) and, of the n steps
//     the run gives a chain of the pipeline, steps r, r + R, r + 2R, ...; the field of
//     chain h of the run is the mean of chain h of every rank, weighted by the steps
//     each averages (weighted_mean(): gathered on rank 0, summed in rank order,
//     broadcast), so the result depends on the seed and the rank count only.
//   - scene: every rank prepares it, the contact search split among them
//     (scenes::PreparationTeam: rank r searches triangles r, r + R, ...; the lines
//     are swapped, so every rank makes the same cuts);
//   - final gather: rank r computes rows r, r + R, ... (sampling::Team), they are
//     shared, every rank filters the whole image.
//   - outputs, stats, messages: rank 0 alone. The other ranks' standard output and
//     error go to /dev/null; their errors reach rank 0 (below).
//
// Failures. Every exchange begins with an agreement (an MPI_Allreduce of "all well, or
// the lowest rank that failed"). A rank that fails (fail(), from main's handlers)
// enters the agreement with its message instead of the next exchange, and every rank
// leaves with the message of the lowest failed rank (RankFailed); rank 0 prints it as
// one line and every rank exits with its code. After finish() (the last exchange) only
// rank 0 works, and its failures are its own.
//
// Without mpirun in the environment (or in a build without MPI) there is one rank and
// no MPI call at all: the run is the single-process one, bit for bit.
#include "sampling/run.h"
#include "scenes/team.h"

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace raybundle::render {

// Another rank failed: its message (prefixed with its rank), and the exit code of all.
struct RankFailed : std::runtime_error {
    RankFailed(const std::string& what, int exit_code) : std::runtime_error(what), code(exit_code) {}
    int code;
};

class Ranks final : public sampling::Team, public scenes::PreparationTeam {
public:
    // MPI_Init where mpirun started the process (its environment says so); throws
    // std::runtime_error where mpirun started a build without MPI with more than one, and
    // RankFailed (code 2, its line already written by rank 0) where the ranks were started
    // with different commands.
    Ranks(int& argc, char**& argv);
    ~Ranks() override;  // MPI_Finalize
    Ranks(const Ranks&) = delete;
    Ranks& operator=(const Ranks&) = delete;

    int rank() const override { return rank_; }
    int size() const override { return size_; }
    bool leader() const { return rank_ == 0; }
    bool spread() const { return size_ > 1; }
    // "MPI (Open MPI 4.1.4)" or "none": what the build can do.
    static std::string library();

    void share_rows(void* data, std::size_t row_bytes, int rows) const override;
    // Every rank's bytes on every rank, in rank order (MPI_Allgatherv).
    std::vector<std::vector<char>> gather_all(const std::vector<char>& mine) const override;
    // The last exchange of a run (every rank gets there; throws RankFailed where one
    // failed): after it the leader writes, the others return.
    void finish() const override;
    // Sums and maxima over ranks (every rank gets them).
    long sum(long value) const override;
    double sum(double value) const override;
    int max(int value) const override;
    // Rank 0's value, on every rank.
    std::uint64_t from_leader(std::uint64_t value) const override;
    // sum_r n_r v_r / sum_r n_r over ranks, summed in rank order (zeros where every n_r is
    // 0); every rank passes a vector of the same size and gets the result in it.
    void weighted_mean(std::vector<double>& values, long n) const override;

    // This rank failed with `message` (one line) and exit code `code`: the leader prints
    // the line of the lowest failed rank, the others nothing; every rank's exit code.
    int fail(const std::string& message, int code);

private:
    // The agreement every exchange begins with (see above).
    void agree(const std::string* failure, int code) const;

    int rank_ = 0, size_ = 1;
    bool mpi_ = false;
    mutable bool finished_ = false;
};

}  // namespace raybundle::render
