#include "tools/report/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

namespace objscan {
namespace {

constexpr double kPairMaxDtS = 0.005;  // s, as objscan_evaluate pairs poses

struct Series {
  std::string label, colour;
  std::vector<double> x, y;  // NaN y breaks the line
};

std::string Num(double v, int decimals = 3) {
  char b[48];
  std::snprintf(b, sizeof b, "%.*f", decimals, v);
  return b;
}

double NiceStep(double range, int ticks) {
  if (!(range > 0)) return 1;
  const double raw = range / ticks;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (raw <= m * p) return m * p;
  return 10 * p;
}

// A line plot as inline SVG: axes with ticks, one polyline per series, a legend. equal_aspect: one unit is as long
// on both axes (the trajectory from above).
std::string SvgPlot(const std::string& x_label, const std::string& y_label, const std::vector<Series>& series,
                    bool equal_aspect) {
  const double width = equal_aspect ? 560 : 760, height = equal_aspect ? 560 : 300;
  const double left = 70, right = 20, top = 34, bottom = 46;
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const auto& s : series)
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      x0 = std::min(x0, s.x[i]), x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, s.y[i]), y1 = std::max(y1, s.y[i]);
    }
  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height
    << "\" font-family=\"sans-serif\" font-size=\"12\">";
  o << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>";
  if (!(x1 >= x0) || !(y1 >= y0)) {
    o << "<text x=\"" << width / 2 << "\" y=\"" << height / 2 << "\" text-anchor=\"middle\">no data</text></svg>";
    return o.str();
  }
  if (x1 - x0 < 1e-9) x0 -= 1, x1 += 1;
  if (y1 - y0 < 1e-9) y0 -= 1, y1 += 1;
  const double plot_w = width - left - right, plot_h = height - top - bottom;
  if (equal_aspect) {  // widen the shorter range so one unit is as long on both axes
    const double units_per_px = std::max((x1 - x0) / plot_w, (y1 - y0) / plot_h);
    const double cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
    x0 = cx - units_per_px * plot_w / 2, x1 = cx + units_per_px * plot_w / 2;
    y0 = cy - units_per_px * plot_h / 2, y1 = cy + units_per_px * plot_h / 2;
  } else {  // counts, errors and latencies: from zero, so that a flat series looks flat
    y0 = std::min(y0, 0.0);
    y1 += 0.05 * (y1 - y0);
  }
  auto px = [&](double x) { return left + (x - x0) / (x1 - x0) * plot_w; };
  auto py = [&](double y) { return top + (y1 - y) / (y1 - y0) * plot_h; };
  o << "<rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << plot_w << "\" height=\"" << plot_h
    << "\" fill=\"none\" stroke=\"#888\"/>";
  const double xs = NiceStep(x1 - x0, 6), ys = NiceStep(y1 - y0, 5);
  for (double t = std::ceil(x0 / xs) * xs; t <= x1 + 1e-9; t += xs)
    o << "<line x1=\"" << Num(px(t), 1) << "\" y1=\"" << top << "\" x2=\"" << Num(px(t), 1) << "\" y2=\""
      << top + plot_h << "\" stroke=\"#eee\"/><text x=\"" << Num(px(t), 1) << "\" y=\"" << top + plot_h + 16
      << "\" text-anchor=\"middle\">" << Num(t, xs < 1 ? 2 : 0) << "</text>";
  for (double t = std::ceil(y0 / ys) * ys; t <= y1 + 1e-9; t += ys)
    o << "<line x1=\"" << left << "\" y1=\"" << Num(py(t), 1) << "\" x2=\"" << left + plot_w << "\" y2=\""
      << Num(py(t), 1) << "\" stroke=\"#eee\"/><text x=\"" << left - 6 << "\" y=\"" << Num(py(t) + 4, 1)
      << "\" text-anchor=\"end\">" << Num(t, ys < 1 ? 2 : 0) << "</text>";
  o << "<text x=\"" << left + plot_w / 2 << "\" y=\"" << height - 8 << "\" text-anchor=\"middle\">"
    << HtmlEscape(x_label) << "</text>";
  o << "<text transform=\"translate(16," << top + plot_h / 2 << ") rotate(-90)\" text-anchor=\"middle\">"
    << HtmlEscape(y_label) << "</text>";
  double legend_x = left;
  for (const auto& s : series) {
    o << "<polyline fill=\"none\" stroke=\"" << s.colour << "\" stroke-width=\"1.5\" points=\"";
    bool open = false;
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
        if (open) o << "\"/><polyline fill=\"none\" stroke=\"" << s.colour << "\" stroke-width=\"1.5\" points=\"";
        open = false;
        continue;
      }
      o << Num(px(s.x[i]), 1) << "," << Num(py(s.y[i]), 1) << " ";
      open = true;
    }
    o << "\"/>";
    o << "<rect x=\"" << legend_x << "\" y=\"10\" width=\"14\" height=\"4\" fill=\"" << s.colour << "\"/><text x=\""
      << legend_x + 18 << "\" y=\"16\">" << HtmlEscape(s.label) << "</text>";
    legend_x += 30 + 7 * static_cast<double>(s.label.size());
  }
  o << "</svg>";
  return o.str();
}

