// raybundle: the command line. Parse into a Command, check it, hand it to solve() or
// check_scene(); map every error to one line and an exit code:
//   2  the user's input is wrong (flags, scene file, meshes, an option a library refuses)
//   1  anything else (an output that cannot be written, a missing run-time library, a bug)
#include "cli.h"
#include "render/ranks.h"
#include "render/signals.h"

#include "render/run_record.h"
#include "scenes/builtin.h"
#include "scenes/errors.h"
#include "visibility/backend.h"

#include <cstdio>
#include <iostream>
#include <optional>

namespace rb = raybundle;

namespace {

constexpr int kExitFailure = 1;
constexpr int kExitBadInput = 2;

int run(int argc, char** argv, rb::render::Ranks& ranks) {
    // One line for the user, on rank 0, whichever rank failed (render/ranks.h).
    auto fail = [&ranks](const std::string& what, int code) {
        return ranks.fail(rb::scenes::printable(what), code);  // one line, whatever the names in it
    };
    CLI::App app{"raybundle: global ray-bundle radiance solver (see `raybundle help`)"};
    app.set_version_flag("--version", [] {
        std::printf("%sranks      %s\n", rb::render::build_info().c_str(), rb::render::Ranks::library().c_str());
        return std::string();
    });
    rb::apps::Command c;
    auto* solve = app.add_subcommand("solve", "solve a scene's radiance, then render and write what is asked for");
    rb::apps::add_solve_options(*solve, c);
    auto* check = app.add_subcommand("check", "validate a scene and show what it holds, without solving");
    rb::apps::add_scene_options(*check, c);
    auto* scenes_cmd = app.add_subcommand("scenes", "list the built-in scenes");
    auto* backends_cmd = app.add_subcommand("backends", "list the visibility backends");
    auto* help_cmd = app.add_subcommand("help", "this help, or a command's: raybundle help solve");
    std::string help_topic;
    help_cmd->add_option("command", help_topic, "solve | check | scenes | backends")
        ->check(CLI::IsMember({"solve", "check", "scenes", "backends"}));
    app.require_subcommand(1);
    app.name("raybundle");

    try {
        app.parse(argc, argv);
        if (help_cmd->parsed()) {
            if (help_topic.empty()) {
                std::cout << app.get_formatter()->make_help(&app, "raybundle", CLI::AppFormatMode::Normal);
                return 0;
            }
            const auto* sub = app.get_subcommand(help_topic);
            std::cout << sub->get_formatter()->make_help(sub, "raybundle " + help_topic, CLI::AppFormatMode::Normal);
            return 0;
        }
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion&) {
        return 0;
    } catch (const CLI::ParseError& e) {
        return fail(std::string(e.what()) + (argc == 1 ? " (see `raybundle help`)" : ""), kExitBadInput);
    }

    try {
        if (scenes_cmd->parsed()) {
            for (const auto& s : rb::scenes::builtin_scenes())
                std::printf("%-16s %s (default patch size %g)\n", s.name.c_str(), s.description.c_str(),
                            s.default_patch_size);
            return 0;
        }
        if (backends_cmd->parsed()) {
            for (const auto& b : rb::visibility::backend_infos())
                std::printf("%-15s %-11s %s\n", b.name.c_str(), b.exact ? "exact" : "approximate", b.summary.c_str());
            return 0;
        }
        CLI::App* cmd = solve->parsed() ? solve : check;
        rb::apps::check_command(*cmd, c);
        return solve->parsed() ? rb::apps::solve(c, ranks) : rb::apps::check_scene(c);
    } catch (const rb::render::RankFailed& e) {
        if (ranks.leader()) std::cerr << "raybundle: error: " << e.what() << "\n";
        return e.code;
    } catch (const rb::apps::UsageError& e) {
        return fail(e.what(), kExitBadInput);
    } catch (const rb::render::OutputError& e) {
        return fail(e.what(), kExitBadInput);
    } catch (const rb::scenes::SceneError& e) {
        return fail(e.what(), kExitBadInput);
    } catch (const rb::scenes::OptionError& e) {
        return fail(c.flags.flag_of(e.option()) + ": " + e.problem(), kExitBadInput);
    } catch (const std::exception& e) {
        return fail(e.what(), kExitFailure);
    }
}

}  // namespace

int main(int argc, char** argv) {
    rb::render::install_signal_handlers();  // before MPI's threads: they inherit its mask
    std::optional<rb::render::Ranks> ranks;
    try {
        ranks.emplace(argc, argv);
    } catch (const rb::render::RankFailed& e) {
        return e.code;  // ranks running different commands: rank 0 has said so
    } catch (const std::exception& e) {
        std::cerr << "raybundle: error: " << e.what() << "\n";
        return kExitBadInput;
    }
    return run(argc, argv, *ranks);
}
