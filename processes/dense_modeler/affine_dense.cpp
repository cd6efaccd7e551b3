#include "processes/dense_modeler/affine_dense.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <unordered_map>
#include <utility>

#include "common/geometry.h"
#include "processes/dense_modeler/image_point_grid.h"

namespace objscan {
namespace {

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

// SmallestAngleDeg(p0, p1, p2) < min_deg, with acos evaluated only within 1e-9 of the limit's cosine (the same
// decision: that margin is far beyond acos' rounding).
bool SmallestAngleBelow(const Eigen::Vector2d& p0, const Eigen::Vector2d& p1, const Eigen::Vector2d& p2,
                        double min_deg) {
  if (!(min_deg > 0.01 && min_deg < 170.0)) return SmallestAngleDeg(p0, p1, p2) < min_deg;
  const double cos_min = std::cos(min_deg * kDegToRad);
  const Eigen::Vector2d pts[3] = {p0, p1, p2};
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector2d e1 = pts[(i + 1) % 3] - pts[i];
    const Eigen::Vector2d e2 = pts[(i + 2) % 3] - pts[i];
    const double n = e1.norm() * e2.norm();
    if (n <= 0) return true;  // SmallestAngleDeg gives 0
    const double c = std::clamp(e1.dot(e2) / n, -1.0, 1.0);
    if (c < cos_min - 1e-9) continue;
    if (c > cos_min + 1e-9 || std::acos(c) / kDegToRad < min_deg) return true;
  }
  return false;
}

double Cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

// TriangulateMidpoint with the cosine of the ray angle instead of the angle (no acos per pixel).
inline bool MidpointCos(const Eigen::Vector3d& oa, const Eigen::Vector3d& da, const Eigen::Vector3d& ob,
                        const Eigen::Vector3d& db, Eigen::Vector3d* point, double* cos_angle) {
  const double b = da.dot(db);
  *cos_angle = b;
  const double denom = 1.0 - b * b;
  if (denom < 1e-12) return false;
  const Eigen::Vector3d w = oa - ob;
  const double d = da.dot(w), e = db.dot(w);
  const double s = (b * e - d) / denom;
  const double t = (e - b * d) / denom;
  if (s <= 0 || t <= 0) return false;
  *point = 0.5 * ((oa + s * da) + (ob + t * db));
  return true;
}

// acos(clamp(cos_angle, -1, 1)) < min_angle, the same decision as comparing TriangulateMidpoint's angle; acos is
// evaluated only within 1e-9 of the limit's cosine (far beyond acos' rounding), or for limits near or above pi.
class AngleLimit {
 public:
  explicit AngleLimit(double min_angle)
      : min_angle_(min_angle), cos_min_(std::cos(min_angle)), exact_(!(min_angle <= 3.0)) {}
  bool Below(double cos_angle) const {
    const double c = std::clamp(cos_angle, -1.0, 1.0);
    if (!exact_) {
      if (c < cos_min_ - 1e-9) return false;
      if (c > cos_min_ + 1e-9) return true;
    }
    return std::acos(c) < min_angle_;
  }

 private:
  double min_angle_, cos_min_;
  bool exact_;
};

// Epipolar test of EpipolarDistancePx: |l·nb| / hypot(l.x, l.y) · fx > threshold. hypot (slow in libm) is replaced by
// sqrt(x² + y²), which agrees with it to a few ulps in the range checked; hypot decides within 1e-9 of the limit.
inline bool EpipolarFar(const Eigen::Vector3d& line, double dot_abs, double fx, double threshold) {
  const double s2 = line.x() * line.x() + line.y() * line.y();
  if (s2 > 1e-200 && s2 < 1e200) {
    const double d = dot_abs / std::sqrt(s2) * fx;
    if (d < threshold * (1 - 1e-9)) return false;
    if (d > threshold * (1 + 1e-9)) return true;
  }
  const double line_norm = std::hypot(line.x(), line.y());
  return !(line_norm > 0) || dot_abs / line_norm * fx > threshold;
}

// Triangulation of a matched pixel pair of two posed views with the checks after matching (ComputeDensePair's and
// TriangulateDenseMatches'): ray midpoint, triangulation angle, reprojection error in A and B, world box, region.
class PairTriangulator {
 public:
  enum Result { kAccepted, kRejectedTriangulation, kRejectedBox };

  PairTriangulator(const PinholeCamera& cam_a, const Eigen::Isometry3d& world_from_a, const PinholeCamera& cam_b,
                   const Eigen::Isometry3d& world_from_b, const AffineDenseOptions& o)
      : cam_a_(cam_a),
        cam_b_(cam_b),
        o_(o),
        center_a_(world_from_a.translation()),
        center_b_(world_from_b.translation()),
        cameras_mid_(0.5 * (center_a_ + center_b_)),
        rwa_(world_from_a.linear()),
        rwb_(world_from_b.linear()),
        a_from_world_(world_from_a.inverse()),
        b_from_world_(world_from_b.inverse()),
        angle_limit_(o.min_triangulation_angle_deg * kDegToRad) {}

  // p in A, q in B (px) with na = cam_a.Unproject(p), nb = cam_b.Unproject(q); on acceptance sets out's point,
  // pixels and toward_camera (not its colour).
  Result Triangulate(const Eigen::Vector2d& p, const Eigen::Vector2d& na, const Eigen::Vector2d& q,
                     const Eigen::Vector2d& nb, DensePoint* out) const {
    const Eigen::Vector3d da = (rwa_ * na.homogeneous()).normalized();
    const Eigen::Vector3d db = (rwb_ * nb.homogeneous()).normalized();
    Eigen::Vector3d x;
    double cos_angle = 0;
    Eigen::Vector2d pa_re, pb_re;
    if (!MidpointCos(center_a_, da, center_b_, db, &x, &cos_angle) || angle_limit_.Below(cos_angle) ||
        !cam_a_.Project(a_from_world_ * x, &pa_re) || !cam_b_.Project(b_from_world_ * x, &pb_re) ||
        (pa_re - p).norm() > o_.max_reprojection_px || (pb_re - q).norm() > o_.max_reprojection_px)
      return kRejectedTriangulation;
    if ((o_.use_world_box && !((x.array() >= o_.box_min.array()).all() && (x.array() <= o_.box_max.array()).all())) ||
        !o_.region.Contains(x))
      return kRejectedBox;
    out->point_in_world = x;
    out->pixel_a = p.cast<float>();
    out->pixel_b = q.cast<float>();
    out->toward_camera = (cameras_mid_ - x).normalized().cast<float>();
    return kAccepted;
  }

 private:
  const PinholeCamera& cam_a_;
  const PinholeCamera& cam_b_;
  const AffineDenseOptions& o_;
  const Eigen::Vector3d center_a_, center_b_, cameras_mid_;
  const Eigen::Matrix3d rwa_, rwb_;
  const Eigen::Isometry3d a_from_world_, b_from_world_;
  const AngleLimit angle_limit_;
};

constexpr int kMaxHalfWindow = 10;  // ValidateAffineDenseOptions' limit of ncc_half_window
constexpr int kMaxSide = 2 * kMaxHalfWindow + 1;

// The NCC window offsets J·d of one affine map, hoisted out of the pixel loop: a window sample of B at q + J·d is
// (q.x + J00·dx + J01·dy, q.y + J10·dx + J11·dy), summed in that order as in the reference expression.
struct WindowWarp {
  int h = 0;
  double reach = 0;                                                       // px, h·(|J00| + |J01| + |J10| + |J11|)
  double x_dx[kMaxSide], y_dx[kMaxSide], x_dy[kMaxSide], y_dy[kMaxSide];  // index d + h

  WindowWarp(const Eigen::Matrix2d& j, int half_window) : h(half_window) {
    reach = h * (std::abs(j(0, 0)) + std::abs(j(0, 1)) + std::abs(j(1, 0)) + std::abs(j(1, 1)));
    for (int d = -h; d <= h; ++d) {
      x_dx[d + h] = j(0, 0) * d;
      y_dx[d + h] = j(1, 0) * d;
      x_dy[d + h] = j(0, 1) * d;
      y_dy[d + h] = j(1, 1) * d;
    }
  }
};

// The window of gray image A around p (its values and sums, accumulated in raster order like the NCC's).
struct WindowA {
  bool inside = false;
  double sum = 0, sum_sq = 0;
  float value[kMaxSide * kMaxSide];  // raster order

  WindowA() = default;
  WindowA(const cv::Mat& gray_a, const Eigen::Vector2d& p, int h) { Set(gray_a, p, h); }
  // h in [0, kMaxHalfWindow].
  void Set(const cv::Mat& gray_a, const Eigen::Vector2d& p, int h) {
    inside = false;
    sum = sum_sq = 0;
    if (!Inside(gray_a, p, h + 1)) return;
    inside = true;
    const bool integral = p.x() == std::floor(p.x()) && p.y() == std::floor(p.y());
    const int pu = static_cast<int>(p.x()), pv = static_cast<int>(p.y());
    float* out = value;
    for (int dy = -h; dy <= h; ++dy) {
      if (integral) {
        const float* row_a = gray_a.ptr<float>(pv + dy) + pu;
        for (int dx = -h; dx <= h; ++dx) *out++ = row_a[dx];
      } else {
        for (int dx = -h; dx <= h; ++dx) *out++ = SampleBilinear(gray_a, p.x() + dx, p.y() + dy);
      }
    }
    double s = 0, ss = 0;  // locals: the compiler keeps them in registers
    for (const float* v = value; v < out; ++v) {
      const double va = *v;
      s += va;
      ss += va * va;
    }
    sum = s;
    sum_sq = ss;
  }
};

// Bilinear sample of gray B at (x, y) >= 0 (truncation = floor), the same float expression as SampleBilinear.
inline float SampleAt(const uchar* data, size_t step, double x, double y) {
  const int u0 = static_cast<int>(x), v0 = static_cast<int>(y);
  const float fu = static_cast<float>(x - u0), fv = static_cast<float>(y - v0);
  const float* r0 = reinterpret_cast<const float*>(data + v0 * step) + u0;
  const float* r1 = reinterpret_cast<const float*>(data + (v0 + 1) * step) + u0;
  return (1 - fv) * ((1 - fu) * r0[0] + fu * r0[1]) + fv * ((1 - fu) * r1[0] + fu * r1[1]);
}

// Implementations of the window NCC sampling and of the refinement's search scores, all bit-identical
// (AffineDenseOptions::refine_kernel): auto = AVX2 where available, else the reference; reference = one WindowNcc per
// search step, windows sampled with SSE2 (the SSE2 batched over steps was measured slower); portable = scalar
// sampling, steps batched; AVX2 = steps batched, windows sampled with AVX2.
enum SearchKernel : int { kSearchAuto = 0, kSearchReference = 1, kSearchPortable = 2, kSearchAvx2 = 3 };
constexpr int kSearchLanes = 8;  // search lanes are padded to a multiple of this (the widest kernel's)

#if defined(__x86_64__) && defined(__GNUC__)
bool CpuHasAvx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}

