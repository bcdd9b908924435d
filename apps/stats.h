#pragma once
// The run's record: every setting, decision and measured figure, so that a run can
// be reproduced and compared from its stats file alone.
#include <nlohmann/json.hpp>

#include <string>

namespace raybundle::apps {

// Writes JSON (pretty, 2 spaces) atomically.
void write_json(const std::string& path, const nlohmann::json& doc);

}  // namespace raybundle::apps
