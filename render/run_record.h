#pragma once
// The run's record: every setting, decision and measured figure, so that a run can
// be reproduced and compared from its stats file alone.
#include "cli.h"

#include <nlohmann/json.hpp>

#include <string>

namespace raybundle::apps {

// The scene, the solver's report and the shots' decisions (no timings of the CLI's own).
nlohmann::json run_record(const scenes::Scene& scene, const Command& c, const solver::SolverReport& report,
                          const solver::Transport& transport, std::size_t coplanar_overlaps);
// What the contacts between surfaces did to the scene (scenes/contacts.h), in a line.
std::string contacts_line(const scenes::Scene& scene);
// The final gather's settings and figures.
nlohmann::json gather_record(const Command& c, const render::GatherResult& gathered);

// Writes JSON (pretty, 2 spaces) atomically.
void write_json(const std::string& path, const nlohmann::json& doc);

}  // namespace raybundle::apps