// The pixel pairs (base[k], base[k + 1]) of k = k0, k1, k2, k3 (p0 p1 of k0, of k1 | of k2, of k3; 8-byte loads
// through __m64, which may alias float).
__attribute__((target("avx2"))) inline __m256 PixelPairs4(const float* base, int32_t k0, int32_t k1, int32_t k2,
                                                          int32_t k3) {
  const __m128 lo = _mm_loadh_pi(_mm_loadl_pi(_mm_setzero_ps(), reinterpret_cast<const __m64*>(base + k0)),
                                 reinterpret_cast<const __m64*>(base + k1));
  const __m128 hi = _mm_loadh_pi(_mm_loadl_pi(_mm_setzero_ps(), reinterpret_cast<const __m64*>(base + k2)),
                                 reinterpret_cast<const __m64*>(base + k3));
  return _mm256_insertf128_ps(_mm256_castps128_ps256(lo), hi, 1);
}

// Bilinear samples of eight positions: k[l] = float index of lane l's top-left pixel, (fu, fv) its fractions; the
// scalar SampleAt's float expression per lane.
__attribute__((target("avx2"))) inline __m256 BilinearAvx2(const float* row0, const float* row1, const int32_t* k,
                                                           __m256 fu, __m256 fv) {
  const __m256 one = _mm256_set1_ps(1.0f);
  const __m256 ta = PixelPairs4(row0, k[0], k[1], k[4], k[5]), tb = PixelPairs4(row0, k[2], k[3], k[6], k[7]);
  const __m256 ba = PixelPairs4(row1, k[0], k[1], k[4], k[5]), bb = PixelPairs4(row1, k[2], k[3], k[6], k[7]);
  const __m256 p00 = _mm256_shuffle_ps(ta, tb, _MM_SHUFFLE(2, 0, 2, 0));
  const __m256 p01 = _mm256_shuffle_ps(ta, tb, _MM_SHUFFLE(3, 1, 3, 1));
  const __m256 p10 = _mm256_shuffle_ps(ba, bb, _MM_SHUFFLE(2, 0, 2, 0));
  const __m256 p11 = _mm256_shuffle_ps(ba, bb, _MM_SHUFFLE(3, 1, 3, 1));
  const __m256 gu = _mm256_sub_ps(one, fu), gv = _mm256_sub_ps(one, fv);
  const __m256 top = _mm256_add_ps(_mm256_mul_ps(gu, p00), _mm256_mul_ps(fu, p01));
  const __m256 bottom = _mm256_add_ps(_mm256_mul_ps(gu, p10), _mm256_mul_ps(fu, p11));
  return _mm256_add_ps(_mm256_mul_ps(gv, top), _mm256_mul_ps(fv, bottom));
}
#else
bool CpuHasAvx2() { return false; }
#endif

// The kernel to run for a requested one (AVX2 falls back to the reference without AVX2; the AVX2 code indexes gray B
// with int32).
int ResolveKernel(int kernel, const cv::Mat& gray_b) {
  if (kernel == kSearchAuto) kernel = kSearchAvx2;
  if (kernel == kSearchAvx2 && (!CpuHasAvx2() || gray_b.step[0] / sizeof(float) * (gray_b.rows + 1.0) > 2e9))
    kernel = kSearchReference;
  return kernel;
}

// The window samples of B at q + J·d in raster order (q passed the reach test: every sample lies inside B).
void SampleWindowPortable(const WindowWarp& w, const cv::Mat& gray_b, const Eigen::Vector2d& q, float* vb) {
  const int side = 2 * w.h + 1;
  for (int iy = 0; iy < side; ++iy) {
    const double ox = w.x_dy[iy], oy = w.y_dy[iy];
    for (int ix = 0; ix < side; ++ix)
      *vb++ = SampleAt(gray_b.data, gray_b.step[0], q.x() + w.x_dx[ix] + ox, q.y() + w.y_dx[ix] + oy);
  }
}

#if defined(__SSE2__)
// The same samples, four at a time with SSE2: the same operations per lane (truncation, double subtraction,
// rounding to float, float bilinear expression), so bit-identical to the portable path.
void SampleWindowSse2(const WindowWarp& w, const cv::Mat& gray_b, const Eigen::Vector2d& q, float* vb) {
  const int side = 2 * w.h + 1, n = side * side;
  alignas(16) double xs[kMaxSide * kMaxSide + 3], ys[kMaxSide * kMaxSide + 3];
  for (int iy = 0, i = 0; iy < side; ++iy) {
    const double ox = w.x_dy[iy], oy = w.y_dy[iy];
    for (int ix = 0; ix < side; ++ix, ++i) {
      xs[i] = q.x() + w.x_dx[ix] + ox;
      ys[i] = q.y() + w.y_dx[ix] + oy;
    }
  }
  const uchar* data = gray_b.data;
  const size_t step = gray_b.step[0];
  const __m128 one = _mm_set1_ps(1.0f);
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    const __m128d x01 = _mm_load_pd(xs + i), x23 = _mm_load_pd(xs + i + 2);
    const __m128d y01 = _mm_load_pd(ys + i), y23 = _mm_load_pd(ys + i + 2);
    const __m128i u01 = _mm_cvttpd_epi32(x01), u23 = _mm_cvttpd_epi32(x23);
    const __m128i v01 = _mm_cvttpd_epi32(y01), v23 = _mm_cvttpd_epi32(y23);
    const __m128 fu = _mm_movelh_ps(_mm_cvtpd_ps(_mm_sub_pd(x01, _mm_cvtepi32_pd(u01))),
                                    _mm_cvtpd_ps(_mm_sub_pd(x23, _mm_cvtepi32_pd(u23))));
    const __m128 fv = _mm_movelh_ps(_mm_cvtpd_ps(_mm_sub_pd(y01, _mm_cvtepi32_pd(v01))),
                                    _mm_cvtpd_ps(_mm_sub_pd(y23, _mm_cvtepi32_pd(v23))));
    alignas(16) int32_t u[4], v[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(u), _mm_unpacklo_epi64(u01, u23));
    _mm_store_si128(reinterpret_cast<__m128i*>(v), _mm_unpacklo_epi64(v01, v23));
    // The pixel pairs (r0[0], r0[1]) and (r1[0], r1[1]) of each sample, 8 bytes each, then transposed.
    __m128 top_pairs[4], bottom_pairs[4];
    for (int k = 0; k < 4; ++k) {
      const uchar* r0 = data + v[k] * step + u[k] * sizeof(float);
      top_pairs[k] = _mm_loadl_pi(_mm_setzero_ps(), reinterpret_cast<const __m64*>(r0));
      bottom_pairs[k] = _mm_loadl_pi(_mm_setzero_ps(), reinterpret_cast<const __m64*>(r0 + step));
    }
    const __m128 t01 = _mm_movelh_ps(top_pairs[0], top_pairs[1]), t23 = _mm_movelh_ps(top_pairs[2], top_pairs[3]);
    const __m128 b01 = _mm_movelh_ps(bottom_pairs[0], bottom_pairs[1]);
    const __m128 b23 = _mm_movelh_ps(bottom_pairs[2], bottom_pairs[3]);
    const __m128 p00 = _mm_shuffle_ps(t01, t23, _MM_SHUFFLE(2, 0, 2, 0));
    const __m128 p01 = _mm_shuffle_ps(t01, t23, _MM_SHUFFLE(3, 1, 3, 1));
    const __m128 p10 = _mm_shuffle_ps(b01, b23, _MM_SHUFFLE(2, 0, 2, 0));
    const __m128 p11 = _mm_shuffle_ps(b01, b23, _MM_SHUFFLE(3, 1, 3, 1));
    const __m128 gu = _mm_sub_ps(one, fu), gv = _mm_sub_ps(one, fv);
    const __m128 top = _mm_add_ps(_mm_mul_ps(gu, p00), _mm_mul_ps(fu, p01));
    const __m128 bottom = _mm_add_ps(_mm_mul_ps(gu, p10), _mm_mul_ps(fu, p11));
    _mm_storeu_ps(vb + i, _mm_add_ps(_mm_mul_ps(gv, top), _mm_mul_ps(fv, bottom)));
  }
  for (; i < n; ++i) vb[i] = SampleAt(data, step, xs[i], ys[i]);
}
#endif

