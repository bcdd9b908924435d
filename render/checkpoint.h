#pragma once
// Checkpoints: a run's solver state in a file, written every so often while it solves
// (--checkpoint F, --checkpoint-every N steps or Ss seconds, and when the run is
// interrupted), read back to go on (--resume F) bit-identically: a run killed and
// resumed writes the image an uninterrupted run with the same seed writes.
//
// What a checkpoint holds: what the run is (its identity: the program's version, a
// hash of the scene as loaded, and every option that decides the result) and where it
// is (the steps each chain has done, the seconds so far, the convergence rows so far,
// each chain's Solver::save()). Resuming checks the identity first, and names the
// first difference. Outputs, --threads (the same result for any count), --quiet and the
// checkpoint flags themselves may differ.
//
// The file, in this machine's byte order:
//   "raybundle checkpoint 1\n", a u32 byte-order mark 0x01020304,
//   u64 length + the header (JSON), u64 count, per chain u64 length + its state,
//   u64 FNV-1a of every byte before.
// It is written to a temporary beside it and renamed, so a kill at any moment leaves
// the last complete checkpoint (or none).
#include "cli.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace raybundle::apps {

struct Checkpoint {
    nlohmann::json identity;
    long steps_done = 0;   // per chain, in the run's first (and only) round
    double seconds = 0.0;  // the solve's seconds before the checkpoint
    nlohmann::json rows = nlohmann::json::array();  // the convergence CSV's rows so far
    std::vector<std::string> states;                // Solver::save() per chain
};

// The options part of a run's identity, from the parsed command line (check_command).
nlohmann::json options_identity(const CLI::App& cmd);
// The whole identity: the options' and the scene's (a hash of its patches, materials,
// lights, sky and camera) and the program's version.
nlohmann::json run_identity(const Command& c, const scenes::Scene& scene);
// A 64-bit hash (FNV-1a) of an identity, for comparing runs without sending it whole
// (apps/ranks.h: every rank's against rank 0's).
std::uint64_t identity_hash(const nlohmann::json& identity);

void write_checkpoint(const std::string& path, const Checkpoint& checkpoint);
// Throws UsageError ("--resume F: ...") for a file that is not a complete checkpoint of
// this machine's byte order.
Checkpoint read_checkpoint(const std::string& path);
// Throws UsageError naming the first difference between the identities.
void require_same_run(const std::string& path, const nlohmann::json& saved, const nlohmann::json& now);

}  // namespace raybundle::apps
