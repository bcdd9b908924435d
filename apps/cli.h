#pragma once
// The `raybundle` command line: what it holds between parsing and running. Options
// are parsed straight into the library's run configuration (render::RunConfig) and the
// scene overrides; the command line adds only what it alone knows: the files to write,
// and its own checks. Libraries report bad options in their own terms (OptionError),
// which Flags::flag_of() turns into flags.
#include "progress.h"
#include "render/output_set.h"
#include "render/run.h"
#include "scenes/loader.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <array>
#include <stdexcept>
#include <string>
#include <vector>

namespace raybundle::render {
class Ranks;  // render/ranks.h
}  // namespace raybundle::render

namespace raybundle::apps {

// The images --aov DIR writes, DIR/<name>.exr.
inline constexpr std::array<const char*, 6> kAovNames = {"direct", "indirect", "indirect-filtered", "bias", "normal",
                                                         "depth"};

// The user's command line is wrong: one line, exit code 2.
struct UsageError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

using render::Ranks;

// The command line's options, one row per flag (apps/options.cpp): the library option
// it sets and whether it is part of the run's identity.
enum class Identity { no, yes };
class Flags {
public:
    // `shown`: the name error messages give the flag, where it is not CLI11's
    // (--one-way for "--both-ways,!--one-way", -o for "-o,--output").
    void row(const char* option, Identity identity, CLI::Option* flag, const char* shown = nullptr);
    // The flag that sets a library option (OptionError::option()), or the name itself.
    std::string flag_of(const std::string& option) const;
    // The options part of a run's identity (render/checkpoint.h): every identity flag
    // given, with its values as given.
    nlohmann::json identity() const;

private:
    struct Row {
        std::string option;
        bool identity;
        CLI::Option* flag;
        std::string shown;
    };
    std::vector<Row> rows_;
};

struct Command {
    // The scene.
    std::string scene_file, builtin;
    std::vector<std::string> defines;  // -D key=value
    scenes::Overrides overrides;       // the defines, then --patch-size, --width, --height, --fov
    // Everything the run computes from, its defaults the library's (render/run.h); the
    // flags set its fields. check_command() fills in the checkpoint identity and the
    // files the run names.
    render::RunConfig config;
    // Outputs: nothing is written that was not asked for.
    std::vector<std::string> images;  // -o, the format by the extension
    std::vector<std::string> baked;   // -o x.glb: the patches with their radiance (glTF)
    double exposure = 0.0;
    std::string stats, csv, patches_csv, ply, aov;
    std::string reference;  // an EXR the image is compared with (relative L1, MSE)
    long csv_every = 0;
    bool quiet = false;
    std::string resume;  // the checkpoint to go on from
    Flags flags;         // the table the flags above were added from
    std::vector<render::NamedFile> outputs, inputs;  // by check_command(); the meshes added in solve()
};

// The options of `solve` (and the scene options of `check`) on their subcommand.
void add_scene_options(CLI::App& cmd, Command& c);
void add_solve_options(CLI::App& cmd, Command& c);
// What only the command line can check, after parsing: one scene source, outputs that
// can be written, flags that need others. Throws UsageError.
void check_command(const CLI::App& cmd, Command& c);

// The scene the command names, its patches bounded by `memory` (scenes/machine.h), its
// preparation shown on `bar` (a scene file's or model's steps, apps/progress.h).
scenes::Scene load_scene(const Command& c, const scenes::MemoryShare& memory, ProgressBar& bar,
                         const scenes::PreparationTeam* team = nullptr);
// `raybundle solve` (on every rank of `ranks`) and `raybundle check`: exit codes.
int solve(const Command& c, Ranks& ranks);
int check_scene(const Command& c);

}  // namespace raybundle::apps