#if defined(__x86_64__) && defined(__GNUC__)
// The same samples, eight at a time with AVX2 (the same per-sample operations; no FMA, nothing contracted).
__attribute__((target("avx2"))) void SampleWindowAvx2(const WindowWarp& w, const cv::Mat& gray_b,
                                                      const Eigen::Vector2d& q, float* vb) {
  const int side = 2 * w.h + 1, n = side * side;
  alignas(32) double xs[kMaxSide * kMaxSide + 7], ys[kMaxSide * kMaxSide + 7];
  for (int iy = 0, i = 0; iy < side; ++iy) {
    const double ox = w.x_dy[iy], oy = w.y_dy[iy];
    for (int ix = 0; ix < side; ++ix, ++i) {
      xs[i] = q.x() + w.x_dx[ix] + ox;
      ys[i] = q.y() + w.y_dx[ix] + oy;
    }
  }
  const float* row0 = reinterpret_cast<const float*>(gray_b.data);
  const float* row1 = reinterpret_cast<const float*>(gray_b.data + gray_b.step[0]);
  const __m256d stride = _mm256_set1_pd(static_cast<double>(gray_b.step[0] / sizeof(float)));
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256d x0 = _mm256_load_pd(xs + i), x1 = _mm256_load_pd(xs + i + 4);
    const __m256d y0 = _mm256_load_pd(ys + i), y1 = _mm256_load_pd(ys + i + 4);
    const __m256d xt0 = _mm256_round_pd(x0, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC);
    const __m256d xt1 = _mm256_round_pd(x1, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC);
    const __m256d yt0 = _mm256_round_pd(y0, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC);
    const __m256d yt1 = _mm256_round_pd(y1, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC);
    const __m256 fu = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm256_cvtpd_ps(_mm256_sub_pd(x0, xt0))),
                                           _mm256_cvtpd_ps(_mm256_sub_pd(x1, xt1)), 1);
    const __m256 fv = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm256_cvtpd_ps(_mm256_sub_pd(y0, yt0))),
                                           _mm256_cvtpd_ps(_mm256_sub_pd(y1, yt1)), 1);
    alignas(32) int32_t k[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(k),
                       _mm256_set_m128i(_mm256_cvttpd_epi32(_mm256_add_pd(_mm256_mul_pd(yt1, stride), xt1)),
                                        _mm256_cvttpd_epi32(_mm256_add_pd(_mm256_mul_pd(yt0, stride), xt0))));
    _mm256_storeu_ps(vb + i, BilinearAvx2(row0, row1, k, fu, fv));
  }
  for (; i < n; ++i) vb[i] = SampleAt(gray_b.data, gray_b.step[0], xs[i], ys[i]);
}
#endif

// The NCC of window A (n samples) and B from B's sums: sum, sum of squares and sum of products with A.
inline double NccFromSums(const WindowA& wa, int n, double sb, double sbb, double sab, double* stddev_a,
                          double* stddev_b) {
  const double ma = wa.sum / n, mb = sb / n;
  const double va = std::max(0.0, wa.sum_sq / n - ma * ma), vbv = std::max(0.0, sbb / n - mb * mb);
  if (stddev_a) *stddev_a = std::sqrt(va);
  if (stddev_b) *stddev_b = std::sqrt(vbv);
  if (va <= 1e-9 || vbv <= 1e-9) return 0.0;
  return (sab / n - ma * mb) / std::sqrt(va * vbv);
}

// NCC of window A and gray B at q + J·d (bilinear); -2 when a window leaves an image. Bit-identical to the plain
// interleaved loop (each sum is accumulated in the same order). Samples lie at x, y >= 0 once q passed the reach
// test, so truncation is floor. kernel: the sampling path (a SearchKernel; the reference samples with SSE2).
double WindowNcc(const WindowA& wa, const WindowWarp& w, const cv::Mat& gray_b, const Eigen::Vector2d& q,
                 double* stddev_a, double* stddev_b, int kernel = kSearchAuto) {
  if (!wa.inside || !Inside(gray_b, q, w.reach + 1)) return -2.0;
  const int side = 2 * w.h + 1;
  float vb[kMaxSide * kMaxSide];
  switch (ResolveKernel(kernel, gray_b)) {
#if defined(__x86_64__) && defined(__GNUC__)
    case kSearchAvx2:
      SampleWindowAvx2(w, gray_b, q, vb);
      break;
#endif
#if defined(__SSE2__)
    case kSearchReference:
      SampleWindowSse2(w, gray_b, q, vb);
      break;
#endif
    default:
      SampleWindowPortable(w, gray_b, q, vb);
  }
  const int n = side * side;
  double sb = 0, sbb = 0, sab = 0;
  for (int i = 0; i < n; ++i) {
    const double b = vb[i];
    sb += b, sbb += b * b, sab += static_cast<double>(wa.value[i]) * b;
  }
  return NccFromSums(wa, n, sb, sbb, sab, stddev_a, stddev_b);
}

// The 1-D refinement search's NCC scores, a list of steps of one pixel at once (SearchScores below): WindowNcc at
// q_s = q0 + (s·step)·dir for each listed s in [-n, n] into scores[s + n], bit-identical to one
// WindowNcc(wa, w, gray_b, q_s) per step (the reference). The steps are the SIMD lanes: every lane does the sample's
// operations of WindowNcc (the same double positions, truncation, float bilinear expression) and accumulates its sums
// in the same order, so only the work is shared (the window offsets, the loop, the setup), never an operation
// reordered.
struct SearchScratch {
  std::vector<double> qx, qy, sb, sbb, sab;  // per lane (padded): position of the window centre in B, B's sums
  std::vector<char> inside;                  // per step: the window lies inside B
  std::vector<float> fu, fv;                 // AVX2 kernel: per window sample and lane, the bilinear fractions
  std::vector<int32_t> index;                // and the float index of the top-left pixel in B
  std::vector<double> value_a;               // and window A's values in double
  std::vector<double> lane_scores;           // per lane: the AVX2 kernel's scores before they go to their steps
};

// B's sums of every lane (lanes: a multiple of kSearchLanes; every lane's window inside B).
void SearchSumsPortable(const WindowA& wa, const WindowWarp& w, const cv::Mat& gray_b, int lanes, SearchScratch* sc) {
  const int side = 2 * w.h + 1;
  const uchar* data = gray_b.data;
  const size_t step = gray_b.step[0];
  for (int k = 0; k < lanes; ++k) {
    double sb = 0, sbb = 0, sab = 0;
    const double qx = sc->qx[k], qy = sc->qy[k];
    for (int iy = 0, i = 0; iy < side; ++iy) {
      const double ox = w.x_dy[iy], oy = w.y_dy[iy];
      for (int ix = 0; ix < side; ++ix, ++i) {
        const double b = SampleAt(data, step, qx + w.x_dx[ix] + ox, qy + w.y_dx[ix] + oy);
        sb += b, sbb += b * b, sab += static_cast<double>(wa.value[i]) * b;
      }
    }
    sc->sb[k] = sb, sc->sbb[k] = sbb, sc->sab[k] = sab;
  }
}

#if defined(__x86_64__) && defined(__GNUC__)
// Eight lanes at a time with AVX2: the same per-lane operations (FMA is not enabled: nothing is contracted). Two
// passes per group of eight lanes: the sample positions' fractions and pixel indices of the whole window, then the
// bilinear samples and the sums (short dependency chains, and the indices are read back as scalars).
__attribute__((target("avx2"))) void SearchSumsAvx2(const WindowA& wa, const WindowWarp& w, const cv::Mat& gray_b,
                                                    int lanes, SearchScratch* sc) {
  const int side = 2 * w.h + 1, n = side * side;
  const float* row0 = reinterpret_cast<const float*>(gray_b.data);
  const float* row1 = reinterpret_cast<const float*>(gray_b.data + gray_b.step[0]);
  const __m256d stride = _mm256_set1_pd(static_cast<double>(gray_b.step[0] / sizeof(float)));
  sc->fu.resize(8 * n), sc->fv.resize(8 * n), sc->index.resize(8 * n), sc->value_a.resize(n);
  float* fus = sc->fu.data();
  float* fvs = sc->fv.data();
  int32_t* indices = sc->index.data();
  double* value_a = sc->value_a.data();
  for (int i = 0; i < n; ++i) value_a[i] = static_cast<double>(wa.value[i]);
  for (int c = 0; c < lanes; c += 8) {
    const __m256d qx0 = _mm256_loadu_pd(&sc->qx[c]), qx1 = _mm256_loadu_pd(&sc->qx[c + 4]);
    const __m256d qy0 = _mm256_loadu_pd(&sc->qy[c]), qy1 = _mm256_loadu_pd(&sc->qy[c + 4]);
    // (q + J·dx) per column, then + J·dy per sample: the reference's summation order.
    __m256d col_x[2 * kMaxSide], col_y[2 * kMaxSide];
    for (int ix = 0; ix < side; ++ix) {
      const __m256d dx = _mm256_set1_pd(w.x_dx[ix]), dy = _mm256_set1_pd(w.y_dx[ix]);
      col_x[2 * ix] = _mm256_add_pd(qx0, dx), col_x[2 * ix + 1] = _mm256_add_pd(qx1, dx);
      col_y[2 * ix] = _mm256_add_pd(qy0, dy), col_y[2 * ix + 1] = _mm256_add_pd(qy1, dy);
    }
    for (int iy = 0, i = 0; iy < side; ++iy) {
      const __m256d ox = _mm256_set1_pd(w.x_dy[iy]), oy = _mm256_set1_pd(w.y_dy[iy]);
      for (int ix = 0; ix < side; ++ix, ++i) {
        const __m256d x0 = _mm256_add_pd(col_x[2 * ix], ox), x1 = _mm256_add_pd(col_x[2 * ix + 1], ox);
        const __m256d y0 = _mm256_add_pd(col_y[2 * ix], oy), y1 = _mm256_add_pd(col_y[2 * ix + 1], oy);
        // Truncation (x, y >= 0: the int conversion's) and the exact fractions; the index in double is exact too.
        const __m256d xt0 = _mm256_round_pd(x0, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC);
        const __m256d xt1 = _mm256_round_pd(x1, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC);
        const __m256d yt0 = _mm256_round_pd(y0, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC);
        const __m256d yt1 = _mm256_round_pd(y1, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC);
        _mm256_storeu_ps(fus + 8 * i,
                         _mm256_insertf128_ps(_mm256_castps128_ps256(_mm256_cvtpd_ps(_mm256_sub_pd(x0, xt0))),
                                              _mm256_cvtpd_ps(_mm256_sub_pd(x1, xt1)), 1));
        _mm256_storeu_ps(fvs + 8 * i,
                         _mm256_insertf128_ps(_mm256_castps128_ps256(_mm256_cvtpd_ps(_mm256_sub_pd(y0, yt0))),
                                              _mm256_cvtpd_ps(_mm256_sub_pd(y1, yt1)), 1));
        const __m128i k0 = _mm256_cvttpd_epi32(_mm256_add_pd(_mm256_mul_pd(yt0, stride), xt0));
        const __m128i k1 = _mm256_cvttpd_epi32(_mm256_add_pd(_mm256_mul_pd(yt1, stride), xt1));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(indices + 8 * i), _mm256_set_m128i(k1, k0));
      }
    }
    __m256d sb0 = _mm256_setzero_pd(), sb1 = sb0, sbb0 = sb0, sbb1 = sb0, sab0 = sb0, sab1 = sb0;
    for (int i = 0; i < n; ++i) {
      const __m256 val =
          BilinearAvx2(row0, row1, indices + 8 * i, _mm256_loadu_ps(fus + 8 * i), _mm256_loadu_ps(fvs + 8 * i));
      const __m256d b0 = _mm256_cvtps_pd(_mm256_castps256_ps128(val));
      const __m256d b1 = _mm256_cvtps_pd(_mm256_extractf128_ps(val, 1));
      const __m256d av = _mm256_broadcast_sd(value_a + i);
      sb0 = _mm256_add_pd(sb0, b0), sb1 = _mm256_add_pd(sb1, b1);
      sbb0 = _mm256_add_pd(sbb0, _mm256_mul_pd(b0, b0)), sbb1 = _mm256_add_pd(sbb1, _mm256_mul_pd(b1, b1));
      sab0 = _mm256_add_pd(sab0, _mm256_mul_pd(av, b0)), sab1 = _mm256_add_pd(sab1, _mm256_mul_pd(av, b1));
    }
    _mm256_storeu_pd(&sc->sb[c], sb0), _mm256_storeu_pd(&sc->sb[c + 4], sb1);
    _mm256_storeu_pd(&sc->sbb[c], sbb0), _mm256_storeu_pd(&sc->sbb[c + 4], sbb1);
    _mm256_storeu_pd(&sc->sab[c], sab0), _mm256_storeu_pd(&sc->sab[c + 4], sab1);
  }
}

