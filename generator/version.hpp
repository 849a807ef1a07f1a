// The project's one version: the generator's, named here alone. CMake, pip (setup.py) and
// `spacearm --version` read it; the banner of generated code, cache keys and provenance records
// carry it.
#pragma once

namespace spacearm {

inline constexpr const char* kGeneratorVersion = "0.3.0";

}  // namespace spacearm
