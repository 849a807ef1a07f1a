// The check the study fuzzer runs on every input, shared with the replay test
// (Study.FuzzSeedsAndRegressionsReplay in tests/sweep/test_sweep.cpp). An input is a study file's
// text, optionally followed by a line "#torques" and a torque file's text. In the study, SCENE
// stands for the paper's geared scene, SPATIAL_SCENE for the 3D arm beside it
// (models/space_arm7_payload.yaml, its URDF read too) and TORQUES for a file holding the torque
// part (written into `scratch` for each input), so that mutations reach the manoeuvre and the
// torque reader.
// A study must be rejected with an error that names the study, the field or the file it is
// about, or be accepted as one that keeps every documented rule; anything else is a bug.
#pragma once

#include <cmath>
#include <fstream>
#include <stdexcept>
#include <string>

#include "study.hpp"

namespace spacearm::fuzz {

// A rule the study reader broke (std::invalid_argument, which the torque reader throws, is a
// logic_error too: this type tells the two apart).
struct BrokenStudyRule : std::logic_error {
  using std::logic_error::logic_error;
};

inline std::string replaced_all(std::string s, const std::string& key, const std::string& value) {
  for (size_t at = s.find(key); at != std::string::npos; at = s.find(key, at + value.size()))
    s.replace(at, key.size(), value);
  return s;
}

// The 3D arm's scene beside the planar one (same folder).
inline std::string spatial_scene_beside(const std::string& scene) {
  return scene.substr(0, scene.find_last_of('/') + 1) + "space_arm7_payload.yaml";
}

// The study text with its placeholders replaced (SPATIAL_SCENE before SCENE, which it contains).
inline std::string study_text(const std::string& text, const std::string& scene,
                              const std::string& torques) {
  return replaced_all(replaced_all(replaced_all(text, "SPATIAL_SCENE", spatial_scene_beside(scene)),
                                   "SCENE", scene),
                      "TORQUES", torques);
}

// Empty when the accepted study keeps the rules, else the rule it breaks.
inline std::string broken_rule(const Study& s) {
  const long n = s.num_runs();
  if (n < 1 || n > kMaxRuns) return "number of runs out of range";
  if (!(s.t_end > 0) || !std::isfinite(s.t_end)) return "t_end";
  if (!(s.integrator.dt > 0) || !std::isfinite(s.integrator.dt)) return "integrator.dt";
  if (!s.plan && !s.torques) return "no manoeuvre";
  if (s.torques) {
    if (s.q0.size() != s.scene.base_coordinates + s.scene.num_links || !s.q0.allFinite())
      return "q0";
    if (const int k = s.scene.quaternion_offset;
        k >= 0 && std::abs(s.q0.segment(k, 4).norm() - 1) > 1e-12)
      return "q0's base quaternion is not unit";
    if (s.torques->samples.size() < 2 || !(s.torques->dt > 0)) return "torque grid";
    for (const auto& sample : s.torques->samples)
      if (sample.size() != s.scene.num_links || !sample.allFinite()) return "torque sample";
  }
  for (long run : {0L, n / 2, n - 1}) {
    const Eigen::VectorXd p = s.parameters(run);
    if (p.size() != static_cast<Eigen::Index>(s.scene.parameter_names.size()) || !p.allFinite())
      return "parameters of run " + std::to_string(run);
  }
  if (s.identity.empty()) return "no identity";
  return "";
}

// Throws BrokenStudyRule (a std::logic_error) for a broken rule; lets anything else escape.
inline void check_study_input(const std::string& input, const std::string& scene,
                              const std::string& scratch) {
  std::string text = input, torques;
  if (const size_t cut = input.find("\n#torques\n"); cut != std::string::npos) {
    text = input.substr(0, cut);
    torques = input.substr(cut + 10);
  }
  const std::string tau = scratch + "/torques.csv", source = scratch + "/fuzz-study.yaml";
  {
    std::ofstream out(tau, std::ios::binary | std::ios::trunc);
    out << torques;
  }
  text = study_text(text, scene, tau);
  auto names_its_subject = [&](const std::string& what) {
    return what.rfind("study '" + source + "'", 0) == 0 || what.find(tau) != std::string::npos ||
           what.find(scene) != std::string::npos ||
           what.find(spatial_scene_beside(scene)) != std::string::npos ||
           what.rfind("manoeuvre.", 0) == 0;
  };
  try {
    const std::string rule = broken_rule(parse_study(text, source));
    if (!rule.empty()) throw BrokenStudyRule("study accepted breaking a rule: " + rule);
  } catch (const BrokenStudyRule&) {
    throw;
  } catch (const std::exception& e) {  // StudyError, SceneError, the torque reader's errors
    if (!names_its_subject(e.what()))
      throw BrokenStudyRule(std::string("study rejection names neither the study, the field "
                                        "nor the file: ") +
                            e.what());
  }
}

}  // namespace spacearm::fuzz
