#pragma once
// The run's record: every setting, decision and measured figure, so that a run can
// be reproduced and compared from its stats file alone; and the convergence rows (CSV,
// and in checkpoints as JSON).
#include "render/run.h"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <optional>
#include <string>

namespace raybundle::render {

// What the field run knows besides its result, for its record.
struct FieldRunFacts {
    std::size_t coplanar_overlaps = 0;
    int members = 1;                  // of the team
    double seconds_total = 0.0;
    std::string shot_choice;          // the diffuse shot's decision
    long resume_steps = 0;            // per chain, of a resumed run
    double seconds_before = 0.0;      // of a resumed run's solve
    std::optional<double> exact;
    nlohmann::json phases;            // [{phase, seconds, threads}, ...] in order
    bool side_by_side = false;        // the chains ran side by side (render/progressive.h)
};

nlohmann::json field_run_record(const scenes::Scene& scene, const RunConfig& c, const solver::Transport& transport,
                                const RunResult& result, const FieldRunFacts& facts);
nlohmann::json path_trace_record(const scenes::Scene& scene, const RunConfig& c, const TracedImage& traced,
                                 double seconds_total);
// The comparison with config.reference, where there is one.
void record_reference(nlohmann::json& record, const RunConfig& c, const std::optional<ImageError>& against);

// The record as the stats file holds it: the run's, with the reading and preparation
// of the scene first among the phases (the contact search on the run's threads, the
// rest on one), and the signal that interrupted it, if any.
nlohmann::json stats_record(const RunResult& r, double seconds_scene, int threads);

// What the contacts between surfaces did to the scene (scenes/contacts.h), in a line.
std::string contacts_line(const scenes::Scene& scene);

// printf's formatting, into a string of any length.
template <class... Values>
std::string strprintf(const char* format, Values... values) {
    const int n = std::snprintf(nullptr, 0, format, values...);
    std::string text(static_cast<std::size_t>(n > 0 ? n : 0), '\0');
    std::snprintf(text.data(), text.size() + 1, format, values...);
    return text;
}

// What `raybundle --version` prints: the version, the compiler, the visibility
// backends of this build and the exact painter's span kernels, a line each.
std::string build_info();

// One line on a run: the scene, its patches, the method and steps (or the paths per
// pixel traced), the seconds, the mean radiance, the errors known and estimated.
std::string summary(const scenes::Scene& scene, const RunResult& r);

nlohmann::json to_json(const ConvergenceRow& row);
// Throws nlohmann::json::exception for a row of other keys or types.
ConvergenceRow row_from_json(const nlohmann::json& row);

// Writes JSON (pretty, 2 spaces) atomically.
void write_json(const std::string& path, const nlohmann::json& doc);

}  // namespace raybundle::render