Series TopView(const std::string& label, const std::string& colour, const std::vector<StampedPose>& poses) {
  Series s{label, colour, {}, {}};
  for (const auto& p : poses) {
    s.x.push_back(p.world_from_camera.translation().x());
    s.y.push_back(p.world_from_camera.translation().y());
  }
  return s;
}

std::string FigureTable(const std::vector<std::pair<std::string, std::string>>& rows) {
  std::ostringstream o;
  o << "<table>";
  for (const auto& [k, v] : rows) o << "<tr><td>" << HtmlEscape(k) << "</td><td>" << HtmlEscape(v) << "</td></tr>";
  o << "</table>";
  return o.str();
}

}  // namespace

std::string HtmlEscape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string Base64(const std::vector<uint8_t>& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const uint32_t b0 = bytes[i], b1 = i + 1 < bytes.size() ? bytes[i + 1] : 0,
                   b2 = i + 2 < bytes.size() ? bytes[i + 2] : 0;
    const uint32_t v = (b0 << 16) | (b1 << 8) | b2;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[v & 63] : '=';
  }
  return out;
}

ReportTrajectoryFigures AlignForReport(const std::vector<StampedPose>& estimate, const std::vector<StampedPose>& truth,
                                       std::vector<StampedPose>* aligned) {
  ReportTrajectoryFigures f;
  *aligned = estimate;
  TrajectoryEvaluation evaluation;
  std::string error;
  if (estimate.size() < 3 || truth.size() < 3 ||
      !EvaluateTumTrajectories(estimate, truth, true, kPairMaxDtS, &evaluation, &error))
    return f;
  f.aligned = true;
  f.ate_rmse_mm = evaluation.error.ate_rmse;
  f.ate_max_mm = evaluation.error.ate_max;
  f.scale = evaluation.error.scale;
  f.registered_fraction = evaluation.registered_fraction;
  for (auto& p : *aligned) p.world_from_camera = evaluation.error.alignment.Apply(p.world_from_camera);
  f.t_s = evaluation.matched_t_s;
  f.error_mm = evaluation.matched_error;
  return f;
}

