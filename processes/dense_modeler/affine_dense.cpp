#include "processes/dense_modeler/affine_dense.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <utility>

namespace objscan {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

inline float SampleBilinear(const cv::Mat& img, double u, double v) {
  const int u0 = static_cast<int>(std::floor(u));
  const int v0 = static_cast<int>(std::floor(v));
  const float fu = static_cast<float>(u - u0), fv = static_cast<float>(v - v0);
  const float* r0 = img.ptr<float>(v0);
  const float* r1 = img.ptr<float>(v0 + 1);
  return (1 - fv) * ((1 - fu) * r0[u0] + fu * r0[u0 + 1]) + fv * ((1 - fu) * r1[u0] + fu * r1[u0 + 1]);
}

inline void SampleBgr(const cv::Mat& img, double u, double v, double out[3]) {
  const int u0 = static_cast<int>(std::floor(u));
  const int v0 = static_cast<int>(std::floor(v));
  const double fu = u - u0, fv = v - v0;
  const int c = img.channels();
  const uint8_t* r0 = img.ptr<uint8_t>(v0) + u0 * c;
  const uint8_t* r1 = img.ptr<uint8_t>(v0 + 1) + u0 * c;
  for (int k = 0; k < 3; ++k) {
    const int ck = c == 3 ? k : 0;
    out[k] = (1 - fv) * ((1 - fu) * r0[ck] + fu * r0[c + ck]) + fv * ((1 - fu) * r1[ck] + fu * r1[c + ck]);
  }
}

inline bool Inside(const cv::Mat& img, const Eigen::Vector2d& q, double margin) {
  return q.x() >= margin && q.y() >= margin && q.x() < img.cols - 1 - margin && q.y() < img.rows - 1 - margin;
}

double SmallestAngleDeg(const Eigen::Vector2d& p0, const Eigen::Vector2d& p1, const Eigen::Vector2d& p2) {
  const Eigen::Vector2d pts[3] = {p0, p1, p2};
  double best = 180.0;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector2d e1 = pts[(i + 1) % 3] - pts[i];
    const Eigen::Vector2d e2 = pts[(i + 2) % 3] - pts[i];
    const double n = e1.norm() * e2.norm();
    if (n <= 0) return 0.0;
    best = std::min(best, std::acos(std::clamp(e1.dot(e2) / n, -1.0, 1.0)) / kDegToRad);
  }
  return best;
}

double Cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

}  // namespace

bool ValidateAffineDenseOptions(const AffineDenseOptions& o, std::string* why) {
  std::ostringstream e;
  if (o.mapping != 0 && o.mapping != 1) e << "mapping must be 0 (affine) or 1 (plane); ";
  if (o.pixel_step < 1) e << "pixel-step must be >= 1; ";
  if (!(o.epipolar_threshold_px > 0)) e << "epipolar-threshold must be > 0; ";
  if (o.ncc_half_window < 0 || o.ncc_half_window > 10) e << "ncc-half-window must be in [0, 10]; ";
  if (!(o.min_ncc >= -1 && o.min_ncc <= 1)) e << "min-ncc must be in [-1, 1]; ";
  if (!(o.junction_min_ncc >= -1 && o.junction_min_ncc <= 1)) e << "junction-min-ncc must be in [-1, 1]; ";
  if (o.refine_along_epipolar && o.ncc_half_window < 1) e << "refinement needs ncc-half-window >= 1; ";
  if (!(o.refine_search_px > 0) || !(o.refine_step_px > 0)) e << "refine search and step must be > 0; ";
  if (!(o.max_triangle_edge_px > 0)) e << "max-triangle-edge must be > 0; ";
  if (!(o.max_vertex_depth_ratio >= 1)) e << "max-vertex-depth-ratio must be >= 1; ";
  if (!(o.max_triangle_slant_deg > 0 && o.max_triangle_slant_deg <= 90)) e << "max-triangle-slant must be in (0, 90]; ";
  if (!(o.max_reprojection_px > 0)) e << "max-reprojection must be > 0; ";
  if (!(o.min_triangulation_angle_deg >= 0)) e << "min-triangulation-angle must be >= 0; ";
  if (o.use_world_box && !(o.box_min.array() < o.box_max.array()).all()) e << "world box min must be < max; ";
  if (o.region.valid && !(o.region.box_min.array() < o.region.box_max.array()).all()) e << "region min must be < max; ";
  if (!(o.region_slack_mm >= 0) || !(o.region_image_margin_px >= 0)) e << "region slack and margin must be >= 0; ";
  const std::string msg = e.str();
  if (msg.empty()) return true;
  if (why) *why = msg.substr(0, msg.size() - 2);
  return false;
}

