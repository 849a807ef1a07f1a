// libFuzzer target: scene parsing and validation (generator/scene/scene.cpp) on arbitrary text.
// Build and run: scripts/fuzz.sh (clang, -fsanitize=fuzzer,address,undefined).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include <tinyxml2.h>

#include "mjcf_export.hpp"
#include "scene_fuzz_target.hpp"

namespace {

// The MuJoCo export of what the spatial reader accepts (the text as a scene, or as the URDF of
// one, under either inertia check): XML that parses, or a refusal naming what MuJoCo lacks.
void check_export(const std::string& text) {
  using namespace spacearm;
  const UrdfFileReader as_urdf = [&text](const std::string&) { return text; };
  const std::string head = "name: f\nspace: spatial\nbase: {type: free_floating}\nurdf: f.urdf\n";
  const std::pair<std::string, UrdfFileReader> ways[] = {
      {text, fuzz::no_files},
      {head, as_urdf},
      {head + "inertia_check: positive_definite\n", as_urdf}};
  for (const auto& [scene_text, files] : ways) {
    SpatialScene scene;
    try {
      scene = parse_spatial_scene(scene_text, "fuzz-input.yaml", files);
    } catch (const SceneError&) {
      continue;
    }
    for (const bool balance : {false, true}) {
      MjcfOptions options;
      options.balance_inertia = balance;
      std::string xml;
      try {
        xml = export_mjcf(scene, options);
      } catch (const std::invalid_argument& e) {
        if (std::string(e.what()).rfind("export --mjcf: ", 0) != 0)
          throw std::logic_error(std::string("export: an unnamed refusal: ") + e.what());
        continue;
      }
      tinyxml2::XMLDocument doc;
      if (doc.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS)
        throw std::logic_error("export: the MJCF is not XML");
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const std::string text(reinterpret_cast<const char*>(data), size);
    spacearm::fuzz::check_scene_text(text);
    check_export(text);
  } catch (const std::logic_error& e) {
    std::fprintf(stderr, "scene fuzzer: %s\n", e.what());
    std::abort();
  }
  return 0;
}
