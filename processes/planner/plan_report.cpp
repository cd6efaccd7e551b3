#include "processes/planner/plan_report.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace objscan {
namespace {

std::string Number(double v, int decimals = 3) {
  if (!std::isfinite(v)) return "null";
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", decimals, v);
  return buffer;
}

}  // namespace

std::string PlanOutcome(const PlanSummary& s) {
  if (s.phase == Phase::kFinish) return "modeled";
  if (s.phase == Phase::kNoTarget) return "no_target";
  return "stopped";
}

std::string PlanJson(const PlanSummary& s, int64_t end_utime) {
  std::ostringstream j;
  j << "{\n  \"outcome\": \"" << PlanOutcome(s) << "\",\n  \"phases\": [";
  for (size_t i = 0; i < s.phases.size(); ++i) {
    const PhaseRecord& p = s.phases[i];
    const int64_t end = p.end_utime >= 0 ? p.end_utime : end_utime;
    j << (i ? ",\n" : "\n") << "    {\"name\": \"" << PhaseName(p.phase) << "\", \"start_utime\": " << p.start_utime
      << ", \"end_utime\": " << end << ", \"seconds\": " << Number((end - p.start_utime) * 1e-6) << "}";
  }
  j << "\n  ],\n  \"path_length_mm\": " << Number(s.path_length_mm, 1) << ",\n  \"frames\": " << s.frames
    << ",\n  \"views\": " << s.views << ",\n  \"orbit_percent\": " << Number(s.orbit_percent, 1)
    << ",\n  \"next_views\": [";
  for (size_t i = 0; i < s.next_views.size(); ++i) {
    const NextViewRecord& v = s.next_views[i];
    j << (i ? ",\n" : "\n") << "    {\"x\": " << Number(v.x_mm, 1) << ", \"y\": " << Number(v.y_mm, 1)
      << ", \"pan\": " << Number(v.pan_rad, 4) << ", \"tilt\": " << Number(v.tilt_rad, 4)
      << ", \"radius\": " << Number(v.radius_mm, 1) << ", \"azimuth\": " << Number(v.azimuth_rad, 4)
      << ", \"gain\": " << v.gain << ", \"coverage_before\": " << Number(v.coverage_before, 4)
      << ", \"coverage_after\": " << Number(v.coverage_after, 4) << "}";
  }
  j << (s.next_views.empty() ? "" : "\n  ") << "],\n  \"coverage\": " << Number(s.coverage, 4)
    << ",\n  \"coverage_samples\": " << s.coverage_samples << ",\n  \"disagreement_max_mm\": "
    << Number(s.max_disagreement.distance_mm, 1) << ",\n  \"disagreement_max_deg\": "
    << Number(s.max_disagreement.angle_rad * 180.0 / M_PI, 2) << ",\n  \"safety_stops\": " << s.safety_stops << ",\n  \"orbit_glances\": " << s.orbit_glances
    << ",\n  \"target\": {\"confirmed\": " << (s.target_confirmed ? "true" : "false") << ", \"centre_mm\": ["
    << Number(s.target.centre_mm.x(), 1) << ", " << Number(s.target.centre_mm.y(), 1) << ", "
    << Number(s.target.centre_mm.z(), 1) << "], \"size_mm\": [" << Number(s.target.size_mm.x(), 1) << ", "
    << Number(s.target.size_mm.y(), 1) << ", " << Number(s.target.size_mm.z(), 1)
    << "], \"yaw_rad\": " << Number(s.target.yaw_rad, 4) << ", \"confirmed_seq\": " << s.confirmed_seq << "}\n}\n";
  return j.str();
}

bool WritePlanJson(const std::string& path, const PlanSummary& summary, int64_t end_utime, std::string* error) {
  std::ofstream out(path);
  if (out) out << PlanJson(summary, end_utime);
  if (!out) {
    if (error) *error = "cannot write " + path;
    return false;
  }
  return true;
}

}  // namespace objscan