std::string RenderReportHtml(const ReportInputs& in) {
  std::ostringstream o;
  const bool failed = !in.status.empty() && in.status != "ok" && in.status != "done";
  o << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>objscan report: " << HtmlEscape(in.title)
    << "</title><style>body{font-family:sans-serif;margin:24px;max-width:1200px}h2{margin-top:32px}"
       "table{border-collapse:collapse}td{border:1px solid #ccc;padding:3px 8px}.bad{color:#b00;font-weight:bold}"
       "figure{display:inline-block;margin:8px}pre{background:#f6f6f6;padding:8px;overflow:auto}</style></head>"
       "<body>\n";
  o << "<h1>objscan report: " << HtmlEscape(in.title) << "</h1>\n";
  o << "<p>status: <span" << (failed ? " class=\"bad\"" : "") << " id=\"status\">"
    << HtmlEscape(in.status.empty() ? "unknown (no summary.json)" : in.status) << "</span></p>\n";
  if (!in.missing.empty()) {
    o << "<p>not in this run: ";
    for (size_t i = 0; i < in.missing.size(); ++i) o << (i ? ", " : "") << HtmlEscape(in.missing[i]);
    o << "</p>\n";
  }

  // Figures: trajectories against the truth, then the other tools'.
  std::vector<StampedPose> final_aligned, online_aligned;
  const auto final_fig = AlignForReport(in.final_poses, in.truth, &final_aligned);
  const auto online_fig = AlignForReport(in.online_poses, in.truth, &online_aligned);
  o << "<h2>Figures</h2>\n";
  std::vector<std::pair<std::string, std::string>> rows = {
      {"final poses (trajectory.txt)", std::to_string(in.final_poses.size())},
      {"online poses (trajectory_online.txt)", std::to_string(in.online_poses.size())}};
  for (const auto& [name, f] : {std::make_pair(std::string("final"), final_fig),
                                std::make_pair(std::string("online"), online_fig)}) {
    if (!f.aligned) continue;
    rows.push_back({name + " ATE RMSE after Sim(3) (mm)", Num(f.ate_rmse_mm, 4)});
    rows.push_back({name + " ATE max (mm)", Num(f.ate_max_mm, 4)});
    rows.push_back({name + " scale to the truth", Num(f.scale, 5)});
    rows.push_back({name + " registered fraction", Num(f.registered_fraction, 4)});
  }
  rows.push_back({"ground truth", in.truth.empty() ? "none: no errors shown"
                                                  : std::to_string(in.truth.size()) + " poses from " +
                                                        (in.truth_source.empty() ? "the run" : in.truth_source)});
  o << FigureTable(rows) << "\n";
  for (const auto& [caption, lines] : in.figures) o << "<h3>" << HtmlEscape(caption) << "</h3>" << FigureTable(lines);

  o << "<h2>Trajectory from above</h2>\n<p>"
    << (final_fig.aligned ? "Camera centres, x-y in the truth's frame (each estimate Sim(3)-aligned to the truth)."
                          : "Camera centres, x-y in the run's world frame.")
    << "</p>\n";
  std::vector<Series> top;
  if (!in.truth.empty()) top.push_back(TopView("truth", "#999999", in.truth));
  if (!online_aligned.empty()) top.push_back(TopView("online", "#e08000", online_aligned));
  if (!final_aligned.empty()) top.push_back(TopView("final", "#1f5fbf", final_aligned));
  o << SvgPlot("x (mm)", "y (mm)", top, true) << "\n";

  if (final_fig.aligned || online_fig.aligned) {
    o << "<h2>Position error per frame</h2>\n";
    std::vector<Series> errors;
    if (online_fig.aligned) errors.push_back({"online", "#e08000", online_fig.t_s, online_fig.error_mm});
    if (final_fig.aligned) errors.push_back({"final", "#1f5fbf", final_fig.t_s, final_fig.error_mm});
    o << SvgPlot("frame time (s)", "error (mm)", errors, false) << "\n";
  }

  const FrameSeries& fr = in.frames;
  o << "<h2>Tracks per frame</h2>\n";
  std::vector<double> tracks;
  for (int n : fr.tracks) tracks.push_back(n < 0 ? std::nan("") : n);
  o << SvgPlot("frame time (s)", "live tracks", {{"FEATURE_TRACKS", "#2a8a2a", fr.t_s, tracks}}, false) << "\n";
  o << "<h2>Latency per frame</h2>\n<p>From the image to the stage's output, as the logger received them.</p>\n";
  o << SvgPlot("frame time (s)", "latency (ms)",
               {{"image to tracks", "#2a8a2a", fr.t_s, fr.tracks_latency_ms},
                {"image to pose", "#1f5fbf", fr.t_s, fr.pose_latency_ms}},
               false)
    << "\n";

  o << "<h2>Model</h2>\n";
  if (in.pictures.empty()) o << "<p>no pictures (no model, or no headless viewer on this machine)</p>\n";
  for (const auto& [caption, png] : in.pictures)
    o << "<figure><img alt=\"" << HtmlEscape(caption) << "\" width=\"480\" src=\"data:image/png;base64,"
      << Base64(png) << "\"><figcaption>" << HtmlEscape(caption) << "</figcaption></figure>\n";

  o << "<h2>summary.json</h2>\n<pre>" << HtmlEscape(in.summary_json.empty() ? "(none)" : in.summary_json)
    << "</pre>\n</body></html>\n";
  return o.str();
}

}  // namespace objscan