// NccFromSums of lanes [0, count) into scores (lanes whose window leaves B get -2), four at a time: the same IEEE
// operations (division and square root are correctly rounded; max(x, 0) picks 0 exactly when std::max(0.0, x) does).
__attribute__((target("avx2"))) void FinishScoresAvx2(const WindowA& wa, int n, int count, const SearchScratch& sc,
                                                      double* scores) {
  const double ma = wa.sum / n;
  const double va = std::max(0.0, wa.sum_sq / n - ma * ma);
  const __m256d nd = _mm256_set1_pd(static_cast<double>(n)), ma4 = _mm256_set1_pd(ma), va4 = _mm256_set1_pd(va);
  const __m256d zero = _mm256_setzero_pd(), flat = _mm256_set1_pd(1e-9);
  const bool flat_a = va <= 1e-9;
  for (int k = 0; k < count; k += 4) {
    const __m256d mb = _mm256_div_pd(_mm256_loadu_pd(&sc.sb[k]), nd);
    const __m256d vbv =
        _mm256_max_pd(_mm256_sub_pd(_mm256_div_pd(_mm256_loadu_pd(&sc.sbb[k]), nd), _mm256_mul_pd(mb, mb)), zero);
    const __m256d num = _mm256_sub_pd(_mm256_div_pd(_mm256_loadu_pd(&sc.sab[k]), nd), _mm256_mul_pd(ma4, mb));
    __m256d r = _mm256_div_pd(num, _mm256_sqrt_pd(_mm256_mul_pd(va4, vbv)));
    r = flat_a ? zero : _mm256_blendv_pd(r, zero, _mm256_cmp_pd(vbv, flat, _CMP_LE_OQ));
    alignas(32) double out[4];
    _mm256_store_pd(out, r);
    for (int l = 0; l < 4 && k + l < count; ++l) scores[k + l] = sc.inside[k + l] ? out[l] : -2.0;
  }
}
#endif

// scores[s + n_steps] for each s of steps[0, count) (each in [-n_steps, n_steps], distinct; see above; other scores
// are left as they are); kernel: a SearchKernel.
void SearchScores(const WindowA& wa, const WindowWarp& w, const cv::Mat& gray_b, const Eigen::Vector2d& q0,
                  const Eigen::Vector2d& dir, double step, int n_steps, const int* steps, int count, int kernel,
                  SearchScratch* sc, double* scores) {
  kernel = ResolveKernel(kernel, gray_b);
  if (kernel == kSearchReference) {
    for (int i = 0; i < count; ++i)
      scores[steps[i] + n_steps] =
          WindowNcc(wa, w, gray_b, q0 + (steps[i] * step) * dir, nullptr, nullptr, kSearchReference);
    return;
  }
  for (int i = 0; i < count; ++i) scores[steps[i] + n_steps] = -2.0;
  if (!wa.inside || count <= 0) return;
  const int lanes = (count + kSearchLanes - 1) / kSearchLanes * kSearchLanes;
  sc->qx.resize(lanes), sc->qy.resize(lanes), sc->sb.resize(lanes), sc->sbb.resize(lanes), sc->sab.resize(lanes);
  sc->inside.resize(count);
  sc->lane_scores.resize(lanes);
  double* qx = sc->qx.data();
  double* qy = sc->qy.data();
  char* inside = sc->inside.data();
  int any = -1;
  // The reference's q0 + (s * step) * dir and Inside(gray_b, q, w.reach + 1), spelled out.
  const double margin = w.reach + 1, x_end = gray_b.cols - 1 - margin, y_end = gray_b.rows - 1 - margin;
  for (int k = 0; k < count; ++k) {
    const double t = steps[k] * step, x = q0.x() + t * dir.x(), y = q0.y() + t * dir.y();
    const bool in = x >= margin && y >= margin && x < x_end && y < y_end;
    qx[k] = x, qy[k] = y, inside[k] = in;
    if (in && any < 0) any = k;
  }
  if (any < 0) return;
  // Lanes whose window leaves B (and the padding) sample the window of an inside lane instead; their score stays -2.
  for (int k = 0; k < lanes; ++k)
    if (k >= count || !inside[k]) qx[k] = qx[any], qy[k] = qy[any];
  const int n = (2 * w.h + 1) * (2 * w.h + 1);
  double* lane_scores = sc->lane_scores.data();
#if defined(__x86_64__) && defined(__GNUC__)
  if (kernel == kSearchAvx2) {
    SearchSumsAvx2(wa, w, gray_b, lanes, sc);
    FinishScoresAvx2(wa, n, count, *sc, lane_scores);
    for (int k = 0; k < count; ++k) scores[steps[k] + n_steps] = lane_scores[k];
    return;
  }
#endif
  SearchSumsPortable(wa, w, gray_b, lanes, sc);
  for (int k = 0; k < count; ++k)
    if (sc->inside[k])
      scores[steps[k] + n_steps] = NccFromSums(wa, n, sc->sb[k], sc->sbb[k], sc->sab[k], nullptr, nullptr);
}

// Exact key of a float pixel position (+0.0f folds -0 into +0, as float comparison does).
inline uint64_t FloatPairKey(float x, float y) {
  x += 0.0f;
  y += 0.0f;
  uint32_t bx, by;
  std::memcpy(&bx, &x, 4);
  std::memcpy(&by, &y, 4);
  return (static_cast<uint64_t>(bx) << 32) | by;
}

// Per-thread buffers reused from pair to pair (gray images, visited mask, search): no page faults per pair.
struct PairScratch {
  cv::Mat gray8, gray_a, gray_b;
  cv::Mat1b visited;
  std::vector<double> scores;
  std::vector<int> near_steps, far_steps;  // the search's steps near the prediction and beyond
  SearchScratch search;
};

// CV_8UC1 gray of image: the image itself when it is gray, else converted into *buffer (reused).
const cv::Mat& Gray8Into(const cv::Mat& image, cv::Mat* buffer) {
  if (image.channels() == 1) return image;
  cv::cvtColor(image, *buffer, cv::COLOR_BGR2GRAY);
  return *buffer;
}

// The view's float gray: its own, else its gray8 (or its image's gray) converted into *out; the same values.
const cv::Mat& GrayFloatOf(const DenseView& v, cv::Mat* gray8, cv::Mat* out) {
  if (!v.gray.empty()) return v.gray;
  (v.gray8.empty() ? Gray8Into(v.image, gray8) : v.gray8).convertTo(*out, CV_32F);
  return *out;
}

}  // namespace

