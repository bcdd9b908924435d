// The outputs of a run as one set (render/output_set.h): a process killed at any step
// of the commit leaves a set that the next run completes, and signals that arrive
// during the commit wait until every output is new.
#include "../scenes/temp_dir.h"
#include "render/output_set.h"

#include <catch2/catch.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

using namespace raybundle;
namespace fs = std::filesystem;

namespace {

std::string read(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Files of the directory tree whose name begins with ".raybundle-".
std::vector<std::string> leftovers(const fs::path& dir) {
    std::vector<std::string> found;
    for (const auto& e : fs::recursive_directory_iterator(dir))
        if (e.path().filename().string().rfind(".raybundle-", 0) == 0) found.push_back(e.path().string());
    return found;
}

// In a child process: stages "new" into every target and commits, calling `at_step`
// after each step of the commit; the child's exit status.
template <class AtStep>
int commit_in_child(const std::vector<fs::path>& targets, AtStep at_step) {
    const pid_t pid = ::fork();
    REQUIRE(pid >= 0);
    if (pid == 0) {
        {
            render::OutputSet set;
            for (const auto& t : targets) set.stage(t.string(), [](const std::string& tmp) { std::ofstream(tmp) << "new"; });
            set.commit(at_step);
        }
        ::_exit(0);
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    return status;
}

}  // namespace

TEST_CASE("outputs: a commit killed at any step is completed by the next run, none left half done",
          "[render][outputs]") {
    // 5 outputs in two directories, killed (SIGKILL) after each of the commit's 6 steps
    // (the journal, then each rename), and a commit not killed: 7 cases, 30 times each.
    int runs = 0;
    for (int repeat = 0; repeat < 30; ++repeat) {
        for (int kill_at = -1; kill_at <= 5; ++kill_at) {
            test::TempDir dir;
            fs::create_directories(dir.path / "aov");
            const std::vector<fs::path> targets = {dir.path / "img.exr", dir.path / "img.png", dir.path / "s.json",
                                                   dir.path / "aov" / "direct.exr", dir.path / "aov" / "depth.exr"};
            for (const auto& t : targets) std::ofstream(t) << "old";
            const int status = commit_in_child(targets, [kill_at](int step) {
                if (step == kill_at) ::raise(SIGKILL);
            });
            if (kill_at == -1) {
                // Not killed: a complete commit, nothing left over.
                CHECK(WIFEXITED(status));
            } else {
                CHECK(WIFSIGNALED(status));
            }
            // The next run that writes there: the check before any work recovers.
            std::vector<render::NamedFile> named;
            for (const auto& t : targets) named.push_back({t.string(), "-o"});
            render::check_outputs(named, {});
            INFO("killed after step " << kill_at);
            for (const auto& t : targets) CHECK(read(t) == "new");  // the journal was written: all completed
            CHECK(leftovers(dir.path).empty());
            ++runs;
        }
    }
    CHECK(runs == 210);
}

TEST_CASE("outputs: a run killed before its commit leaves the old set, its temporaries removed by the next",
          "[render][outputs]") {
    test::TempDir dir;
    const fs::path target = dir.path / "img.exr";
    std::ofstream(target) << "old";
    const pid_t pid = ::fork();
    REQUIRE(pid >= 0);
    if (pid == 0) {
        render::OutputSet set;
        set.stage(target.string(), [](const std::string& tmp) { std::ofstream(tmp) << "new"; });
        ::raise(SIGKILL);  // staged, not committed
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    REQUIRE(WIFSIGNALED(status));
    CHECK(leftovers(dir.path).size() == 1);
    render::check_outputs({{target.string(), "-o"}}, {});
    CHECK(read(target) == "old");
    CHECK(leftovers(dir.path).empty());
}

TEST_CASE("outputs: signals that arrive during the commit wait until every output is new", "[render][outputs]") {
    for (int signal_at = 0; signal_at <= 3; ++signal_at) {
        test::TempDir dir;
        const std::vector<fs::path> targets = {dir.path / "a.exr", dir.path / "b.csv", dir.path / "c.json"};
        for (const auto& t : targets) std::ofstream(t) << "old";
        // The child ends by its own handler: SIGINT twice, as a user presses ^C twice.
        const int status = commit_in_child(targets, [signal_at](int step) {
            if (step != signal_at) return;
            ::signal(SIGINT, [](int) { ::_exit(42); });
            ::raise(SIGINT);
            ::raise(SIGINT);
        });
        INFO("signals after step " << signal_at);
        REQUIRE(WIFEXITED(status));
        CHECK(WEXITSTATUS(status) == 42);  // the handler ran, after the commit
        for (const auto& t : targets) CHECK(read(t) == "new");
        CHECK(leftovers(dir.path).empty());
    }
}

TEST_CASE("outputs: a write that fails names the output, not its hidden temporary", "[render][outputs]") {
    test::TempDir dir;
    const std::string target = (dir.path / "img.exr").string();
    render::OutputSet set;
    try {
        set.stage(target, [](const std::string& tmp) {
            const std::string partial = tmp + ".partial-" + std::to_string(::getpid());
            throw std::runtime_error(tmp + ": cannot write EXR (Failed to write \"" + partial + "\". No space left)");
        });
        FAIL("no exception");
    } catch (const std::runtime_error& e) {
        CHECK(std::string(e.what()) == target + ": cannot write EXR (Failed to write \"" + target + "\". No space left)");
    }
    CHECK(leftovers(dir.path).empty());
}

TEST_CASE("outputs: a target that became a directory during the run stops the commit before any rename",
          "[render][outputs]") {
    test::TempDir dir;
    const fs::path a = dir.path / "a.exr", s = dir.path / "s.json";
    std::ofstream(a) << "old";
    std::ofstream(s) << "old";
    {
        render::OutputSet set;
        for (const auto& t : {a, s}) set.stage(t.string(), [](const std::string& tmp) { std::ofstream(tmp) << "new"; });
        fs::remove(s);
        fs::create_directory(s);  // replaced mid-run
        CHECK_THROWS_WITH(set.commit(), Catch::Contains(s.string()) && Catch::Contains("is a directory now"));
    }
    CHECK(read(a) == "old");
    CHECK(fs::is_directory(s));
    CHECK(leftovers(dir.path).empty());
}
