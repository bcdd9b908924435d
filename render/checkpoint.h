#pragma once
// Checkpoints: a run's solver state in a file, written every so often while it solves
// (RunConfig::checkpoint, every so many steps or seconds, and when the run is
// interrupted), read back to go on (RunConfig::resume) bit-identically: a run killed
// and resumed writes the image an uninterrupted run with the same seed writes.
//
// What a checkpoint holds: what the run is (its identity: the program's version, a
// hash of the scene as loaded, and every option that decides the result) and where it
// is (the steps each chain has done, the seconds so far, the convergence rows so far,
// each chain's Solver::save()). Resuming checks the identity first, and names the
// first difference. The options part of the identity is the caller's (the command line
// gives every option that decides the result: outputs, threads, chatter and the
// checkpoint flags themselves may differ).
//
// The file, in this machine's byte order:
//   "raybundle checkpoint 1\n", a u32 byte-order mark 0x01020304,
//   u64 length + the header (JSON), u64 count, per chain u64 length + its state,
//   u64 FNV-1a of every byte before.
// It is written to a temporary beside it and renamed, so a kill at any moment leaves
// the last complete checkpoint (or none).
#include "render/image_io.h"
#include "scenes/machine.h"
#include "scenes/scene.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace raybundle::render {

// A checkpoint that cannot be read, or that another run wrote: the message begins with
// the file's name.
struct CheckpointError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

struct Checkpoint {
    nlohmann::json identity;
    long steps_done = 0;   // per chain, in the run's first (and only) round
    double seconds = 0.0;  // the solve's seconds before the checkpoint
    nlohmann::json rows = nlohmann::json::array();  // the convergence CSV's rows so far
    std::vector<std::string> states;                // Solver::save() per chain
};

// The whole identity: the options' (given by the caller) and the scene's (a hash of its
// patches, materials, lights, sky and camera) and the program's version.
nlohmann::json run_identity(const nlohmann::json& options, const scenes::Scene& scene);
// A 64-bit hash (FNV-1a) of an identity, for comparing runs without sending it whole
// (render/ranks.h: every rank's against rank 0's).
std::uint64_t identity_hash(const nlohmann::json& identity);

// Writes atomically (render::write_atomically; fsynced before the rename), its
// temporary registered with `tracker`. Throws std::runtime_error ("F: cannot write
// ...") where it cannot.
void write_checkpoint(const std::string& path, const Checkpoint& checkpoint, const TemporaryTracker& tracker = {});
// Throws CheckpointError ("F: ...") for a file that is not a complete checkpoint of
// this machine's byte order, or one larger than half of `memory` (what this process may
// hold: scenes::memory_share) before it is read.
Checkpoint read_checkpoint(const std::string& path, const scenes::MemoryShare& memory = scenes::memory_share());
// The same for a checkpoint's bytes (read_checkpoint once it has read the file; the
// fuzzer), `path` naming it in errors.
Checkpoint parse_checkpoint(std::string bytes, const std::string& path);
// Throws CheckpointError naming the first difference between the identities, compared
// as the run means them: a number's spelling ("02000", "2e3") and the order of -D's
// assignments to different keys do not matter.
void require_same_run(const std::string& path, const nlohmann::json& saved, const nlohmann::json& now);

}  // namespace raybundle::render