bool ValidateAffineDenseOptions(const AffineDenseOptions& o, std::string* why) {
  std::ostringstream e;
  if (o.mapping != 0 && o.mapping != 1) e << "mapping must be 0 (affine) or 1 (plane); ";
  if (o.pixel_step < 1) e << "pixel_step must be >= 1; ";
  if (!(o.epipolar_threshold_px > 0)) e << "epipolar_threshold_px must be > 0; ";
  if (o.ncc_half_window < 0 || o.ncc_half_window > kMaxHalfWindow)
    e << "ncc_half_window must be in [0, " << kMaxHalfWindow << "]; ";
  if (!(o.min_ncc >= -1 && o.min_ncc <= 1)) e << "min_ncc must be in [-1, 1]; ";
  if (!(o.strict_triangle_edge_px > 0)) e << "strict_triangle_edge_px must be > 0 px; ";
  if (!(o.junction_min_ncc >= -1 && o.junction_min_ncc <= 1)) e << "junction_min_ncc must be in [-1, 1]; ";
  if (!(o.junction_floor_ncc_margin <= 2)) e << "junction_floor_ncc_margin must be <= 2 (< 0 = off); ";
  if (!(o.junction_floor_min_separation_px >= 0)) e << "junction_floor_min_separation_px must be >= 0 px; ";
  if (o.refine_along_epipolar && o.ncc_half_window < 1) e << "refinement needs ncc_half_window >= 1; ";
  if (!(o.refine_search_px > 0) || !(o.refine_step_px > 0)) e << "refine search and step must be > 0; ";
  if (o.refine_along_epipolar && !(o.refine_search_px >= o.refine_step_px))
    e << "refine search must be >= refine step (else the search has no step but the prediction); ";
  if (o.refine_kernel < 0 || o.refine_kernel > 3) e << "refine_kernel must be in [0, 3]; ";
  if (o.refine_first_steps < 0) e << "refine_first_steps must be >= 0 (0 = every step at once); ";
  if (!(o.refine_first_min_ncc >= -1 && o.refine_first_min_ncc <= 1)) e << "refine_first_min_ncc must be in [-1, 1]; ";
  if (!(o.max_triangle_edge_px > 0)) e << "max_triangle_edge_px must be > 0; ";
  if (!(o.max_vertex_depth_ratio >= 1)) e << "max_vertex_depth_ratio must be >= 1; ";
  if (!(o.max_triangle_slant_deg > 0 && o.max_triangle_slant_deg <= 90))
    e << "max_triangle_slant_deg must be in (0, 90]; ";
  if (!(o.max_reprojection_px > 0)) e << "max_reprojection_px must be > 0; ";
  if (!(o.min_triangulation_angle_deg >= 0)) e << "min_triangulation_angle_deg must be >= 0; ";
  if (o.use_world_box && !(o.box_min.array() < o.box_max.array()).all()) e << "world box min must be < max; ";
  if (o.region.valid && !(o.region.box_min.array() < o.region.box_max.array()).all()) e << "region min must be < max; ";
  if (!(o.region_slack_mm >= 0) || !(o.region_image_margin_px >= 0)) e << "region slack and margin must be >= 0; ";
  const std::string msg = e.str();
  if (msg.empty()) return true;
  if (why) *why = msg.substr(0, msg.size() - 2);
  return false;
}

cv::Mat GrayFloat(const cv::Mat& image) {
  cv::Mat buffer, out;
  Gray8Into(image, &buffer).convertTo(out, CV_32F);
  return out;
}

cv::Mat Gray8(const cv::Mat& image) {
  cv::Mat buffer;
  return Gray8Into(image, &buffer);
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
  double cos_angle = 0;
  Eigen::Vector3d x;
  const bool ok = MidpointCos(oa, da, ob, db, &x, &cos_angle);
  if (angle_rad) *angle_rad = std::acos(std::clamp(cos_angle, -1.0, 1.0));
  if (ok) *point = x;
  return ok;
}

double WarpedNcc(const cv::Mat& gray_a, const Eigen::Vector2d& p, const cv::Mat& gray_b, const Eigen::Vector2d& q,
                 const Eigen::Matrix2d& jacobian, int h, double* stddev_a, double* stddev_b) {
  if (h < 0 || h > kMaxHalfWindow) return -2.0;
  return WindowNcc(WindowA(gray_a, p, h), WindowWarp(jacobian, h), gray_b, q, stddev_a, stddev_b);
}

double WarpedNccPortable(const cv::Mat& gray_a, const Eigen::Vector2d& p, const cv::Mat& gray_b,
                         const Eigen::Vector2d& q, const Eigen::Matrix2d& jacobian, int h, double* stddev_a,
                         double* stddev_b) {
  if (h < 0 || h > kMaxHalfWindow) return -2.0;
  return WindowNcc(WindowA(gray_a, p, h), WindowWarp(jacobian, h), gray_b, q, stddev_a, stddev_b, kSearchPortable);
}

bool DensePairViewsUsable(const DenseView& a, const DenseView& b) {
  auto gray_fits = [](const cv::Mat& gray, const cv::Mat& image, int type) {
    return gray.empty() || (gray.type() == type && gray.size() == image.size());
  };
  for (const DenseView* v : {&a, &b})
    if (!gray_fits(v->gray, v->image, CV_32FC1) || !gray_fits(v->gray8, v->image, CV_8UC1)) return false;
  return !a.image.empty() && !b.image.empty() && a.image.type() == b.image.type() && a.camera.IsValid() &&
         b.camera.IsValid() && a.image.cols == a.camera.width && a.image.rows == a.camera.height &&
         b.image.cols == b.camera.width && b.image.rows == b.camera.height &&
         !((a.world_from_camera.translation() - b.world_from_camera.translation()).norm() < 1e-9);
}

cv::Rect DensePairRoi(const PinholeCamera& camera_a, const Eigen::Isometry3d& world_from_a,
                      const AffineDenseOptions& o) {
  const cv::Rect image_rect(0, 0, camera_a.width, camera_a.height);
  cv::Rect roi = o.roi_a.area() > 0 ? (o.roi_a & image_rect) : image_rect;
  if (o.region.valid) roi &= o.region.ImageRect(camera_a, world_from_a, o.region_image_margin_px);
  return roi;
}

std::vector<DensePoint> ComputeDensePair(const DenseView& a, const DenseView& b, const std::vector<PointMatch>& matches,
                                         const AffineDenseOptions& o, DensePairStats* stats_out) {
  std::vector<DensePoint> out;
  ComputeDensePair(a, b, matches, o, &out, stats_out);
  return out;
}

namespace {

// ComputeDensePair's steps. Frames: world, A and B = the cameras of views a and b (x right, y down, z forward);
// lengths in the poses' unit (mm); pixels (px) of A or B with (0, 0) at the first pixel's centre.

// The pair's features: the matches (a in A, b in B, px) finite and inside both images, without those closer than
// min_feature_separation_px in A or in B to an earlier kept one (order kept, deterministic).
std::vector<PointMatch> PairFeatures(const DenseView& a, const DenseView& b, const std::vector<PointMatch>& matches,
                                     const AffineDenseOptions& o) {
  std::vector<PointMatch> feats;
  feats.reserve(matches.size());
  const double sep2 = o.min_feature_separation_px * o.min_feature_separation_px;
  // A match is a duplicate when an earlier kept one lies closer than the separation in A or in B (looked up in
  // grids of both images instead of comparing with every earlier match).
  ImagePointGrid grid_a(a.camera.width, a.camera.height, o.min_feature_separation_px);
  ImagePointGrid grid_b(b.camera.width, b.camera.height, o.min_feature_separation_px);
  for (const PointMatch& m : matches) {
    if (!m.a.allFinite() || !m.b.allFinite()) continue;
    if (!a.camera.InImage(m.a) || !b.camera.InImage(m.b)) continue;
    if (sep2 > 0) {  // else no squared distance is below it
      const bool dup = grid_a.AnyNear(m.a, [&](int i) { return (feats[i].a - m.a).squaredNorm() < sep2; }) ||
                       grid_b.AnyNear(m.b, [&](int i) { return (feats[i].b - m.b).squaredNorm() < sep2; });
      if (dup) continue;
      grid_a.Insert(m.a, static_cast<int>(feats.size()));
      grid_b.Insert(m.b, static_cast<int>(feats.size()));
    }
    feats.push_back(m);
  }
  return feats;
}

// The pair's relative geometry, computed once per pair.
struct PairGeometry {
  Eigen::Vector3d center_a, center_b;  // the cameras' centres in world (mm)
  Eigen::Matrix3d rwa, rwb;            // rotations world_from_A, world_from_B
  Eigen::Isometry3d b_from_a, a_from_world, b_from_world;
  Eigen::Matrix3d essential;    // normalized point of A (x, y, 1) -> its epipolar line in B's normalized coordinates
  Eigen::Matrix3d fundamental;  // pixel of A (u, v, 1) -> its epipolar line in B's pixels
  double min_angle;             // rad, the vertices' least triangulation angle

