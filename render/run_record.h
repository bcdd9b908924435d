#pragma once
// The run's record: every setting, decision and measured figure, so that a run can
// be reproduced and compared from its stats file alone; and the convergence rows (CSV,
// and in checkpoints as JSON).
#include "render/run.h"

#include <nlohmann/json.hpp>

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
};

nlohmann::json field_run_record(const scenes::Scene& scene, const RunConfig& c, const solver::Transport& transport,
                                const RunResult& result, const FieldRunFacts& facts);
nlohmann::json path_trace_record(const scenes::Scene& scene, const RunConfig& c, const TracedImage& traced,
                                 double seconds_total);
// The comparison with config.reference, where there is one.
void record_reference(nlohmann::json& record, const RunConfig& c, const std::optional<Compared>& against);

// What the contacts between surfaces did to the scene (scenes/contacts.h), in a line.
std::string contacts_line(const scenes::Scene& scene);

nlohmann::json to_json(const ConvergenceRow& row);
// Throws nlohmann::json::exception for a row of other keys or types.
ConvergenceRow row_from_json(const nlohmann::json& row);

// Writes JSON (pretty, 2 spaces) atomically.
void write_json(const std::string& path, const nlohmann::json& doc);

}  // namespace raybundle::render
