// The self-contained HTML page of `spacearm view`: the data as JSON inside
// <script type="application/json">, then the viewer's script (web/, bundled by esbuild at build
// time and compiled into the program). Nothing of the data is markup: the JSON is escaped so
// that no string can close the script element.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace spacearm::cli {

// JSON text safe inside a <script> element: ASCII only, with '<', '>', '&' (and U+2028/9 by
// the ASCII escape) written as \u escapes; invalid UTF-8 replaced by U+FFFD.
std::string json_for_script(const nlohmann::json& data);

// The whole page for `data` (docs/viewer.md: the format the viewer reads).
std::string view_page(const nlohmann::json& data);

// Whether this program has the viewer's script (built with SPACEARM_BUILD_VIEWER).
bool viewer_built();

}  // namespace spacearm::cli
