#pragma once
// Scene descriptions compiled into the binary from assets/scenes/*.json.
#include <optional>
#include <string_view>
#include <vector>

namespace cofusion::assets {

// JSON text of the built-in scene `name` (file name without .json), if there is one.
std::optional<std::string_view> scene_json(std::string_view name);
// Names of every built-in scene, sorted.
std::vector<std::string_view> scene_names();

}  // namespace cofusion::assets
