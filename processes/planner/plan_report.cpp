#include "processes/planner/plan_report.h"

#include <algorithm>
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
  if (s.phase == Phase::kFinish) return s.coverage < s.min_coverage ? "partial" : "modeled";
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
    << ",\n  \"min_coverage\": " << Number(s.min_coverage, 4)
    << ",\n  \"coverage_samples\": " << s.coverage_samples << ",\n  \"disagreement_max_mm\": "
    << Number(s.max_disagreement.distance_mm, 1) << ",\n  \"disagreement_max_deg\": "
    << Number(s.max_disagreement.angle_rad * 180.0 / M_PI, 2) << ",\n  \"safety_stops\": " << s.safety_stops << ",\n  \"pan_limit_reversals\": " << s.pan_limit_reversals << ",\n  \"orbit_glances\": " << s.orbit_glances << ",\n  \"relocalizations\": " << s.relocalizations << ",\n  \"map_restarts\": " << s.map_restarts << ",\n  \"contacts\": " << s.contacts
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

bool WritePlanMapPgm(const std::string& path, const OccupancyMap& map, const std::vector<Eigen::Vector2d>& path_mm,
                     std::string* error) {
  int x0 = map.width(), y0 = map.height(), x1 = -1, y1 = -1;
  for (int i = 0; i < map.num_cells(); ++i) {
    if (map.StateOf(i) == OccupancyMap::State::kUnknown) continue;
    x0 = std::min(x0, map.XOf(i));
    x1 = std::max(x1, map.XOf(i));
    y0 = std::min(y0, map.YOf(i));
    y1 = std::max(y1, map.YOf(i));
  }
  if (x1 < 0) x0 = y0 = 0, x1 = y1 = 0;
  const int pad = static_cast<int>(1000 / map.cell_mm());
  x0 = std::max(0, x0 - pad);
  y0 = std::max(0, y0 - pad);
  x1 = std::min(map.width() - 1, x1 + pad);
  y1 = std::min(map.height() - 1, y1 + pad);
  const int w = x1 - x0 + 1, h = y1 - y0 + 1;
  std::vector<uint8_t> pixels(static_cast<size_t>(w) * h, 128);
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const int i = map.IndexAt(x, y);
      uint8_t v = 128;
      if (map.StateOf(i) == OccupancyMap::State::kOccupied) v = 0;
      if (map.StateOf(i) == OccupancyMap::State::kFree) v = map.Traversable(i) ? 255 : 200;
      pixels[static_cast<size_t>(y1 - y) * w + (x - x0)] = v;
    }
  for (const Eigen::Vector2d& p : path_mm) {
    int i;
    if (!map.IndexOf(p, &i) || map.XOf(i) < x0 || map.XOf(i) > x1 || map.YOf(i) < y0 || map.YOf(i) > y1) continue;
    pixels[static_cast<size_t>(y1 - map.YOf(i)) * w + (map.XOf(i) - x0)] = 64;
  }
  std::ofstream out(path, std::ios::binary);
  const Eigen::Vector2d top_left = map.CentreOf(map.IndexAt(x0, y1));
  out << "P5\n# objscan planner map: cell " << map.cell_mm() << " mm, top-left pixel at x " << top_left.x()
      << " y " << top_left.y() << " mm (world); up = +y\n"
      << w << " " << h << "\n255\n";
  out.write(reinterpret_cast<const char*>(pixels.data()), static_cast<std::streamsize>(pixels.size()));
  if (!out) {
    *error = "cannot write " + path;
    return false;
  }
  return true;
}

}  // namespace objscan