cv::Mat GrayFloat(const cv::Mat& image) {
  cv::Mat gray;
  if (image.channels() == 3)
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  else
    gray = image;
  cv::Mat out;
  gray.convertTo(out, CV_32F);
  return out;
}

Eigen::Matrix3d EssentialMatrix(const Eigen::Isometry3d& world_from_a, const Eigen::Isometry3d& world_from_b) {
  const Eigen::Isometry3d b_from_a = world_from_b.inverse() * world_from_a;
  const Eigen::Vector3d t = b_from_a.translation();
  Eigen::Matrix3d tx;
  tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  return tx * b_from_a.linear();
}

double EpipolarDistancePx(const Eigen::Matrix3d& essential, const PinholeCamera& camera_a,
                          const PinholeCamera& camera_b, const Eigen::Vector2d& p, const Eigen::Vector2d& q) {
  const Eigen::Vector3d na = camera_a.Unproject(p).homogeneous();
  const Eigen::Vector3d nb = camera_b.Unproject(q).homogeneous();
  const Eigen::Vector3d l = essential * na;
  const double n = std::hypot(l.x(), l.y());
  if (n <= 0) return std::numeric_limits<double>::infinity();
  return std::abs(l.dot(nb)) / n * camera_b.fx;
}

bool TriangulateMidpoint(const Eigen::Vector3d& oa, const Eigen::Vector3d& da, const Eigen::Vector3d& ob,
                         const Eigen::Vector3d& db, Eigen::Vector3d* point, double* angle_rad) {
  const double b = da.dot(db);
  const double denom = 1.0 - b * b;
  if (angle_rad) *angle_rad = std::acos(std::clamp(b, -1.0, 1.0));
  if (denom < 1e-12) return false;
  const Eigen::Vector3d w = oa - ob;
  const double d = da.dot(w), e = db.dot(w);
  const double s = (b * e - d) / denom;
  const double t = (e - b * d) / denom;
  if (s <= 0 || t <= 0) return false;
  *point = 0.5 * ((oa + s * da) + (ob + t * db));
  return true;
}

double WarpedNcc(const cv::Mat& gray_a, const Eigen::Vector2d& p, const cv::Mat& gray_b, const Eigen::Vector2d& q,
                 const Eigen::Matrix2d& jacobian, int h, double* stddev_a, double* stddev_b) {
  const double reach_b =
      h * (std::abs(jacobian(0, 0)) + std::abs(jacobian(0, 1)) + std::abs(jacobian(1, 0)) + std::abs(jacobian(1, 1)));
  if (!Inside(gray_a, p, h + 1) || !Inside(gray_b, q, reach_b + 1)) return -2.0;
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  int n = 0;
  const bool integral = p.x() == std::floor(p.x()) && p.y() == std::floor(p.y());
  const int pu = static_cast<int>(p.x()), pv = static_cast<int>(p.y());
  for (int dy = -h; dy <= h; ++dy) {
    const float* row_a = integral ? gray_a.ptr<float>(pv + dy) + pu : nullptr;
    for (int dx = -h; dx <= h; ++dx) {
      const double va = integral ? row_a[dx] : SampleBilinear(gray_a, p.x() + dx, p.y() + dy);
      const double vb = SampleBilinear(gray_b, q.x() + jacobian(0, 0) * dx + jacobian(0, 1) * dy,
                                       q.y() + jacobian(1, 0) * dx + jacobian(1, 1) * dy);
      sa += va, sb += vb, saa += va * va, sbb += vb * vb, sab += va * vb;
      ++n;
    }
  }
  const double ma = sa / n, mb = sb / n;
  const double va = std::max(0.0, saa / n - ma * ma), vb = std::max(0.0, sbb / n - mb * mb);
  if (stddev_a) *stddev_a = std::sqrt(va);
  if (stddev_b) *stddev_b = std::sqrt(vb);
  if (va <= 1e-9 || vb <= 1e-9) return 0.0;
  return (sab / n - ma * mb) / std::sqrt(va * vb);
}