  PairGeometry(const DenseView& a, const DenseView& b, const AffineDenseOptions& o)
      : center_a(a.world_from_camera.translation()),
        center_b(b.world_from_camera.translation()),
        rwa(a.world_from_camera.linear()),
        rwb(b.world_from_camera.linear()),
        b_from_a(b.world_from_camera.inverse() * a.world_from_camera),
        a_from_world(a.world_from_camera.inverse()),
        b_from_world(b.world_from_camera.inverse()),
        essential(EssentialMatrix(a.world_from_camera, b.world_from_camera)),
        fundamental(b.camera.K().inverse().transpose() * essential * a.camera.K().inverse()),
        min_angle(o.min_triangulation_angle_deg * kDegToRad) {}
};

// The features' vertices, for the depth-edge test and the plane mapping: (*vertex_in_a)[i] = feature i's ray
// midpoint in A (mm) with (*vertex_ok)[i] = 1 when it triangulates with at least g.min_angle in front of A; both
// sized feats.size() by the caller (entries not ok are left as they are).
void TriangulateVertices(const std::vector<PointMatch>& feats, const DenseView& a, const DenseView& b,
                         const PairGeometry& g, std::vector<Eigen::Vector3d>* vertex_in_a,
                         std::vector<char>* vertex_ok) {
  for (size_t i = 0; i < feats.size(); ++i) {
    const Eigen::Vector3d da = (g.rwa * a.camera.Unproject(feats[i].a).homogeneous()).normalized();
    const Eigen::Vector3d db = (g.rwb * b.camera.Unproject(feats[i].b).homogeneous()).normalized();
    Eigen::Vector3d x;
    double angle = 0;
    if (TriangulateMidpoint(g.center_a, da, g.center_b, db, &x, &angle) && angle >= g.min_angle) {
      (*vertex_in_a)[i] = g.a_from_world * x;
      (*vertex_ok)[i] = (*vertex_in_a)[i].z() > 0;
    }
  }
}

// Delaunay triangulation of the features' pixels in A (as float px) over image_a's rectangle: *tri_list in
// Subdiv2D's order (including triangles on its virtual outer vertices), *index_of = exact float position -> the
// first feature there (the features at a position already taken are not inserted).
void DelaunayInA(const std::vector<PointMatch>& feats, const cv::Mat& image_a,
                 std::unordered_map<uint64_t, int>* index_of, std::vector<cv::Vec6f>* tri_list) {
  cv::Subdiv2D subdiv(cv::Rect(-2, -2, image_a.cols + 4, image_a.rows + 4));
  index_of->reserve(2 * feats.size());
  for (size_t i = 0; i < feats.size(); ++i) {
    const cv::Point2f pt(static_cast<float>(feats[i].a.x()), static_cast<float>(feats[i].a.y()));
    if (!index_of->emplace(FloatPairKey(pt.x, pt.y), static_cast<int>(i)).second) continue;
    subdiv.insert(pt);
  }
  subdiv.getTriangleList(*tri_list);
}

// One Delaunay triangle of the features.
struct PairTriangle {
  int idx[3];                  // the corners' feature indices
  Eigen::Vector2d a0, a1, a2;  // the corners in A (px)
  Eigen::Vector2d b0, b1, b2;  // their matches in B (px)
};

// The features at t's corners into *tri; false for a triangle touching Subdiv2D's virtual outer vertices.
bool ResolveTriangle(const cv::Vec6f& t, const std::unordered_map<uint64_t, int>& index_of,
                     const std::vector<PointMatch>& feats, PairTriangle* tri) {
  for (int k = 0; k < 3; ++k) {
    auto it = index_of.find(FloatPairKey(t[2 * k], t[2 * k + 1]));
    if (it == index_of.end()) return false;
    tri->idx[k] = it->second;
  }
  tri->a0 = feats[tri->idx[0]].a, tri->a1 = feats[tri->idx[1]].a, tri->a2 = feats[tri->idx[2]].a;
  tri->b0 = feats[tri->idx[0]].b, tri->b1 = feats[tri->idx[1]].b, tri->b2 = feats[tri->idx[2]].b;
  return true;
}

// What the triangles' and pixels' steps read, fixed for the pair.
struct PairInputs {
  const DenseView& a;
  const DenseView& b;
  const AffineDenseOptions& o;
  const PairGeometry& g;
  const std::vector<Eigen::Vector3d>& vertex_in_a;  // see TriangulateVertices
  const std::vector<char>& vertex_ok;
  const cv::Rect& roi;    // the pixels of A visited (DensePairRoi)
  const cv::Mat& gray_a;  // CV_32F gray of A and B (0-255)
  const cv::Mat& gray_b;
  const PairTriangulator& triangulator;
  const std::vector<int>& near_steps;  // the search's steps (see SetSearchSteps)
  const std::vector<int>& far_steps;
  int n_steps;      // steps each side of the prediction (refine_step_px each)
  int first_steps;  // steps each side searched first
  int h;            // ncc_half_window (px)
  int channels;     // of a.image
};

// What they update.
struct PairState {
  cv::Mat1b& visited;           // pixels of A already handled by an earlier triangle
  WindowA& window_a;            // A's NCC window of the current pixel
  std::vector<double>& scores;  // the search's scores, index step + n_steps
  SearchScratch& search;
  std::vector<DensePoint>& points;  // the accepted points
  DensePairStats& stats;
  double refine_shift_sum;  // px, |q_refined - q| summed over refine_count pixels
  int64_t refine_count;
};

// The epipolar search's steps, the same for every pixel (in refine_step_px, relative to the prediction's foot on the
// line): *n_steps each side (0 without refinement), those within *first_steps into scratch->near_steps (-first to
// +first), the others into scratch->far_steps (-s, s by increasing s); scratch->scores sized 2·n_steps + 1.
void SetSearchSteps(const AffineDenseOptions& o, PairScratch* scratch, int* n_steps_out, int* first_steps_out) {
  const int n_steps = o.refine_along_epipolar ? static_cast<int>(std::floor(o.refine_search_px / o.refine_step_px)) : 0;
  const int first_steps =
      o.refine_first_steps > 0 ? std::min(n_steps, o.refine_first_steps) : n_steps;  // 0: every step at once
  std::vector<int>& near_steps = scratch->near_steps;
  std::vector<int>& far_steps = scratch->far_steps;
  near_steps.clear(), far_steps.clear();
  for (int s = -first_steps; s <= first_steps; ++s) near_steps.push_back(s);
  for (int s = first_steps + 1; s <= n_steps; ++s) far_steps.push_back(-s), far_steps.push_back(s);
  scratch->scores.assign(2 * n_steps + 1, -2.0);
  *n_steps_out = n_steps;
  *first_steps_out = first_steps;
}

// The triangle's checks before any pixel work, each rejection counted in *stats (but for missing the ROI): shape in
// A and B (area px², orientation, edges px, angles deg), the vertices' depths in A (triangulated, ratio, slant) and
// the region (outside, on the floor). When accepted sets *strict (an edge over strict_triangle_edge_px) and
// *junction (joins the floor to the object): stricter photometric checks for its pixels.
bool TriangleAccepted(const PairInputs& in, const PairTriangle& tri, DensePairStats* stats, bool* strict,
                      bool* junction) {
  const AffineDenseOptions& o = in.o;
  const cv::Rect& roi = in.roi;
  const std::vector<Eigen::Vector3d>& vertex_in_a = in.vertex_in_a;
  const int* idx = tri.idx;
  const Eigen::Vector2d &a0 = tri.a0, &a1 = tri.a1, &a2 = tri.a2;
  const Eigen::Vector2d &b0 = tri.b0, &b1 = tri.b1, &b2 = tri.b2;
  const double area_a = 0.5 * Cross2(a1 - a0, a2 - a0);
  const double area_b = 0.5 * Cross2(b1 - b0, b2 - b0);
  const double max_edge = std::max(
      {(a1 - a0).norm(), (a2 - a1).norm(), (a0 - a2).norm(), (b1 - b0).norm(), (b2 - b1).norm(), (b0 - b2).norm()});
  if (std::abs(area_a) < o.min_triangle_area_px2 || area_a * area_b <= 0 || max_edge > o.max_triangle_edge_px ||
      SmallestAngleBelow(a0, a1, a2, o.min_triangle_angle_deg)) {
    ++stats->triangles_skipped_shape;
    return false;
  }
  if (!in.vertex_ok[idx[0]] || !in.vertex_ok[idx[1]] || !in.vertex_ok[idx[2]]) {
    ++stats->triangles_skipped_depth;
    return false;
  }
  const double z0 = vertex_in_a[idx[0]].z(), z1 = vertex_in_a[idx[1]].z(), z2 = vertex_in_a[idx[2]].z();
  if (std::max({z0, z1, z2}) > o.max_vertex_depth_ratio * std::min({z0, z1, z2})) {
    ++stats->triangles_skipped_depth;
    return false;
  }
  *strict = max_edge > o.strict_triangle_edge_px;
  *junction = false;
  if (o.region.valid) {
    const Eigen::Vector3d w0 = in.a.world_from_camera * vertex_in_a[idx[0]],
                          w1 = in.a.world_from_camera * vertex_in_a[idx[1]],
                          w2 = in.a.world_from_camera * vertex_in_a[idx[2]];
    if (o.region.TriangleOutside(w0, w1, w2, o.region_slack_mm) ||
        (o.skip_floor_triangles && o.region.TriangleOnFloor(w0, w1, w2))) {
      ++stats->triangles_skipped_region;
      return false;
    }
    *junction = o.region.TriangleSpansFloorJunction(w0, w1, w2);
  }
  // Cheap reject before any pixel work: the triangle's bounding box misses the ROI rectangle.
  if (std::max({a0.x(), a1.x(), a2.x()}) < roi.x || std::min({a0.x(), a1.x(), a2.x()}) > roi.x + roi.width - 1 ||
      std::max({a0.y(), a1.y(), a2.y()}) < roi.y || std::min({a0.y(), a1.y(), a2.y()}) > roi.y + roi.height - 1)
    return false;
  {
    const Eigen::Vector3d& v0 = vertex_in_a[idx[0]];
    const Eigen::Vector3d normal = (vertex_in_a[idx[1]] - v0).cross(vertex_in_a[idx[2]] - v0);
    const Eigen::Vector3d centroid = (v0 + vertex_in_a[idx[1]] + vertex_in_a[idx[2]]) / 3.0;
    const double nn = normal.norm() * centroid.norm();
    if (!(nn > 0) || std::abs(normal.dot(centroid)) < std::cos(o.max_triangle_slant_deg * kDegToRad) * nn) {
      ++stats->triangles_skipped_depth;
      return false;
    }
  }
  return true;
}

// A triangle's prediction of B from A.
struct TrianglePrediction {
  Eigen::Matrix3d tinv;           // pixel of A (u, v, 1) -> barycentric coordinates (α, β, γ)
  Eigen::Matrix<double, 2, 3> m;  // the affine map: pixel of A (u, v, 1) -> predicted pixel of B
  Eigen::Vector3d plane_n;        // the vertices' plane in A: plane_n · X = plane_d (X in A, mm; plane_n unnormalized)
  double plane_d;
  int u_lo, u_hi, v_lo, v_hi;  // the triangle's bounding box of pixels of A within the ROI (inclusive)
  bool strict, junction;       // see TriangleAccepted
};

// The affine map of the triangle's corners A -> B, the plane of its vertices in A and its pixel box in the ROI.
TrianglePrediction PredictTriangle(const PairInputs& in, const PairTriangle& tri, bool strict, bool junction) {
  const cv::Rect& roi = in.roi;
  const std::vector<Eigen::Vector3d>& vertex_in_a = in.vertex_in_a;
  const int* idx = tri.idx;
  const Eigen::Vector2d &a0 = tri.a0, &a1 = tri.a1, &a2 = tri.a2;
  const Eigen::Vector2d &b0 = tri.b0, &b1 = tri.b1, &b2 = tri.b2;
  // Barycentric coordinates: (α, β, γ) = tinv * (u, v, 1); affine map Q = m * (u, v, 1).
  Eigen::Matrix3d tmat;
  tmat << a0.x(), a1.x(), a2.x(), a0.y(), a1.y(), a2.y(), 1, 1, 1;
  const Eigen::Matrix3d tinv = tmat.inverse();
  Eigen::Matrix<double, 2, 3> bmat;
  bmat << b0.x(), b1.x(), b2.x(), b0.y(), b1.y(), b2.y();
  const Eigen::Matrix<double, 2, 3> m = bmat * tinv;
  const Eigen::Vector3d x0 = vertex_in_a[idx[0]];
  const Eigen::Vector3d plane_n = (vertex_in_a[idx[1]] - x0).cross(vertex_in_a[idx[2]] - x0);
  const double plane_d = plane_n.dot(x0);

  const int u_lo = std::max(roi.x, static_cast<int>(std::ceil(std::min({a0.x(), a1.x(), a2.x()}))));
  const int u_hi = std::min(roi.x + roi.width - 1, static_cast<int>(std::floor(std::max({a0.x(), a1.x(), a2.x()}))));
  const int v_lo = std::max(roi.y, static_cast<int>(std::ceil(std::min({a0.y(), a1.y(), a2.y()}))));
  const int v_hi = std::min(roi.y + roi.height - 1, static_cast<int>(std::floor(std::max({a0.y(), a1.y(), a2.y()}))));
  return {tinv, m, plane_n, plane_d, u_lo, u_hi, v_lo, v_hi, strict, junction};
}

// The first best score of scores[lo, hi].
int BestIn(const std::vector<double>& scores, int lo, int hi) {
  int best = lo;
  for (int k = lo + 1; k <= hi; ++k)
    if (scores[k] > scores[best]) best = k;
  return best;
}

// Pixel (u, v) of A (na: its normalized point) predicted in B into *q (px): through the vertices' plane (plane
// mapping) or the affine map. False when the plane misses the ray, B cannot project the point or q's NCC window
// (h + 1) leaves B.
bool PredictInB(const PairInputs& in, const TrianglePrediction& tri, int u, int v, const Eigen::Vector2d& na,
                Eigen::Vector2d* q) {
  if (in.o.mapping == static_cast<int>(DenseMapping::kPlane)) {
    const Eigen::Vector3d ray = na.homogeneous();
    const double denom = tri.plane_n.dot(ray);
    if (std::abs(denom) < 1e-12 * tri.plane_n.norm()) return false;
    if (!in.b.camera.Project(in.g.b_from_a * (ray * (tri.plane_d / denom)), q)) return false;
  } else {
    *q = tri.m * Eigen::Vector3d(u, v, 1);
  }
  return Inside(in.b.image, *q, in.h + 1);
}

// Refines *q (px in B, p = (u, v) in A) along p's epipolar line in B: the NCC of A's window around p (set into
// s->window_a) warped by the triangle's affine map at refine_step_px steps about q's foot on the line (the near
// steps first, the far ones only when needed), the best step refined by a parabola to within ±0.5 step. False
// when rejected (counted: the best at the search's border, or the refined q's window leaving B); else *q is the
// refined pixel and |shift| (px) is added to s's sums.
bool RefineAlongEpipolar(const PairInputs& in, const WindowWarp& warp, int u, int v, const Eigen::Vector2d& p,
                         Eigen::Vector2d* q_io, PairState* s) {
  const AffineDenseOptions& o = in.o;
  DensePairStats& stats = s->stats;
  std::vector<double>& scores = s->scores;
  const int n_steps = in.n_steps, first_steps = in.first_steps;
  const std::vector<int>& near_steps = in.near_steps;
  const std::vector<int>& far_steps = in.far_steps;
  const Eigen::Vector2d q = *q_io;
  s->window_a.Set(in.gray_a, p, in.h);
  const Eigen::Vector3d l = in.g.fundamental * Eigen::Vector3d(u, v, 1);
  const double ln = std::hypot(l.x(), l.y());
  const Eigen::Vector2d dir(-l.y() / ln, l.x() / ln);
  const Eigen::Vector2d q0 = q - (l.dot(q.homogeneous()) / ln) * Eigen::Vector2d(l.x() / ln, l.y() / ln);
  // The steps within first_steps of the prediction first; the rest only when their best is at their edge
  // (the peak may lie farther out) or under refine_first_min_ncc (a weak peak: a better one may lie farther
  // out). Steps not scored stay at -2 (never the best, never a neighbour).
  ++stats.refine_searches;
  if (far_steps.empty()) ++stats.refine_full_searches;  // every step at once
  std::fill(scores.begin(), scores.end(), -2.0);
  SearchScores(s->window_a, warp, in.gray_b, q0, dir, o.refine_step_px, n_steps, near_steps.data(),
               static_cast<int>(near_steps.size()), o.refine_kernel, &s->search, scores.data());
  int best = BestIn(scores, n_steps - first_steps, n_steps + first_steps);
  if (!far_steps.empty() &&
      (best == n_steps - first_steps || best == n_steps + first_steps || scores[best] < o.refine_first_min_ncc)) {
    ++stats.refine_full_searches;
    SearchScores(s->window_a, warp, in.gray_b, q0, dir, o.refine_step_px, n_steps, far_steps.data(),
                 static_cast<int>(far_steps.size()), o.refine_kernel, &s->search, scores.data());
    best = BestIn(scores, 0, 2 * n_steps);
  }
  if (o.reject_refine_at_border && (best == 0 || best == 2 * n_steps)) {
    ++stats.rejected_refine_border;  // the best match lies beyond the search: the affine map is off here
    return false;
  }
  double offset = 0;
  if (best > 0 && best < 2 * n_steps) {
    const double l0 = scores[best - 1], c0 = scores[best], r0 = scores[best + 1];
    const double den = l0 - 2 * c0 + r0;
    if (den < 0 && l0 > -2 && r0 > -2) offset = std::clamp(0.5 * (l0 - r0) / den, -0.5, 0.5);
  }
  const Eigen::Vector2d qr = q0 + ((best - n_steps + offset) * o.refine_step_px) * dir;
  if (!Inside(in.b.image, qr, in.h + 1)) {
    ++stats.rejected_outside;
    return false;
  }
  s->refine_shift_sum += (qr - q).norm();
  ++s->refine_count;
  *q_io = qr;
  return true;
}

// Whether A's colour at (u, v) and B's bilinear colour at q (px) agree: mean absolute difference over B, G, R
// (0-255; a gray image's value stands for all three) not over max_color_difference.
bool ColorAgrees(const PairInputs& in, int u, int v, const Eigen::Vector2d& q) {
  double cb[3];
  SampleBgr(in.b.image, q.x(), q.y(), cb);
  const uint8_t* pa = in.a.image.ptr<uint8_t>(v) + u * in.channels;
  double diff = 0;
  for (int k = 0; k < 3; ++k) diff += std::abs(pa[in.channels == 3 ? k : 0] - cb[k]);
  return !(diff / 3.0 > in.o.max_color_difference);
}

// The NCC checks of p (px in A; na its normalized point) against q (px in B) with the triangle's affine window
// (h > 0): min_ncc where both windows are textured, the junction limits on strict or junction triangles, and the
// floor hypothesis on junction triangles. Sets s->window_a unless window_a_set; a rejection is counted.
bool NccAccepted(const PairInputs& in, const TrianglePrediction& tri, const WindowWarp& warp, const Eigen::Vector2d& p,
                 const Eigen::Vector2d& na, const Eigen::Vector2d& q, bool window_a_set, PairState* s) {
  const AffineDenseOptions& o = in.o;
  DensePairStats& stats = s->stats;
  const bool junction = tri.junction, strict = tri.strict;
  double sd_a = 0, sd_b = 0;
  if (!window_a_set) s->window_a.Set(in.gray_a, p, in.h);
  const double ncc = WindowNcc(s->window_a, warp, in.gray_b, q, &sd_a, &sd_b, o.refine_kernel);
  if (ncc < -1.5 || (sd_a >= o.min_window_stddev && sd_b >= o.min_window_stddev && ncc < o.min_ncc)) {
    ++stats.rejected_ncc;
    return false;
  }
  if ((junction || strict) && o.junction_min_window_stddev >= 0 &&
      (sd_a < o.junction_min_window_stddev || sd_b < o.junction_min_window_stddev || ncc < o.junction_min_ncc)) {
    ++stats.rejected_ncc;
    return false;
  }
  // The floor hypothesis: the ray of P meets the floor plane at X_f, seen in B at q_f. In the crevice between
  // the floor and the object, the triangle's plane puts P in the air in front of the shadowed floor that P
  // really sees; when the floor explains the match about as well (q_f near q, or an NCC at q_f nearly as
  // high), P is ambiguous and dropped.
  if (junction && o.junction_floor_ncc_margin >= 0) {
    const Eigen::Vector3d ray = (in.g.rwa * na.homogeneous()).normalized();
    const double along = o.region.floor.normal.dot(ray);
    if (along < -1e-9) {
      const Eigen::Vector3d& center_a = in.g.center_a;
      const Eigen::Vector3d x_floor = center_a - (o.region.HeightAboveFloor(center_a) / along) * ray;
      Eigen::Vector2d q_floor;
      if (in.b.camera.Project(in.g.b_from_world * x_floor, &q_floor) &&
          ((q_floor - q).norm() < o.junction_floor_min_separation_px ||
           (Inside(in.b.image, q_floor, in.h + 1) &&
            WindowNcc(s->window_a, warp, in.gray_b, q_floor, nullptr, nullptr, o.refine_kernel) >=
                ncc - o.junction_floor_ncc_margin))) {
        ++stats.rejected_floor_ambiguous;
        return false;
      }
    }
  }
  return true;
}

// Pixel (u, v) of A: its prediction q in B, the epipolar check, the refinement along the epipolar line, the colour
// and NCC checks, then its triangulation; an accepted point (with A's colour) is appended to s->points, a rejection
// counted in s->stats.
void MatchPixel(const PairInputs& in, const TrianglePrediction& tri, const WindowWarp& warp, int u, int v,
                PairState* s) {
  const AffineDenseOptions& o = in.o;
  DensePairStats& stats = s->stats;
  const Eigen::Vector2d p(u, v);
  bool window_a_set = false;
  const Eigen::Vector2d na = in.a.camera.Unproject(p);
  Eigen::Vector2d q;
  if (!PredictInB(in, tri, u, v, na, &q)) {
    ++stats.rejected_outside;
    return;
  }
  const Eigen::Vector3d nb_line = in.g.essential * na.homogeneous();
  const Eigen::Vector2d nb = in.b.camera.Unproject(q);  // of the unrefined q
  bool q_refined = false;
  if (EpipolarFar(nb_line, std::abs(nb_line.dot(nb.homogeneous())), in.b.camera.fx, o.epipolar_threshold_px)) {
    ++stats.rejected_epipolar;
    return;
  }
  if (o.refine_along_epipolar) {
    if (!RefineAlongEpipolar(in, warp, u, v, p, &q, s)) return;
    window_a_set = true;
    q_refined = true;
  }
  if (o.max_color_difference >= 0 && !ColorAgrees(in, u, v, q)) {
    ++stats.rejected_color;
    return;
  }
  if (in.h > 0 && !NccAccepted(in, tri, warp, p, na, q, window_a_set, s)) return;
  DensePoint dp;
  const PairTriangulator::Result result =
      in.triangulator.Triangulate(p, na, q, q_refined ? in.b.camera.Unproject(q) : nb, &dp);
  if (result == PairTriangulator::kRejectedTriangulation) {
    ++stats.rejected_triangulation;
    return;
  }
  if (result == PairTriangulator::kRejectedBox) {
    ++stats.rejected_box;
    return;
  }
  const uint8_t* pa = in.a.image.ptr<uint8_t>(v) + u * in.channels;
  for (int k = 0; k < 3; ++k) dp.bgr[k] = pa[in.channels == 3 ? k : 0];
  s->points.push_back(dp);
  ++stats.accepted;
}

// The triangle's pixels of A (every pixel_step-th of its box, raster order) not handled by an earlier triangle,
// each counted in stats.pixels and matched (MatchPixel) with the triangle's affine NCC window.
void MatchTrianglePixels(const PairInputs& in, const TrianglePrediction& tri, PairState* s) {
  const Eigen::Matrix2d jac = tri.m.leftCols<2>();
  const WindowWarp warp(jac, in.h);
  const int step = in.o.pixel_step;
  for (int v = tri.v_lo + (step - tri.v_lo % step) % step; v <= tri.v_hi; v += step) {
    for (int u = tri.u_lo + (step - tri.u_lo % step) % step; u <= tri.u_hi; u += step) {
      const Eigen::Vector3d bary = tri.tinv * Eigen::Vector3d(u, v, 1);
      if (bary.minCoeff() < -1e-9) continue;
      uint8_t& seen = s->visited(v, u);
      if (seen) continue;
      seen = 1;
      ++s->stats.pixels;
      MatchPixel(in, tri, warp, u, v, s);
    }
  }
}

}  // namespace

