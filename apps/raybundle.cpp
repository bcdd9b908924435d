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

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

namespace rb = raybundle;

namespace {

constexpr int kExitFailure = 1;
constexpr int kExitBadInput = 2;

using rb::scenes::edit_distance;

// The option of `cmd` whose long name is nearest to `arg` ("--iteration=5" against
// "iterations"): at most 2 edits, or a name it begins; empty where none is.
std::string nearest_option(const CLI::App& cmd, const std::string& arg) {
    std::string word = arg.substr(arg.find_first_not_of('-') == std::string::npos ? arg.size() : arg.find_first_not_of('-'));
    word = word.substr(0, word.find('='));
    std::string best;
    std::size_t best_distance = 3;
    for (const CLI::Option* option : cmd.get_options()) {
        for (const std::string& name : option->get_lnames()) {
            const std::size_t d = name.rfind(word, 0) == 0 && word.size() >= 3 ? 1 : edit_distance(word, name);
            if (d < best_distance) best_distance = d, best = "--" + name;
        }
    }
    return best;
}

// One line for the arguments no option took: the first unknown option, with the
// nearest one, else the first argument left over.
std::string unexpected(const CLI::App& app, const std::vector<const CLI::App*>& commands) {
    for (const CLI::App* cmd : commands) {
        if (cmd->count() == 0) continue;
        const std::vector<std::string> left = cmd->remaining();
        if (left.empty()) continue;
        const std::string name = "raybundle " + cmd->get_name();
        const std::string help = cmd->get_name() == "help" ? "raybundle help" : "raybundle help " + cmd->get_name();
        // An option: a dash and a letter (-2 and -.5 are numbers).
        const auto option = std::find_if(left.begin(), left.end(), [](const std::string& a) {
            return a.size() > 1 && a[0] == '-' && (std::isalpha(static_cast<unsigned char>(a[1])) || a[1] == '-');
        });
        if (option == left.end()) return name + ": unexpected argument '" + left.front() + "' (see `" + help + "`)";
        const std::string near = nearest_option(*cmd, *option);
        return name + ": unknown option " + *option + (near.empty() ? "" : " (did you mean " + near + "?)") + " (see `" +
               help + "`)";
    }
    const std::vector<std::string> left = app.remaining();
    if (left.empty()) return "";
    const auto command = std::find_if(commands.begin(), commands.end(), [](const CLI::App* c) { return c->count() > 0; });
    if (command != commands.end())
        return left.front() + ": options go after the command (raybundle " + (*command)->get_name() + " ... " +
               left.front() + " ...)";
    return (left.front()[0] == '-' ? "unknown option " : "unknown command ") + ("'" + left.front() + "'") +
           " (commands: solve, check, scenes, backends, help; --version, --help)";
}

// One line for an option given more often than it takes values ("--gather 0 ... --gather
// 1"): refused, as a scene file's key given twice is, with what each use said. CLI11
// would say "At Most 1 required but received 2".
std::string repeated(const std::vector<const CLI::App*>& commands) {
    for (const CLI::App* cmd : commands) {
        if (cmd->count() == 0) continue;
        for (const CLI::Option* option : cmd->get_options()) {
            if (option->get_multi_option_policy() != CLI::MultiOptionPolicy::Throw) continue;
            const std::size_t most = static_cast<std::size_t>(std::max(option->get_items_expected_max(), 1));
            const std::vector<std::string>& given = option->results();
            if (given.size() <= most || option->get_items_expected_max() >= CLI::detail::expected_max_vector_size)
                continue;
            std::string values;
            for (const std::string& v : given) values += (values.empty() ? "" : ", ") + v;
            return "raybundle " + cmd->get_name() + ": " + option->get_name() + " given " + std::to_string(given.size()) +
                   " times (" + values + "): give it once";
        }
    }
    return "";
}

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
        // `raybundle render --help`: CLI11 shows the main help for a word it does not
        // know; the word is refused as it is without --help.
        for (int i = 1; i < argc; ++i) {
            const std::string word = argv[i];
            if (word.empty() || word[0] == '-') continue;
            const auto known = app.get_subcommands([&word](const CLI::App* sub) { return sub->get_name() == word; });
            if (known.empty())
                return fail("unknown command '" + word + "' (commands: solve, check, scenes, backends, help; --version, --help)",
                            kExitBadInput);
            break;
        }
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion&) {
        return 0;
    } catch (const CLI::ParseError& e) {
        // Arguments nothing took (CLI11 lists them in no helpful order, or only says a
        // command is required): named one by one, with the nearest option.
        const std::string left = unexpected(app, {solve, check, scenes_cmd, backends_cmd, help_cmd});
        if (!left.empty()) return fail(left, kExitBadInput);
        if (const std::string twice = repeated({solve, check, help_cmd}); !twice.empty())
            return fail(twice, kExitBadInput);
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