std::vector<DensePoint> ComputeDensePair(const DenseView& a, const DenseView& b, const std::vector<PointMatch>& matches,
                                         const AffineDenseOptions& o, DensePairStats* stats_out) {
  DensePairStats stats;
  std::vector<DensePoint> out;
  auto finish = [&]() {
    if (stats_out) *stats_out = stats;
    return out;
  };
  if (a.image.empty() || b.image.empty() || a.image.type() != b.image.type() || !a.camera.IsValid() ||
      !b.camera.IsValid() || !ValidateAffineDenseOptions(o, nullptr))
    return finish();
  if (a.image.cols != a.camera.width || a.image.rows != a.camera.height || b.image.cols != b.camera.width ||
      b.image.rows != b.camera.height)
    return finish();
  const Eigen::Vector3d center_a = a.world_from_camera.translation();
  const Eigen::Vector3d center_b = b.world_from_camera.translation();
  if ((center_a - center_b).norm() < 1e-9) return finish();

  // Features: inside both images, finite, deduplicated (order kept, deterministic).
  std::vector<PointMatch> feats;
  feats.reserve(matches.size());
  const double sep2 = o.min_feature_separation_px * o.min_feature_separation_px;
  for (const PointMatch& m : matches) {
    if (!m.a.allFinite() || !m.b.allFinite()) continue;
    if (!a.camera.InImage(m.a) || !b.camera.InImage(m.b)) continue;
    bool dup = false;
    for (const PointMatch& f : feats) {
      if ((f.a - m.a).squaredNorm() < sep2 || (f.b - m.b).squaredNorm() < sep2) {
        dup = true;
        break;
      }
    }
    if (!dup) feats.push_back(m);
  }
  stats.features = static_cast<int>(feats.size());
  if (feats.size() < 3) return finish();

  const Eigen::Matrix3d rwa = a.world_from_camera.linear();
  const Eigen::Matrix3d rwb = b.world_from_camera.linear();
  const Eigen::Isometry3d b_from_a = b.world_from_camera.inverse() * a.world_from_camera;
  const Eigen::Isometry3d a_from_world = a.world_from_camera.inverse();
  const Eigen::Isometry3d b_from_world = b.world_from_camera.inverse();
  const Eigen::Matrix3d essential = EssentialMatrix(a.world_from_camera, b.world_from_camera);
  const Eigen::Matrix3d fundamental = b.camera.K().inverse().transpose() * essential * a.camera.K().inverse();
  const double min_angle = o.min_triangulation_angle_deg * kDegToRad;

  // Triangulate the vertices (depth in A for the depth-edge test, points for the plane mapping).
  std::vector<Eigen::Vector3d> vertex_in_a(feats.size());
  std::vector<char> vertex_ok(feats.size(), 0);
  for (size_t i = 0; i < feats.size(); ++i) {
    const Eigen::Vector3d da = (rwa * a.camera.Unproject(feats[i].a).homogeneous()).normalized();
    const Eigen::Vector3d db = (rwb * b.camera.Unproject(feats[i].b).homogeneous()).normalized();
    Eigen::Vector3d x;
    double angle = 0;
    if (TriangulateMidpoint(center_a, da, center_b, db, &x, &angle) && angle >= min_angle) {
      vertex_in_a[i] = a_from_world * x;
      vertex_ok[i] = vertex_in_a[i].z() > 0;
    }
  }

  // Delaunay triangulation of the features in A.
  cv::Subdiv2D subdiv(cv::Rect(-2, -2, a.image.cols + 4, a.image.rows + 4));
  std::map<std::pair<float, float>, int> index_of;
  for (size_t i = 0; i < feats.size(); ++i) {
    const cv::Point2f pt(static_cast<float>(feats[i].a.x()), static_cast<float>(feats[i].a.y()));
    if (index_of.count({pt.x, pt.y})) continue;
    index_of[{pt.x, pt.y}] = static_cast<int>(i);
    subdiv.insert(pt);
  }
  std::vector<cv::Vec6f> tri_list;
  subdiv.getTriangleList(tri_list);

  cv::Mat gray_a = a.gray.empty() ? GrayFloat(a.image) : a.gray;
  cv::Mat gray_b = b.gray.empty() ? GrayFloat(b.image) : b.gray;
  cv::Mat1b visited = cv::Mat1b::zeros(a.image.rows, a.image.cols);
  const cv::Rect image_rect(0, 0, a.image.cols, a.image.rows);
  cv::Rect roi = o.roi_a.area() > 0 ? (o.roi_a & image_rect) : image_rect;
  if (o.region.valid) roi &= o.region.ImageRect(a.camera, a.world_from_camera, o.region_image_margin_px);
  if (roi.area() <= 0) return finish();
  const int h = o.ncc_half_window;
  const int channels = a.image.channels();
  double refine_shift_sum = 0;
  int64_t refine_count = 0;

  for (const cv::Vec6f& t : tri_list) {
    int idx[3];
    bool real = true;
    for (int k = 0; k < 3; ++k) {
      auto it = index_of.find({t[2 * k], t[2 * k + 1]});
      if (it == index_of.end()) {
        real = false;
        break;
      }
      idx[k] = it->second;
    }
    if (!real) continue;  // a triangle touching Subdiv2D's virtual outer vertices
    ++stats.triangles;
    const Eigen::Vector2d a0 = feats[idx[0]].a, a1 = feats[idx[1]].a, a2 = feats[idx[2]].a;
    const Eigen::Vector2d b0 = feats[idx[0]].b, b1 = feats[idx[1]].b, b2 = feats[idx[2]].b;
    const double area_a = 0.5 * Cross2(a1 - a0, a2 - a0);
    const double area_b = 0.5 * Cross2(b1 - b0, b2 - b0);
    const double max_edge = std::max(
        {(a1 - a0).norm(), (a2 - a1).norm(), (a0 - a2).norm(), (b1 - b0).norm(), (b2 - b1).norm(), (b0 - b2).norm()});
    if (std::abs(area_a) < o.min_triangle_area_px2 || area_a * area_b <= 0 || max_edge > o.max_triangle_edge_px ||
        SmallestAngleDeg(a0, a1, a2) < o.min_triangle_angle_deg) {
      ++stats.triangles_skipped_shape;
      continue;
    }
    if (!vertex_ok[idx[0]] || !vertex_ok[idx[1]] || !vertex_ok[idx[2]]) {
      ++stats.triangles_skipped_depth;
      continue;
    }
    const double z0 = vertex_in_a[idx[0]].z(), z1 = vertex_in_a[idx[1]].z(), z2 = vertex_in_a[idx[2]].z();
    if (std::max({z0, z1, z2}) > o.max_vertex_depth_ratio * std::min({z0, z1, z2})) {
      ++stats.triangles_skipped_depth;
      continue;
    }
    bool junction = false;  // joins the floor to the object: stricter photometric checks below
    if (o.region.valid) {
      const Eigen::Vector3d w0 = a.world_from_camera * vertex_in_a[idx[0]],
                            w1 = a.world_from_camera * vertex_in_a[idx[1]],
                            w2 = a.world_from_camera * vertex_in_a[idx[2]];
      if (o.region.TriangleOutside(w0, w1, w2, o.region_slack_mm)) {
        ++stats.triangles_skipped_region;
        continue;
      }
      junction = o.region.TriangleSpansFloorJunction(w0, w1, w2);
    }
    // Cheap reject before any pixel work: the triangle's bounding box misses the ROI rectangle.
    if (std::max({a0.x(), a1.x(), a2.x()}) < roi.x || std::min({a0.x(), a1.x(), a2.x()}) > roi.x + roi.width - 1 ||
        std::max({a0.y(), a1.y(), a2.y()}) < roi.y || std::min({a0.y(), a1.y(), a2.y()}) > roi.y + roi.height - 1)
      continue;
    {
      const Eigen::Vector3d& v0 = vertex_in_a[idx[0]];
      const Eigen::Vector3d normal = (vertex_in_a[idx[1]] - v0).cross(vertex_in_a[idx[2]] - v0);
      const Eigen::Vector3d centroid = (v0 + vertex_in_a[idx[1]] + vertex_in_a[idx[2]]) / 3.0;
      const double nn = normal.norm() * centroid.norm();
      if (!(nn > 0) || std::abs(normal.dot(centroid)) < std::cos(o.max_triangle_slant_deg * kDegToRad) * nn) {
        ++stats.triangles_skipped_depth;
        continue;
      }
    }
    // Barycentric coordinates: (α, β, γ) = tinv * (u, v, 1); affine map Q = m * (u, v, 1).
    Eigen::Matrix3d tmat;
    tmat << a0.x(), a1.x(), a2.x(), a0.y(), a1.y(), a2.y(), 1, 1, 1;
    const Eigen::Matrix3d tinv = tmat.inverse();
    Eigen::Matrix<double, 2, 3> bmat;
    bmat << b0.x(), b1.x(), b2.x(), b0.y(), b1.y(), b2.y();
    const Eigen::Matrix<double, 2, 3> m = bmat * tinv;
    const Eigen::Matrix2d jac = m.leftCols<2>();
    const Eigen::Vector3d x0 = vertex_in_a[idx[0]];
    const Eigen::Vector3d plane_n = (vertex_in_a[idx[1]] - x0).cross(vertex_in_a[idx[2]] - x0);
    const double plane_d = plane_n.dot(x0);

    const int u_lo = std::max(roi.x, static_cast<int>(std::ceil(std::min({a0.x(), a1.x(), a2.x()}))));
    const int u_hi = std::min(roi.x + roi.width - 1, static_cast<int>(std::floor(std::max({a0.x(), a1.x(), a2.x()}))));
    const int v_lo = std::max(roi.y, static_cast<int>(std::ceil(std::min({a0.y(), a1.y(), a2.y()}))));
    const int v_hi = std::min(roi.y + roi.height - 1, static_cast<int>(std::floor(std::max({a0.y(), a1.y(), a2.y()}))));
    const int step = o.pixel_step;
    for (int v = v_lo + (step - v_lo % step) % step; v <= v_hi; v += step) {
      for (int u = u_lo + (step - u_lo % step) % step; u <= u_hi; u += step) {
        const Eigen::Vector3d bary = tinv * Eigen::Vector3d(u, v, 1);
        if (bary.minCoeff() < -1e-9) continue;
        uint8_t& seen = visited(v, u);
        if (seen) continue;
        seen = 1;
        ++stats.pixels;
        const Eigen::Vector2d p(u, v);
        const Eigen::Vector2d na = a.camera.Unproject(p);
        Eigen::Vector2d q;
        if (o.mapping == static_cast<int>(DenseMapping::kPlane)) {
          const Eigen::Vector3d ray = na.homogeneous();
          const double denom = plane_n.dot(ray);
          if (std::abs(denom) < 1e-12 * plane_n.norm()) {
            ++stats.rejected_outside;
            continue;
          }
          if (!b.camera.Project(b_from_a * (ray * (plane_d / denom)), &q)) {
            ++stats.rejected_outside;
            continue;
          }
        } else {
          q = m * Eigen::Vector3d(u, v, 1);
        }
        if (!Inside(b.image, q, h + 1)) {
          ++stats.rejected_outside;
          continue;
        }
        const Eigen::Vector3d nb_line = essential * na.homogeneous();
        const double line_norm = std::hypot(nb_line.x(), nb_line.y());
        if (!(line_norm > 0) || std::abs(nb_line.dot(b.camera.Unproject(q).homogeneous())) / line_norm * b.camera.fx >
                                    o.epipolar_threshold_px) {
          ++stats.rejected_epipolar;
          continue;
        }
        if (o.refine_along_epipolar) {
          const Eigen::Vector3d l = fundamental * Eigen::Vector3d(u, v, 1);
          const double ln = std::hypot(l.x(), l.y());
          const Eigen::Vector2d dir(-l.y() / ln, l.x() / ln);
          const Eigen::Vector2d q0 = q - (l.dot(q.homogeneous()) / ln) * Eigen::Vector2d(l.x() / ln, l.y() / ln);
          const int n_steps = static_cast<int>(std::floor(o.refine_search_px / o.refine_step_px));
          std::vector<double> scores(2 * n_steps + 1, -2.0);
          int best = -1;
          for (int s = -n_steps; s <= n_steps; ++s) {
            scores[s + n_steps] = WarpedNcc(gray_a, p, gray_b, q0 + (s * o.refine_step_px) * dir, jac, h);
            if (best < 0 || scores[s + n_steps] > scores[best]) best = s + n_steps;
          }
          if (o.reject_refine_at_border && (best == 0 || best == 2 * n_steps)) {
            ++stats.rejected_refine_border;  // the best match lies beyond the search: the affine map is off here
            continue;
          }
          double offset = 0;
          if (best > 0 && best < 2 * n_steps) {
            const double l0 = scores[best - 1], c0 = scores[best], r0 = scores[best + 1];
            const double den = l0 - 2 * c0 + r0;
            if (den < 0 && l0 > -2 && r0 > -2) offset = std::clamp(0.5 * (l0 - r0) / den, -0.5, 0.5);
          }
          const Eigen::Vector2d qr = q0 + ((best - n_steps + offset) * o.refine_step_px) * dir;
          if (!Inside(b.image, qr, h + 1)) {
            ++stats.rejected_outside;
            continue;
          }
          refine_shift_sum += (qr - q).norm();
          ++refine_count;
          q = qr;
        }
        if (o.max_color_difference >= 0) {
          double cb[3];
          SampleBgr(b.image, q.x(), q.y(), cb);
          const uint8_t* pa = a.image.ptr<uint8_t>(v) + u * channels;
          double diff = 0;
          for (int k = 0; k < 3; ++k) diff += std::abs(pa[channels == 3 ? k : 0] - cb[k]);
          if (diff / 3.0 > o.max_color_difference) {
            ++stats.rejected_color;
            continue;
          }
        }
        if (h > 0) {
          double sd_a = 0, sd_b = 0;
          const double ncc = WarpedNcc(gray_a, p, gray_b, q, jac, h, &sd_a, &sd_b);
          if (ncc < -1.5 || (sd_a >= o.min_window_stddev && sd_b >= o.min_window_stddev && ncc < o.min_ncc)) {
            ++stats.rejected_ncc;
            continue;
          }
          if (junction && o.junction_min_window_stddev >= 0 &&
              (sd_a < o.junction_min_window_stddev || sd_b < o.junction_min_window_stddev ||
               ncc < o.junction_min_ncc)) {
            ++stats.rejected_ncc;
            continue;
          }
        }
        const Eigen::Vector3d da = (rwa * na.homogeneous()).normalized();
        const Eigen::Vector3d db = (rwb * b.camera.Unproject(q).homogeneous()).normalized();
        Eigen::Vector3d x;
        double angle = 0;
        Eigen::Vector2d pa_re, pb_re;
        if (!TriangulateMidpoint(center_a, da, center_b, db, &x, &angle) || angle < min_angle ||
            !a.camera.Project(a_from_world * x, &pa_re) || !b.camera.Project(b_from_world * x, &pb_re) ||
            (pa_re - p).norm() > o.max_reprojection_px || (pb_re - q).norm() > o.max_reprojection_px) {
          ++stats.rejected_triangulation;
          continue;
        }
        if ((o.use_world_box && !((x.array() >= o.box_min.array()).all() && (x.array() <= o.box_max.array()).all())) ||
            !o.region.Contains(x)) {
          ++stats.rejected_box;
          continue;
        }
        DensePoint dp;
        dp.point_in_world = x;
        dp.pixel_a = p.cast<float>();
        dp.pixel_b = q.cast<float>();
        dp.toward_camera = (0.5 * (center_a + center_b) - x).normalized().cast<float>();
        const uint8_t* pa = a.image.ptr<uint8_t>(v) + u * channels;
        for (int k = 0; k < 3; ++k) dp.bgr[k] = pa[channels == 3 ? k : 0];
        out.push_back(dp);
        ++stats.accepted;
      }
    }
  }
  if (refine_count > 0) stats.mean_refine_shift_px = refine_shift_sum / refine_count;
  // Triangles come from Subdiv2D in its own order; sort output into raster order of the source pixel is not
  // needed for determinism (Subdiv2D is deterministic for the same input), so keep the order as produced.
  return finish();
}

}  // namespace objscan