void ComputeDensePair(const DenseView& a, const DenseView& b, const std::vector<PointMatch>& matches,
                      const AffineDenseOptions& o, std::vector<DensePoint>* out, DensePairStats* stats_out) {
  DensePairStats stats;
  out->clear();
  auto finish = [&]() {
    if (stats_out) *stats_out = stats;
  };
  if (!DensePairViewsUsable(a, b) || !ValidateAffineDenseOptions(o, nullptr)) return finish();

  // Features: inside both images, finite, deduplicated (order kept, deterministic).
  const std::vector<PointMatch> feats = PairFeatures(a, b, matches, o);
  stats.features = static_cast<int>(feats.size());
  if (feats.size() < 3) return finish();
  const PairGeometry geometry(a, b, o);

  // Triangulate the vertices (depth in A for the depth-edge test, points for the plane mapping).
  std::vector<Eigen::Vector3d> vertex_in_a(feats.size());
  std::vector<char> vertex_ok(feats.size(), 0);
  TriangulateVertices(feats, a, b, geometry, &vertex_in_a, &vertex_ok);

  // Delaunay triangulation of the features in A.
  std::unordered_map<uint64_t, int> index_of;  // exact float position -> first feature there
  std::vector<cv::Vec6f> tri_list;
  DelaunayInA(feats, a.image, &index_of, &tri_list);

  thread_local PairScratch scratch;
  const cv::Mat& gray_a = GrayFloatOf(a, &scratch.gray8, &scratch.gray_a);
  const cv::Mat& gray_b = GrayFloatOf(b, &scratch.gray8, &scratch.gray_b);
  cv::Mat1b& visited = scratch.visited;
  visited.create(a.image.rows, a.image.cols);
  visited.setTo(0);
  const PairTriangulator triangulator(a.camera, a.world_from_camera, b.camera, b.world_from_camera, o);
  int n_steps = 0, first_steps = 0;
  SetSearchSteps(o, &scratch, &n_steps, &first_steps);
  WindowA window_a;
  const cv::Rect roi = DensePairRoi(a.camera, a.world_from_camera, o);
  if (roi.area() <= 0) return finish();
  const PairInputs in{a,
                      b,
                      o,
                      geometry,
                      vertex_in_a,
                      vertex_ok,
                      roi,
                      gray_a,
                      gray_b,
                      triangulator,
                      scratch.near_steps,
                      scratch.far_steps,
                      n_steps,
                      first_steps,
                      o.ncc_half_window,
                      a.image.channels()};
  PairState state{visited, window_a, scratch.scores, scratch.search, *out, stats, 0, 0};

  // Each triangle: its checks, its affine prediction, then its pixels' search, checks and triangulation.
  for (const cv::Vec6f& t : tri_list) {
    PairTriangle tri;
    if (!ResolveTriangle(t, index_of, feats, &tri)) continue;  // a triangle touching Subdiv2D's virtual vertices
    ++stats.triangles;
    bool strict = false, junction = false;
    if (!TriangleAccepted(in, tri, &stats, &strict, &junction)) continue;
    MatchTrianglePixels(in, PredictTriangle(in, tri, strict, junction), &state);
  }
  if (state.refine_count > 0) stats.mean_refine_shift_px = state.refine_shift_sum / state.refine_count;
  // Triangles come from Subdiv2D in its own order; sort output into raster order of the source pixel is not
  // needed for determinism (Subdiv2D is deterministic for the same input), so keep the order as produced.
  return finish();
}

std::vector<DenseMatch> DenseMatchesOf(const std::vector<DensePoint>& points) {
  std::vector<DenseMatch> matches;
  matches.reserve(points.size());
  for (const DensePoint& p : points) matches.push_back({p.pixel_a, p.pixel_b, p.bgr});
  return matches;
}

std::vector<DensePoint> TriangulateDenseMatches(const PinholeCamera& cam_a, const Eigen::Isometry3d& world_from_a,
                                                const PinholeCamera& cam_b, const Eigen::Isometry3d& world_from_b,
                                                const std::vector<DenseMatch>& matches, const AffineDenseOptions& o,
                                                int64_t* rejected) {
  std::vector<DensePoint> points;
  if (rejected) *rejected = static_cast<int64_t>(matches.size());
  if (!cam_a.IsValid() || !cam_b.IsValid() || (world_from_a.translation() - world_from_b.translation()).norm() < 1e-9)
    return points;
  const PairTriangulator triangulator(cam_a, world_from_a, cam_b, world_from_b, o);
  const Eigen::Matrix3d essential = EssentialMatrix(world_from_a, world_from_b);
  points.reserve(matches.size());
  for (const DenseMatch& m : matches) {
    const Eigen::Vector2d p = m.pixel_a.cast<double>(), q = m.pixel_b.cast<double>();
    const Eigen::Vector2d na = cam_a.Unproject(p), nb = cam_b.Unproject(q);
    const Eigen::Vector3d nb_line = essential * na.homogeneous();
    if (EpipolarFar(nb_line, std::abs(nb_line.dot(nb.homogeneous())), cam_b.fx, o.epipolar_threshold_px)) continue;
    DensePoint dp;
    if (triangulator.Triangulate(p, na, q, nb, &dp) != PairTriangulator::kAccepted) continue;
    dp.bgr = m.bgr;
    points.push_back(dp);
  }
  if (rejected) *rejected = static_cast<int64_t>(matches.size() - points.size());
  return points;
}

}  // namespace objscan
