#include "processes/tracker/klt_tracker.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <opencv2/imgproc.hpp>

namespace objscan {
namespace {

// Buckets of side `cell` px for "is there a point within radius" queries (radius <= cell).
class PointBuckets {
 public:
  // Radii up to `cell` can be queried; cells are at least 8 px so that tiny radii do not allocate huge grids.
  PointBuckets(cv::Size size, double cell) : cell_(std::max(cell, 8.0)) {
    cols_ = std::max(1, static_cast<int>(std::ceil(size.width / cell_)) + 1);
    rows_ = std::max(1, static_cast<int>(std::ceil(size.height / cell_)) + 1);
    buckets_.resize(static_cast<size_t>(cols_) * static_cast<size_t>(rows_));
  }
  bool AnyWithin(const cv::Point2f& p, double radius) const {
    const int bx = Col(p.x), by = Row(p.y);
    const double r2 = radius * radius;
    for (int y = std::max(0, by - 1); y <= std::min(rows_ - 1, by + 1); ++y) {
      for (int x = std::max(0, bx - 1); x <= std::min(cols_ - 1, bx + 1); ++x) {
        for (const cv::Point2f& q : buckets_[static_cast<size_t>(y * cols_ + x)]) {
          const double dx = q.x - p.x, dy = q.y - p.y;
          if (dx * dx + dy * dy < r2) return true;
        }
      }
    }
    return false;
  }
  void Insert(const cv::Point2f& p) { buckets_[static_cast<size_t>(Row(p.y) * cols_ + Col(p.x))].push_back(p); }

 private:
  int Col(float x) const { return std::clamp(static_cast<int>(std::floor(x / cell_)), 0, cols_ - 1); }
  int Row(float y) const { return std::clamp(static_cast<int>(std::floor(y / cell_)), 0, rows_ - 1); }
  double cell_;
  int cols_ = 1, rows_ = 1;
  std::vector<std::vector<cv::Point2f>> buckets_;
};

// Per detection, the response reference keeps this fraction of its previous value (if no stronger corner is seen).
constexpr double kResponseReferenceDecay = 0.95;

struct Candidate {
  float response;
  int x, y;
};

}  // namespace

// Reference template of a track: the (2h+1)^2 pixels of its anchor frame around the anchor position p0, on that
// frame's integer pixel grid (no resampling). Template pixel (c, r) lies at y = origin + (c, r) relative to p0.
// Everything the alignment needs from the template alone is computed here once per anchor (inverse-compositional
// formulation), so that an alignment iteration only samples the image and accumulates nine sums.
struct KltTracker::Anchor {
  int side = 0;        // 2h + 1
  cv::Point2f origin;  // px, template pixel (0, 0) relative to the anchor position
  cv::Point2f centre;  // px, template pixel (h, h) relative to the anchor position (|.| <= 0.5)
  float mean = 0.0f;   // gray levels, mean of the template pixels
  // Three planes of side * side floats in one block (about 2.7 kB for h = 7: a frame's 1000 templates are read from
  // memory once per frame, so their size matters as much as the arithmetic): the gray levels minus their mean, and
  // the template's x and y gradients. The steepest-descent images grad(T) * dW/dp are products of these with the
  // pixel positions, formed in the sums of the alignment.
  std::vector<float> planes;
  const float* value() const { return planes.data(); }
  const float* gx() const { return planes.data() + side * side; }
  const float* gy() const { return planes.data() + 2 * side * side; }
  double sd_sum[6] = {0, 0, 0, 0, 0, 0};    // per steepest-descent image (see AlignToAnchor): sum of its pixels
  double sd_value[6] = {0, 0, 0, 0, 0, 0};  // per steepest-descent image: sum of its pixels times value
  double value_ss = 0.0;                    // sum of value^2
  Eigen::Matrix<double, 6, 6> inv_hessian;  // inverse of sum sd^T sd
  double rms = 0.0;                         // gray levels, RMS of value (the template's contrast)
};

namespace {

// Anchor template of `gray` around p (px) with half side h; null when it is too flat or its affine Hessian is
// singular (e.g. a straight edge), so that the alignment would be ill-posed. Pixels outside the image are clamped.
std::shared_ptr<const KltTracker::Anchor> MakeAnchor(const cv::Mat& gray, const cv::Point2f& p, int h) {
  auto a = std::make_shared<KltTracker::Anchor>();
  a->side = 2 * h + 1;
  const int c0 = static_cast<int>(std::lround(p.x)) - h, r0 = static_cast<int>(std::lround(p.y)) - h;
  a->origin = cv::Point2f(static_cast<float>(c0) - p.x, static_cast<float>(r0) - p.y);
  a->centre = a->origin + cv::Point2f(static_cast<float>(h), static_cast<float>(h));
  const int s = a->side, n = s * s;
  auto at = [&gray](int r, int c) {
    return static_cast<float>(gray.at<uchar>(std::clamp(r, 0, gray.rows - 1), std::clamp(c, 0, gray.cols - 1)));
  };
  a->planes.resize(static_cast<size_t>(3 * n));
  float* value = a->planes.data();
  float* gxs = value + n;
  float* gys = value + 2 * n;
  std::vector<float> sd(static_cast<size_t>(6 * n));
  double sum = 0.0;
  Eigen::Matrix<double, 6, 6> hessian = Eigen::Matrix<double, 6, 6>::Zero();
  for (int r = 0; r < s; ++r) {
    for (int c = 0; c < s; ++c) {
      const int k = r * s + c;
      const float v = at(r0 + r, c0 + c);
      value[k] = v;
      sum += v;
      const float gx = 0.5f * (at(r0 + r, c0 + c + 1) - at(r0 + r, c0 + c - 1));
      const float gy = 0.5f * (at(r0 + r + 1, c0 + c) - at(r0 + r - 1, c0 + c));
      gxs[k] = gx;
      gys[k] = gy;
      const float yx = a->origin.x + static_cast<float>(c), yy = a->origin.y + static_cast<float>(r);
      const float d[6] = {gx * yx, gx * yy, gy * yx, gy * yy, gx, gy};
      for (int j = 0; j < 6; ++j) sd[static_cast<size_t>(j * n + k)] = d[j];
      Eigen::Matrix<double, 6, 1> dv;
      dv << d[0], d[1], d[2], d[3], d[4], d[5];
      hessian.selfadjointView<Eigen::Lower>().rankUpdate(dv);
    }
  }
  hessian = hessian.selfadjointView<Eigen::Lower>();
  const float mean = static_cast<float>(sum / n);
  a->mean = mean;
  double ss = 0.0;
  for (int k = 0; k < n; ++k) {
    float& v = value[k];
    v -= mean;
    ss += static_cast<double>(v) * v;
    for (int j = 0; j < 6; ++j) {
      const double d = sd[static_cast<size_t>(j * n + k)];
      a->sd_sum[j] += d;
      a->sd_value[j] += d * v;
    }
  }
  a->value_ss = ss;
  a->rms = std::sqrt(ss / n);
  // Flat patches and (near-)singular systems cannot be aligned: translation block min eigenvalue per pixel below
  // 1 gray level^2 per px^2, or a failing Cholesky factorisation.
  const double txx = hessian(4, 4) / n, tyy = hessian(5, 5) / n, txy = hessian(4, 5) / n;
  const double min_eig = 0.5 * (txx + tyy - std::sqrt((txx - tyy) * (txx - tyy) + 4 * txy * txy));
  if (!(a->rms > 1.0) || !(min_eig > 1.0)) return nullptr;
  Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(hessian);
  if (llt.info() != Eigen::Success) return nullptr;
  a->inv_hessian = llt.solve(Eigen::Matrix<double, 6, 6>::Identity());
  return a;
}

// Result of aligning an anchor template to an image.
enum class AlignResult { kOk, kOutside, kFlat, kNoConvergence };

// Scratch space of AlignToAnchor (per template pixel).
struct AlignScratch {
  int side = 0;                  // template side the grid below is for
  std::vector<float> cc, rr;     // template pixel column and row relative to the centre pixel (-h..h)
  std::vector<float> fx, fy;     // bilinear fractions
  std::vector<int> offset;       // byte offset of the top-left neighbour in the image
  std::vector<int> top, bottom;  // neighbour pairs: left + 256 * right, in the top and bottom row
  void Resize(int s) {
    if (s == side) return;
    side = s;
    const size_t n = static_cast<size_t>(s) * static_cast<size_t>(s);
    for (std::vector<float>* v : {&cc, &rr, &fx, &fy}) v->resize(n);
    for (std::vector<int>* v : {&offset, &top, &bottom}) v->resize(n);
    const int h = s / 2;
    for (int r = 0; r < s; ++r) {
      for (int c = 0; c < s; ++c) {
        cc[static_cast<size_t>(r * s + c)] = static_cast<float>(c - h);
        rr[static_cast<size_t>(r * s + c)] = static_cast<float>(r - h);
      }
    }
  }
};

// Number of independent partial sums per accumulated quantity: the sums are split over this many lanes (fixed
// order, so the result is deterministic) so that the compiler can vectorise them without reassociating.
constexpr int kLanes = 8;

// Inputs of one alignment iteration's sums (see AlignSums).
struct AlignSumsInput {
  const uchar* image;        // gray image, 8 bit
  int step;                  // bytes per image row
  const float* value;        // template gray levels minus their mean
  const float* gx;           // template x gradient
  const float* gy;           // template y gradient
  float mean;                // template mean
  float bx, by;              // px, warped position of the template's centre pixel
  float a00, a01, a10, a11;  // linear part of the warp
  int n;                     // template pixels
};

// Samples the warped template (bilinear; every pixel's 2x2 neighbourhood must lie inside the image) and returns in
// t[] the sums of w, w^2, w * value, g = w * gx, g * cc, g * rr, h = w * gy, h * cc, h * rr, with w the warped
// patch minus the template's mean and (cc, rr) the pixel's position relative to the centre pixel. Inlined into a
// portable and an AVX2 variant: the sums are split over kLanes fixed lanes and no operation is fused or reordered,
// so both variants give bit-identical results.
inline __attribute__((always_inline)) void AlignSumsBody(const AlignSumsInput& in, AlignScratch* scratch, double t[9]) {
  const int n = in.n;
  float* fx = scratch->fx.data();
  float* fy = scratch->fy.data();
  int* offset = scratch->offset.data();
  int* pair0 = scratch->top.data();
  int* pair1 = scratch->bottom.data();
  const float* cc = scratch->cc.data();
  const float* rr = scratch->rr.data();
  const float* value = in.value;
  const float* tgx = in.gx;
  const float* tgy = in.gy;
  const float bx = in.bx, by = in.by, a00 = in.a00, a01 = in.a01, a10 = in.a10, a11 = in.a11;
  const int istep = in.step;
  // Three passes so that all but the gathering of the neighbours vectorise.
  for (int k = 0; k < n; ++k) {
    const float zx = bx + a00 * cc[k] + a01 * rr[k], zy = by + a10 * cc[k] + a11 * rr[k];
    const int x0 = static_cast<int>(zx), y0 = static_cast<int>(zy);  // zx, zy >= 0: truncation is floor
    fx[k] = zx - static_cast<float>(x0);
    fy[k] = zy - static_cast<float>(y0);
    offset[k] = y0 * istep + x0;
  }
  for (int k = 0; k < n; ++k) {
    const uchar* q = in.image + offset[k];
    pair0[k] = q[0] | (q[1] << 8);  // compilers merge each pair into one 16-bit load
    pair1[k] = q[istep] | (q[istep + 1] << 8);
  }
  const float mean = in.mean;
  auto sample = [&](int k) {
    const float v00 = static_cast<float>(pair0[k] & 255), v01 = static_cast<float>(pair0[k] >> 8);
    const float v10 = static_cast<float>(pair1[k] & 255), v11 = static_cast<float>(pair1[k] >> 8);
    const float top = v00 + fx[k] * (v01 - v00);
    const float bottom = v10 + fx[k] * (v11 - v10);
    return top + fy[k] * (bottom - top) - mean;
  };
  float acc[9][kLanes] = {};
  auto accumulate = [&](int k, int l) {
    const float x = sample(k);
    const float g = x * tgx[k], h = x * tgy[k];
    acc[0][l] += x;
    acc[1][l] += x * x;
    acc[2][l] += x * value[k];
    acc[3][l] += g;
    acc[4][l] += g * cc[k];
    acc[5][l] += g * rr[k];
    acc[6][l] += h;
    acc[7][l] += h * cc[k];
    acc[8][l] += h * rr[k];
  };
  const int n_main = n - n % kLanes;
  for (int k0 = 0; k0 < n_main; k0 += kLanes) {
    for (int l = 0; l < kLanes; ++l) accumulate(k0 + l, l);
  }
  for (int k = n_main; k < n; ++k) accumulate(k, 0);
  for (int q = 0; q < 9; ++q) {
    double u = 0.0;
    for (int l = 0; l < kLanes; ++l) u += acc[q][l];
    t[q] = u;
  }
}

void AlignSumsPortable(const AlignSumsInput& in, AlignScratch* scratch, double t[9]) { AlignSumsBody(in, scratch, t); }

#if defined(__x86_64__) && defined(__GNUC__)
// The same code compiled for AVX2 (8-float vectors; FMA is not enabled, so nothing is contracted or reordered and
// the results are bit-identical). Explicit AVX2 gathers of the neighbours were measured slower here (AMD EPYC) than
// the scalar 16-bit loads of the second pass.
__attribute__((target("avx2"))) void AlignSumsAvx2(const AlignSumsInput& in, AlignScratch* scratch, double t[9]) {
  AlignSumsBody(in, scratch, t);
}
bool CpuHasAvx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}
#else
void AlignSumsAvx2(const AlignSumsInput& in, AlignScratch* scratch, double t[9]) { AlignSumsBody(in, scratch, t); }
bool CpuHasAvx2() { return false; }
#endif

// Inverse-compositional Lucas-Kanade (Baker and Matthews, 2004) of the anchor template to `gray` with the warp
// W(y) = *p + *affine * y (y relative to the anchor position) and a gain/bias compensation (the warped patch is
// normalised to the template's mean and RMS contrast). *p and *affine are the start and the result; *rel_residual is
// the RMS residual (at the last iterate before the final update) divided by the template's RMS contrast;
// *iterations is incremented once per iteration.
AlignResult AlignToAnchor(const KltTracker::Anchor& a, const cv::Mat& gray, int max_iterations, double epsilon,
                          bool use_avx2, cv::Point2f* p, cv::Matx22f* affine, double* rel_residual, int* iterations,
                          AlignScratch* scratch) {
  const int s = a.side, n = s * s;
  scratch->Resize(s);
  // A margin keeps every template pixel's left/top neighbour strictly inside despite rounding.
  const float max_x = static_cast<float>(gray.cols - 1) - 0.01f, max_y = static_cast<float>(gray.rows - 1) - 0.01f;
  const size_t step = gray.step[0];
  const float e2 = static_cast<float>(epsilon * epsilon);
  const cv::Point2f corners[4] = {a.origin, a.origin + cv::Point2f(static_cast<float>(s - 1), 0.0f),
                                  a.origin + cv::Point2f(0.0f, static_cast<float>(s - 1)),
                                  a.origin + cv::Point2f(static_cast<float>(s - 1), static_cast<float>(s - 1))};
  const float* value = a.value();
  const float* tgx = a.gx();
  const float* tgy = a.gy();
  const float dx = a.centre.x, dy = a.centre.y;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    ++*iterations;
    const cv::Matx22f& A = *affine;
    // The warp is affine, so the template lies inside the image when its corners do.
    for (const cv::Point2f& y : corners) {
      const float zx = p->x + A(0, 0) * y.x + A(0, 1) * y.y, zy = p->y + A(1, 0) * y.x + A(1, 1) * y.y;
      if (!(zx >= 0.0f && zy >= 0.0f && zx < max_x && zy < max_y)) return AlignResult::kOutside;
    }
    // Warped patch and its sums. Pixel positions relative to the centre pixel: W(y) = b + A (cc, rr) with
    // b = p + A * centre.
    const float a00 = A(0, 0), a01 = A(0, 1), a10 = A(1, 0), a11 = A(1, 1);
    const AlignSumsInput in{gray.data,
                            static_cast<int>(step),
                            value,
                            tgx,
                            tgy,
                            a.mean,
                            p->x + a00 * dx + a01 * dy,
                            p->y + a10 * dx + a11 * dy,
                            a00,
                            a01,
                            a10,
                            a11,
                            n};
    double t[9];
    if (use_avx2) {
      AlignSumsAvx2(in, scratch, t);
    } else {
      AlignSumsPortable(in, scratch, t);
    }
    // The six steepest-descent images are gx * yx, gx * yy, gy * yx, gy * yy, gx, gy with y = centre + (cc, rr),
    // so their sums with w follow from t[]. The residual e = gain * (w - m) - value then follows in closed form from
    // these and the anchor's precomputed sums.
    const double sums[9] = {t[0], t[1], t[2], t[4] + dx * t[3], t[5] + dy * t[3], t[7] + dx * t[6], t[8] + dy * t[6],
                            t[3], t[6]};
    const double m = sums[0] / n;
    const double ss = std::max(0.0, sums[1] - n * m * m);
    const double rms = std::sqrt(ss / n);
    if (!(rms > 1e-3 * a.rms) || !(rms > 0.1)) return AlignResult::kFlat;
    const double gain = a.rms / rms;
    // sum e^2 = gain^2 ss - 2 gain sum (w - m) value + sum value^2, with gain^2 ss = sum value^2 and sum value = 0.
    const double err2 = std::max(0.0, 2.0 * a.value_ss - 2.0 * gain * sums[2]);
    *rel_residual = std::sqrt(err2 / n) / a.rms;
    double b[6];
    for (int j = 0; j < 6; ++j) b[j] = gain * (sums[3 + j] - m * a.sd_sum[j]) - a.sd_value[j];
    const Eigen::Matrix<double, 6, 1> delta = a.inv_hessian * Eigen::Map<const Eigen::Matrix<double, 6, 1>>(b);
    // W <- W o dW^-1 with dW(y) = (I + dA) y + dt: A' = A (I + dA)^-1, t' = t - A' dt.
    const cv::Matx22f I_plus(static_cast<float>(1.0 + delta(0)), static_cast<float>(delta(1)),
                             static_cast<float>(delta(2)), static_cast<float>(1.0 + delta(3)));
    const float det = I_plus(0, 0) * I_plus(1, 1) - I_plus(0, 1) * I_plus(1, 0);
    if (!(std::abs(det) > 1e-3f)) return AlignResult::kNoConvergence;
    const cv::Matx22f inv(I_plus(1, 1) / det, -I_plus(0, 1) / det, -I_plus(1, 0) / det, I_plus(0, 0) / det);
    const cv::Matx22f A_new = A * inv;
    const cv::Vec2f dt(static_cast<float>(delta(4)), static_cast<float>(delta(5)));
    const cv::Vec2f shift = A_new * dt;
    *p -= cv::Point2f(shift(0), shift(1));
    *affine = A_new;
    // Converged when the update moves no template corner (in the template frame) by more than epsilon.
    float worst = 0.0f;
    for (const cv::Point2f& y : corners) {
      const float ux = static_cast<float>(delta(0)) * y.x + static_cast<float>(delta(1)) * y.y + dt(0);
      const float uy = static_cast<float>(delta(2)) * y.x + static_cast<float>(delta(3)) * y.y + dt(1);
      worst = std::max(worst, ux * ux + uy * uy);
    }
    if (!std::isfinite(worst)) return AlignResult::kNoConvergence;
    if (worst <= e2) return AlignResult::kOk;
  }
  return AlignResult::kNoConvergence;
}

// ---- Pyramidal Lucas-Kanade (translation, inverse compositional) ----
//
// Pyramid levels are float images with a replicated border of `pad` px on every side, so that windows reaching a
// little beyond the image need no per-pixel bounds checks. Level l has the size of cv::pyrDown applied l times;
// a point (u, v) of the base image is (u, v) / 2^l on level l.

// Level l of the LK pyramid of `gray`: levels below `finest` are left empty (never used).
void BuildLkPyramid(const cv::Mat& gray, int levels, int finest, int pad, std::vector<cv::Mat>* pyramid) {
  pyramid->assign(static_cast<size_t>(levels + 1), cv::Mat());
  cv::Mat level = gray, padded;
  for (int l = 0; l <= levels; ++l) {
    if (l > 0) {
      cv::Mat down;
      cv::pyrDown(level, down);
      level = down;
    }
    if (l < finest) continue;
    cv::copyMakeBorder(level, padded, pad, pad, pad, pad, cv::BORDER_REPLICATE);
    padded.convertTo((*pyramid)[static_cast<size_t>(l)], CV_32F);
  }
}

// Scratch buffers of LkLevel.
struct LkScratch {
  std::vector<float> patch;   // (W + 2)^2 template samples (with a one pixel ring for the gradient)
  std::vector<float> tpl;     // W^2 template values
  std::vector<float> gx, gy;  // W^2 template gradients
  std::vector<float> acc;     // per-column partial sums
};

// Bilinear weights of the fractional offsets (ax, ay).
struct Bilinear {
  float w00, w01, w10, w11;
  Bilinear(float ax, float ay)
      : w00((1.0f - ax) * (1.0f - ay)), w01(ax * (1.0f - ay)), w10((1.0f - ax) * ay), w11(ax * ay) {}
};

// One pyramid level of LK for one point: the W x W window (W = 2 half + 1) of `from` around p is the template; *q
// (start and result, level px) is moved until the window of `to` around it matches (inverse compositional: the
// template's gradients and 2x2 Hessian are computed once). Returns false when a window leaves the padded image,
// the gradient matrix is (near) singular (min eigenvalue per pixel < min_eig) or the result is not finite.
// *err: mean absolute difference of the windows at the last iterate (gray levels).
bool LkLevel(const cv::Mat& from, const cv::Mat& to, int pad, int half, const cv::Point2f& p, cv::Point2f* q,
             int max_iterations, float eps2, float min_eig, float* err, LkScratch* s) {
  const int W = 2 * half + 1, P = W + 2, n = W * W;
  const size_t from_step = from.step[0] / sizeof(float), to_step = to.step[0] / sizeof(float);
  // Template with a one pixel ring, top-left sample at p - (half + 1).
  {
    const float x = p.x + static_cast<float>(pad - half - 1), y = p.y + static_cast<float>(pad - half - 1);
    if (!(x >= 0.0f && y >= 0.0f && x < static_cast<float>(from.cols - P) && y < static_cast<float>(from.rows - P)))
      return false;
    const int ix = static_cast<int>(x), iy = static_cast<int>(y);
    const Bilinear b(x - static_cast<float>(ix), y - static_cast<float>(iy));
    s->patch.resize(static_cast<size_t>(P * P));
    for (int r = 0; r < P; ++r) {
      const float* a0 = from.ptr<float>(iy + r) + ix;
      const float* a1 = a0 + from_step;
      float* out = s->patch.data() + r * P;
      for (int c = 0; c < P; ++c) out[c] = b.w00 * a0[c] + b.w01 * a0[c + 1] + b.w10 * a1[c] + b.w11 * a1[c + 1];
    }
  }
  s->tpl.resize(static_cast<size_t>(n));
  s->gx.resize(static_cast<size_t>(n));
  s->gy.resize(static_cast<size_t>(n));
  s->acc.assign(static_cast<size_t>(3 * W), 0.0f);
  float* sxx = s->acc.data();
  float* sxy = sxx + W;
  float* syy = sxy + W;
  for (int r = 0; r < W; ++r) {
    const float* above = s->patch.data() + r * P + 1;
    const float* mid = above + P;
    const float* below = mid + P;
    float* t = s->tpl.data() + r * W;
    float* gx = s->gx.data() + r * W;
    float* gy = s->gy.data() + r * W;
    for (int c = 0; c < W; ++c) {
      t[c] = mid[c];
      gx[c] = 0.5f * (mid[c + 1] - mid[c - 1]);
      gy[c] = 0.5f * (below[c] - above[c]);
      sxx[c] += gx[c] * gx[c];
      sxy[c] += gx[c] * gy[c];
      syy[c] += gy[c] * gy[c];
    }
  }
  float hxx = 0.0f, hxy = 0.0f, hyy = 0.0f;
  for (int c = 0; c < W; ++c) {
    hxx += sxx[c];
    hxy += sxy[c];
    hyy += syy[c];
  }
  const float det = hxx * hyy - hxy * hxy;
  const float eig = 0.5f * (hxx + hyy - std::sqrt((hxx - hyy) * (hxx - hyy) + 4.0f * hxy * hxy)) / n;
  if (!(eig >= min_eig) || !(det > 1e-6f * (hxx + hyy) * (hxx + hyy))) return false;
  const float ixx = hyy / det, ixy = -hxy / det, iyy = hxx / det;
  cv::Point2f d = *q;
  float abs_sum = 0.0f;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    const float x = d.x + static_cast<float>(pad - half), y = d.y + static_cast<float>(pad - half);
    if (!(x >= 0.0f && y >= 0.0f && x < static_cast<float>(to.cols - W - 1) && y < static_cast<float>(to.rows - W - 1)))
      return false;
    const int ix = static_cast<int>(x), iy = static_cast<int>(y);
    const Bilinear b(x - static_cast<float>(ix), y - static_cast<float>(iy));
    std::fill(s->acc.begin(), s->acc.end(), 0.0f);
    float* bx = s->acc.data();
    float* by = bx + W;
    float* ba = by + W;
    for (int r = 0; r < W; ++r) {
      const float* a0 = to.ptr<float>(iy + r) + ix;
      const float* a1 = a0 + to_step;
      const float* t = s->tpl.data() + r * W;
      const float* gx = s->gx.data() + r * W;
      const float* gy = s->gy.data() + r * W;
      for (int c = 0; c < W; ++c) {
        const float e = b.w00 * a0[c] + b.w01 * a0[c + 1] + b.w10 * a1[c] + b.w11 * a1[c + 1] - t[c];
        bx[c] += e * gx[c];
        by[c] += e * gy[c];
        ba[c] += std::abs(e);
      }
    }
    float sx = 0.0f, sy = 0.0f;
    abs_sum = 0.0f;
    for (int c = 0; c < W; ++c) {
      sx += bx[c];
      sy += by[c];
      abs_sum += ba[c];
    }
    // Template update dp = H^-1 sum grad(T) e; the warp x + d composed with the inverse of x + dp: d -= dp.
    const float dx = ixx * sx + ixy * sy, dy = ixy * sx + iyy * sy;
    d.x -= dx;
    d.y -= dy;
    if (!std::isfinite(d.x) || !std::isfinite(d.y)) return false;
    if (dx * dx + dy * dy < eps2) break;
  }
  *q = d;
  *err = abs_sum / static_cast<float>(n);
  return true;
}

}  // namespace

bool ValidateKltTrackerOptions(const KltTrackerOptions& o, std::string* why) {
  std::ostringstream e;
  if (o.max_tracks < 1) e << "max_tracks must be >= 1 (is " << o.max_tracks << "); ";
  if (o.grid_cols < 1 || o.grid_rows < 1) e << "grid_cols and grid_rows must be >= 1; ";
  if (o.max_per_cell < 0) e << "max_per_cell must be >= 0 (0 = automatic); ";
  if (o.border_margin_px < 0) e << "border_margin_px must be >= 0; ";
  if (!(o.min_distance_px >= 0.0) || !std::isfinite(o.min_distance_px)) e << "min_distance_px must be >= 0; ";
  if (!(o.duplicate_distance_px >= 0.0) || !std::isfinite(o.duplicate_distance_px))
    e << "duplicate_distance_px must be >= 0; ";
  if (!(o.quality_level > 0.0 && o.quality_level < 1.0)) e << "quality_level must be in (0, 1); ";
  if (!(o.min_eigenvalue >= 0.0) || !std::isfinite(o.min_eigenvalue)) e << "min_eigenvalue must be >= 0; ";
  if (o.corner_block_size < 3 || o.corner_block_size % 2 == 0 || o.corner_block_size > 31)
    e << "corner_block_size must be odd in [3, 31]; ";
  if (o.subpix_half_window < 0 || o.subpix_half_window > 15) e << "subpix_half_window must be in [0, 15]; ";
  if (o.detect_interval < 1) e << "detect_interval must be >= 1; ";
  if (!(o.min_cell_fill > 0.0 && o.min_cell_fill <= 1.0)) e << "min_cell_fill must be in (0, 1]; ";
  if (o.win_size < 5 || o.win_size % 2 == 0 || o.win_size > 101) e << "win_size must be odd in [5, 101]; ";
  if (o.max_level < 0 || o.max_level > 8) e << "max_level must be in [0, 8]; ";
  if (o.max_iterations < 1) e << "max_iterations must be >= 1; ";
  if (!(o.epsilon > 0.0) || !std::isfinite(o.epsilon)) e << "epsilon must be > 0; ";
  if (!(o.lk_min_eigenvalue >= 0.0) || !std::isfinite(o.lk_min_eigenvalue)) e << "lk_min_eigenvalue must be >= 0; ";
  if (!(o.fb_threshold_px > 0.0) || !std::isfinite(o.fb_threshold_px)) e << "fb_threshold_px must be > 0; ";
  if (!(o.max_patch_error >= 0.0) || !std::isfinite(o.max_patch_error)) e << "max_patch_error must be >= 0; ";
  if (o.coarse_win_size != 0 && (o.coarse_win_size < 5 || o.coarse_win_size % 2 == 0 || o.coarse_win_size > o.win_size))
    e << "coarse_win_size must be 0 or odd in [5, win_size]; ";
  if (o.lk_stop_level < 0 || o.lk_stop_level > o.max_level) e << "lk_stop_level must be in [0, max_level]; ";
  if (o.threads < 1) e << "threads must be >= 1; ";
  if (o.anchor_half_window < 2 || o.anchor_half_window > 25) e << "anchor_half_window must be in [2, 25]; ";
  if (o.anchor_max_iterations < 1) e << "anchor_max_iterations must be >= 1; ";
  if (!(o.anchor_epsilon > 0.0) || !std::isfinite(o.anchor_epsilon)) e << "anchor_epsilon must be > 0; ";
  if (!(o.anchor_max_residual > 0.0 && o.anchor_max_residual <= 2.0)) e << "anchor_max_residual must be in (0, 2]; ";
  if (!(o.anchor_reanchor_residual >= 0.0 && o.anchor_reanchor_residual <= 2.0))
    e << "anchor_reanchor_residual must be in [0, 2] (0 = off); ";
  if (!(o.anchor_max_shift_px > 0.0) || !std::isfinite(o.anchor_max_shift_px)) e << "anchor_max_shift_px must be > 0; ";
  if (!(o.anchor_max_distortion > 1.0) || !std::isfinite(o.anchor_max_distortion))
    e << "anchor_max_distortion must be > 1; ";
  const std::string msg = e.str();
  if (msg.empty()) return true;
  if (why) *why = "invalid tracker options: " + msg.substr(0, msg.size() - 2);
  return false;
}

KltTracker::KltTracker(const KltTrackerOptions& options) : options_(options) {
  std::string why;
  if (!ValidateKltTrackerOptions(options_, &why)) throw std::invalid_argument(why);
  const int cells = options_.grid_cols * options_.grid_rows;
  quota_ = options_.max_per_cell > 0 ? options_.max_per_cell : (options_.max_tracks + cells - 1) / cells;
  finest_level_ = options_.anchor_refine ? options_.lk_stop_level : 0;
  // The border must hold a window with its gradient ring and bilinear neighbour, plus some travel.
  pad_ = std::max(options_.win_size, options_.coarse_win_size) / 2 + 4;
}

void KltTracker::Reset() {
  tracks_.clear();
  prev_pyramid_.clear();
  prev_gray_.release();
  size_ = cv::Size();
  frames_since_reset_ = 0;
  response_reference_ = 0.0;
  median_velocity_ = cv::Point2f();
}

int KltTracker::CellOf(const cv::Point2f& p) const {
  const int cx = std::clamp(static_cast<int>(p.x * options_.grid_cols / size_.width), 0, options_.grid_cols - 1);
  const int cy = std::clamp(static_cast<int>(p.y * options_.grid_rows / size_.height), 0, options_.grid_rows - 1);
  return cy * options_.grid_cols + cx;
}

TrackFrame KltTracker::Track(const ImageFrame& frame) {
  if (frame.image.empty()) throw std::invalid_argument("KltTracker::Track: empty image");
  if (frame.image.type() != CV_8UC1 && frame.image.type() != CV_8UC3)
    throw std::invalid_argument("KltTracker::Track: image must be CV_8UC1 or CV_8UC3");
  cv::setNumThreads(options_.threads);
  stats_ = KltTrackStats();
  const int64 t_start = cv::getTickCount();

  cv::Mat gray;
  if (frame.image.channels() == 3)
    cv::cvtColor(frame.image, gray, cv::COLOR_BGR2GRAY);
  else
    gray = frame.image.clone();

  // Levels above the base: max_level, fewer when a level would get smaller than its LK window.
  int levels = 0;
  for (int l = 1, w = gray.cols, h = gray.rows; l <= options_.max_level; ++l) {
    w = (w + 1) / 2;
    h = (h + 1) / 2;
    const int win = options_.coarse_win_size > 0 ? options_.coarse_win_size : options_.win_size;
    if (w < win || h < win) break;
    levels = l;
  }
  std::vector<cv::Mat> pyramid;
  // This pyramid is the "previous" one of the next frame.
  // The base level is also needed when tracks may be re-anchored at their LK position (anchor_reanchor_residual).
  const int build_from = options_.anchor_reanchor_residual > 0.0 ? 0 : std::min(finest_level_, levels);
  BuildLkPyramid(gray, levels, build_from, pad_, &pyramid);

  const int64 t_pyramid = cv::getTickCount();
  if (gray.size() != size_) {
    stats_.lost = static_cast<int>(tracks_.size());
    stats_.reset = true;
    Reset();
    size_ = gray.size();
  }

  const size_t n_prev = tracks_.size();
  if (n_prev > 0) {
    std::vector<cv::Point2f> prev_pts(n_prev), next_pts;
    for (size_t i = 0; i < n_prev; ++i) prev_pts[i] = tracks_[i].pt;
    // Motion prior: the track's last displacement (new tracks: the median of the last frame).
    std::vector<cv::Point2f> offset(n_prev);
    if (options_.predict_motion)
      for (size_t i = 0; i < n_prev; ++i) offset[i] = tracks_[i].age > 0 ? tracks_[i].velocity : median_velocity_;
    std::vector<uchar> keep;
    TrackAndCheck(prev_pyramid_, pyramid, prev_pts, offset, &next_pts, &keep);
    // Tracks that fail with a non-zero prior get a second chance without it (the camera may have stopped).
    std::vector<size_t> retry;
    for (size_t i = 0; i < n_prev; ++i)
      if (!keep[i] && offset[i] != cv::Point2f()) retry.push_back(i);
    if (!retry.empty()) {
      std::vector<cv::Point2f> retry_pts(retry.size()), retry_next;
      for (size_t k = 0; k < retry.size(); ++k) retry_pts[k] = prev_pts[retry[k]];
      std::vector<uchar> retry_keep;
      TrackAndCheck(prev_pyramid_, pyramid, retry_pts, std::vector<cv::Point2f>(retry.size()), &retry_next,
                    &retry_keep);
      for (size_t k = 0; k < retry.size(); ++k) {
        if (!retry_keep[k]) continue;
        keep[retry[k]] = 1;
        next_pts[retry[k]] = retry_next[k];
      }
    }
    if (options_.anchor_refine) {
      const int64 t_refine = cv::getTickCount();
      RefineToAnchors(gray, prev_pts, pyramid, &next_pts, &keep);
      stats_.refine_ms = static_cast<double>(cv::getTickCount() - t_refine) * 1e3 / cv::getTickFrequency();
    }
    std::vector<LiveTrack> survivors;
    survivors.reserve(n_prev);
    for (size_t i = 0; i < n_prev; ++i) {
      if (!keep[i]) continue;
      survivors.push_back({tracks_[i].id, next_pts[i], tracks_[i].age + 1, next_pts[i] - prev_pts[i],
                           std::move(tracks_[i].anchor), tracks_[i].affine});
    }
    // Median displacement of the continued tracks: the motion prior of tracks born in this frame.
    if (!survivors.empty()) {
      std::vector<float> dx(survivors.size()), dy(survivors.size());
      for (size_t k = 0; k < survivors.size(); ++k) {
        dx[k] = survivors[k].velocity.x;
        dy[k] = survivors[k].velocity.y;
      }
      const auto mid = static_cast<std::ptrdiff_t>(dx.size() / 2);
      std::nth_element(dx.begin(), dx.begin() + mid, dx.end());
      std::nth_element(dy.begin(), dy.begin() + mid, dy.end());
      median_velocity_ = cv::Point2f(dx[static_cast<size_t>(mid)], dy[static_cast<size_t>(mid)]);
    }
    RemoveDuplicates(&survivors);
    stats_.lost = static_cast<int>(n_prev - survivors.size());
    tracks_ = std::move(survivors);
  }

  const int64 t_lk = cv::getTickCount();
  const size_t before = tracks_.size();
  if (frames_since_reset_ % options_.detect_interval == 0 || tracks_.empty()) Detect(gray, &tracks_);
  stats_.born = static_cast<int>(tracks_.size() - before);
  const int64 t_detect = cv::getTickCount();
  const double tick_ms = 1e3 / cv::getTickFrequency();
  stats_.pyramid_ms = static_cast<double>(t_pyramid - t_start) * tick_ms;
  stats_.lk_ms = static_cast<double>(t_lk - t_pyramid) * tick_ms;
  stats_.detect_ms = static_cast<double>(t_detect - t_lk) * tick_ms;

  prev_gray_ = gray;
  prev_pyramid_ = std::move(pyramid);
  levels_ = levels;
  ++frames_;
  ++frames_since_reset_;

  TrackFrame out;
  out.utime = frame.utime;
  out.seq = frame.seq;
  out.camera_name = frame.camera_name;
  out.width = size_.width;
  out.height = size_.height;
  out.features.reserve(tracks_.size());
  for (const LiveTrack& t : tracks_) out.features.push_back({t.id, t.pt.x, t.pt.y, t.age});
  stats_.live = static_cast<int>(out.features.size());
  return out;
}

void KltTracker::TrackAndCheck(const std::vector<cv::Mat>& from_pyramid, const std::vector<cv::Mat>& to_pyramid,
                               const std::vector<cv::Point2f>& pts, const std::vector<cv::Point2f>& offset,
                               std::vector<cv::Point2f>* out, std::vector<uchar>* keep) const {
  const size_t n = pts.size();
  std::vector<cv::Point2f> start(n);
  for (size_t i = 0; i < n; ++i) start[i] = pts[i] + offset[i];
  std::vector<uchar> status;
  std::vector<float> err;
  TrackPoints(from_pyramid, to_pyramid, pts, &start, out, &status, &err);
  const float lo = static_cast<float>(options_.border_margin_px);
  const float hi_u = static_cast<float>(size_.width - 1 - options_.border_margin_px);
  const float hi_v = static_cast<float>(size_.height - 1 - options_.border_margin_px);
  keep->assign(n, 0);
  std::vector<size_t> ok;
  ok.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const cv::Point2f& p = (*out)[i];
    if (options_.max_patch_error > 0.0 && !(err[i] <= options_.max_patch_error)) continue;
    if (status[i] && std::isfinite(p.x) && std::isfinite(p.y) && p.x >= lo && p.y >= lo && p.x <= hi_u && p.y <= hi_v)
      ok.push_back(i);
  }
  if (!options_.forward_backward_check) {
    for (size_t i : ok) (*keep)[i] = 1;
    return;
  }
  if (ok.empty()) return;
  // The backward pass searches like the forward pass did, with the same motion prior reversed (no hint of where
  // home is beyond that).
  std::vector<cv::Point2f> fwd(ok.size()), back_start(ok.size()), back;
  for (size_t k = 0; k < ok.size(); ++k) {
    fwd[k] = (*out)[ok[k]];
    back_start[k] = fwd[k] - offset[ok[k]];
  }
  std::vector<uchar> back_status;
  TrackPoints(to_pyramid, from_pyramid, fwd, &back_start, &back, &back_status, &err);
  const double t2 = options_.fb_threshold_px * options_.fb_threshold_px;
  for (size_t k = 0; k < ok.size(); ++k) {
    const cv::Point2f d = back[k] - pts[ok[k]];
    if (back_status[k] && static_cast<double>(d.x) * d.x + static_cast<double>(d.y) * d.y <= t2) (*keep)[ok[k]] = 1;
  }
}

void KltTracker::TrackPoints(const std::vector<cv::Mat>& from, const std::vector<cv::Mat>& to,
                             const std::vector<cv::Point2f>& pts, const std::vector<cv::Point2f>* initial,
                             std::vector<cv::Point2f>* out, std::vector<uchar>* status, std::vector<float>* err) const {
  const size_t n = pts.size();
  out->resize(n);
  status->assign(n, 0);
  err->assign(n, 0.0f);
  const int finest = std::min(finest_level_, levels_);
  const float eps2 = static_cast<float>(options_.epsilon * options_.epsilon);
  const float min_eig = static_cast<float>(options_.lk_min_eigenvalue);
  const int coarse_win = options_.coarse_win_size > 0 ? options_.coarse_win_size : options_.win_size;
  LkScratch scratch;
  for (size_t i = 0; i < n; ++i) {
    // Coarse to fine: the position found on level l + 1, doubled, starts the search on level l.
    cv::Point2f q = (initial ? (*initial)[i] : pts[i]) * (1.0f / static_cast<float>(1 << levels_));
    bool ok = true;
    float e = 0.0f;
    for (int l = levels_; l >= finest && ok; --l) {
      if (l < levels_) q *= 2.0f;
      const int half = (l == 0 ? options_.win_size : coarse_win) / 2;
      ok = LkLevel(from[static_cast<size_t>(l)], to[static_cast<size_t>(l)], pad_, half,
                   pts[i] * (1.0f / static_cast<float>(1 << l)), &q, options_.max_iterations, eps2, min_eig, &e,
                   &scratch);
    }
    (*out)[i] = q * static_cast<float>(1 << finest);
    (*status)[i] = ok ? 1 : 0;
    (*err)[i] = e;
  }
}

void KltTracker::RefineToAnchors(const cv::Mat& gray, const std::vector<cv::Point2f>& prev_pts,
                                 const std::vector<cv::Mat>& pyramid, std::vector<cv::Point2f>* pts,
                                 std::vector<uchar>* keep) {
  AlignScratch buffer;
  LkScratch lk_scratch;
  const int finest = std::min(finest_level_, levels_);
  const double max_shift2 = options_.anchor_max_shift_px * options_.anchor_max_shift_px;
  const float lo = static_cast<float>(options_.border_margin_px);
  const float hi_u = static_cast<float>(size_.width - 1 - options_.border_margin_px);
  const float hi_v = static_cast<float>(size_.height - 1 - options_.border_margin_px);
  for (size_t i = 0; i < tracks_.size(); ++i) {
    if (!(*keep)[i]) continue;
    LiveTrack& t = tracks_[i];
    if (!t.anchor) continue;  // not refined (cannot happen while anchor_refine stays on)
    cv::Point2f p = (*pts)[i];
    cv::Matx22f affine = t.affine;
    double residual = 0.0;
    ++stats_.anchor_aligned;
    const AlignResult r =
        AlignToAnchor(*t.anchor, gray, options_.anchor_max_iterations, options_.anchor_epsilon,
                      options_.use_avx2 && CpuHasAvx2(), &p, &affine, &residual, &stats_.anchor_iterations, &buffer);
    const cv::Point2f d = p - (*pts)[i];
    if (r == AlignResult::kOk && residual > options_.anchor_max_residual &&
        residual <= options_.anchor_reanchor_residual) {
      // The template no longer matches well but not badly either: keep the LK position and start a new anchor.
      // When LK stopped above the base level, its position is finished on the base level first (base window).
      cv::Point2f q = (*pts)[i];
      float lk_err = 0.0f;
      bool ok = true;
      if (finest > 0) {
        ok = LkLevel(prev_pyramid_[0], pyramid[0], pad_, options_.win_size / 2, prev_pts[i], &q,
                     options_.max_iterations, static_cast<float>(options_.epsilon * options_.epsilon),
                     static_cast<float>(options_.lk_min_eigenvalue), &lk_err, &lk_scratch);
        const cv::Point2f moved = q - (*pts)[i];
        ok = ok && q.x >= lo && q.y >= lo && q.x <= hi_u && q.y <= hi_v &&
             static_cast<double>(moved.x) * moved.x + static_cast<double>(moved.y) * moved.y <= max_shift2;
      }
      std::shared_ptr<const Anchor> anchor = ok ? MakeAnchor(gray, q, options_.anchor_half_window) : nullptr;
      if (anchor) {
        (*pts)[i] = q;
        t.anchor = std::move(anchor);
        t.affine = cv::Matx22f::eye();
        ++stats_.reanchored;
        continue;
      }
    }
    if (r != AlignResult::kOk || !(residual <= options_.anchor_max_residual) ||
        !(static_cast<double>(d.x) * d.x + static_cast<double>(d.y) * d.y <= max_shift2) || p.x < lo || p.y < lo ||
        p.x > hi_u || p.y > hi_v) {
      (*keep)[i] = 0;
      ++stats_.anchor_rejected;
      continue;
    }
    // Scale change since the anchor: the singular values of the affine map.
    const cv::Matx22f& A = affine;
    const double a = A(0, 0), b = A(0, 1), c = A(1, 0), e = A(1, 1);
    const double s1 = a * a + b * b + c * c + e * e, det = a * e - b * c;
    const double disc = std::sqrt(std::max(0.0, s1 * s1 - 4 * det * det));
    const double sigma_max = std::sqrt(0.5 * (s1 + disc)), sigma_min = std::sqrt(std::max(0.0, 0.5 * (s1 - disc)));
    const double limit = options_.anchor_max_distortion;
    if (sigma_max > limit || sigma_min * limit < 1.0) {
      std::shared_ptr<const Anchor> anchor =
          options_.anchor_reanchor ? MakeAnchor(gray, p, options_.anchor_half_window) : nullptr;
      if (!anchor) {
        (*keep)[i] = 0;
        ++stats_.anchor_rejected;
        continue;
      }
      t.anchor = std::move(anchor);
      affine = cv::Matx22f::eye();
      ++stats_.reanchored;
    }
    (*pts)[i] = p;
    t.affine = affine;
  }
}

void KltTracker::RemoveDuplicates(std::vector<LiveTrack>* tracks) const {
  if (options_.duplicate_distance_px <= 0.0 || tracks->size() < 2) return;
  // Older tracks win; among equals the smaller id. Survivors keep ascending id order.
  std::vector<size_t> order(tracks->size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    const LiveTrack& ta = (*tracks)[a];
    const LiveTrack& tb = (*tracks)[b];
    return ta.age != tb.age ? ta.age > tb.age : ta.id < tb.id;
  });
  PointBuckets buckets(size_, options_.duplicate_distance_px);
  std::vector<bool> keep(tracks->size(), false);
  for (size_t i : order) {
    const cv::Point2f& p = (*tracks)[i].pt;
    if (buckets.AnyWithin(p, options_.duplicate_distance_px)) continue;
    buckets.Insert(p);
    keep[i] = true;
  }
  std::vector<LiveTrack> out;
  out.reserve(tracks->size());
  for (size_t i = 0; i < tracks->size(); ++i)
    if (keep[i]) out.push_back((*tracks)[i]);
  *tracks = std::move(out);
}

void KltTracker::Detect(const cv::Mat& gray, std::vector<LiveTrack>* tracks) {
  int total = static_cast<int>(tracks->size());
  if (total >= options_.max_tracks) return;
  const int cells = options_.grid_cols * options_.grid_rows;
  std::vector<int> count(static_cast<size_t>(cells), 0);
  for (const LiveTrack& t : *tracks) ++count[static_cast<size_t>(CellOf(t.pt))];
  const double fill_needed = options_.min_cell_fill * quota_;

  const int m = options_.border_margin_px;
  const cv::Rect inner(m, m, size_.width - 2 * m, size_.height - 2 * m);
  if (inner.width <= 0 || inner.height <= 0) return;

  // Cells whose inner part is non-empty and that are below quota (triggered by one below min_cell_fill).
  std::vector<int> deficient;
  std::vector<cv::Rect> cell_rect(static_cast<size_t>(cells));
  bool triggered = false;
  for (int cy = 0; cy < options_.grid_rows; ++cy) {
    for (int cx = 0; cx < options_.grid_cols; ++cx) {
      const int c = cy * options_.grid_cols + cx;
      // Pixel x belongs to cell floor(x * cols / width): cell cx covers [ceil(cx*W/cols), ceil((cx+1)*W/cols)).
      const int x0 = (cx * size_.width + options_.grid_cols - 1) / options_.grid_cols;
      const int x1 = ((cx + 1) * size_.width + options_.grid_cols - 1) / options_.grid_cols;
      const int y0 = (cy * size_.height + options_.grid_rows - 1) / options_.grid_rows;
      const int y1 = ((cy + 1) * size_.height + options_.grid_rows - 1) / options_.grid_rows;
      const cv::Rect r = cv::Rect(x0, y0, x1 - x0, y1 - y0) & inner;
      cell_rect[static_cast<size_t>(c)] = r;
      if (r.area() <= 0 || count[static_cast<size_t>(c)] >= quota_) continue;
      deficient.push_back(c);
      if (count[static_cast<size_t>(c)] < fill_needed) triggered = true;
    }
  }
  if (deficient.empty() || !triggered) return;
  stats_.detected = true;
  // Emptiest cells first (ties: cell index), so that a small budget goes where tracks are missing most.
  std::stable_sort(deficient.begin(), deficient.end(),
                   [&count](int a, int b) { return count[static_cast<size_t>(a)] < count[static_cast<size_t>(b)]; });

  // Shi-Tomasi candidates of one cell, computed when the cell is first visited: min-eigenvalue response on the cell
  // plus the filter apron (values inside the cell equal those of a full-image computation because the filters read
  // the neighbouring pixels), local maxima (3x3) above the absolute floor, strongest first (ties: row, column).
  const int apron = options_.corner_block_size / 2 + 2;
  const cv::Rect whole(0, 0, size_.width, size_.height);
  const float floor = static_cast<float>(options_.min_eigenvalue);
  cv::Mat eig, dilated;
  response_reference_ *= kResponseReferenceDecay;
  auto compute = [&](int c, std::vector<Candidate>* list) {
    const cv::Rect r = cell_rect[static_cast<size_t>(c)];
    const cv::Rect padded = cv::Rect(r.x - apron, r.y - apron, r.width + 2 * apron, r.height + 2 * apron) & whole;
    cv::cornerMinEigenVal(gray(padded), eig, options_.corner_block_size, 3);
    cv::dilate(eig, dilated, cv::Mat());
    for (int y = r.y; y < r.y + r.height; ++y) {
      const float* e = eig.ptr<float>(y - padded.y);
      const float* d = dilated.ptr<float>(y - padded.y);
      for (int x = r.x; x < r.x + r.width; ++x) {
        const int xi = x - padded.x;
        if (e[xi] > 0.0f && e[xi] >= floor && e[xi] == d[xi]) list->push_back({e[xi], x, y});
      }
    }
    std::sort(list->begin(), list->end(), [](const Candidate& a, const Candidate& b) {
      return std::tie(b.response, a.y, a.x) < std::tie(a.response, b.y, b.x);
    });
    if (!list->empty())
      response_reference_ = std::max(response_reference_, static_cast<double>(list->front().response));
  };
  std::vector<std::vector<Candidate>> candidates(deficient.size());
  std::vector<bool> computed(deficient.size(), false);
  // Right after a reset there is no reference response yet: compute every cell first so that the quality threshold
  // is relative to the strongest corner of the whole frame, as in goodFeaturesToTrack.
  if (frames_since_reset_ == 0) {
    for (size_t k = 0; k < deficient.size(); ++k) {
      compute(deficient[k], &candidates[k]);
      computed[k] = true;
    }
  }

  PointBuckets occupied(size_, options_.min_distance_px);
  for (const LiveTrack& t : *tracks) occupied.Insert(t.pt);
  const bool use_distance = options_.min_distance_px > 0.0;
  const float lo = static_cast<float>(m);
  const float hi_u = static_cast<float>(size_.width - 1 - m);
  const float hi_v = static_cast<float>(size_.height - 1 - m);
  const int h = options_.subpix_half_window;
  const cv::TermCriteria subpix_criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.01);
  std::vector<cv::Point2f> refined(1);
  std::vector<size_t> next(deficient.size(), 0);
  // Water filling: in round `level`, every cell holding fewer than `level` tracks gets one more (if it has a
  // usable corner). Each candidate is refined to subpixel precision before it is accepted, so that the checks
  // (border, cell quota, distance to other tracks) hold for the position actually used.
  const int start_level = count[static_cast<size_t>(deficient.front())] + 1;
  for (int level = start_level; level <= quota_ && total < options_.max_tracks; ++level) {
    for (size_t k = 0; k < deficient.size() && total < options_.max_tracks; ++k) {
      int& n_cell = count[static_cast<size_t>(deficient[k])];
      if (n_cell >= level) continue;
      if (!computed[k]) {
        compute(deficient[k], &candidates[k]);
        computed[k] = true;
      }
      const float threshold =
          static_cast<float>(std::max(options_.quality_level * response_reference_, options_.min_eigenvalue));
      const auto& list = candidates[k];
      while (next[k] < list.size()) {
        const Candidate& c = list[next[k]++];
        if (c.response < threshold) {
          next[k] = list.size();  // sorted: the rest are weaker still
          break;
        }
        cv::Point2f p(static_cast<float>(c.x), static_cast<float>(c.y));
        if (use_distance && occupied.AnyWithin(p, options_.min_distance_px)) continue;
        if (h > 0) {
          refined[0] = p;
          cv::cornerSubPix(gray, refined, cv::Size(h, h), cv::Size(-1, -1), subpix_criteria);
          const cv::Point2f q = refined[0];
          // A refinement that runs off (non-corner structure) keeps the integer maximum.
          if (std::isfinite(q.x) && std::isfinite(q.y) && std::abs(q.x - p.x) <= 1.0f && std::abs(q.y - p.y) <= 1.0f)
            p = q;
          if (p.x < lo || p.y < lo || p.x > hi_u || p.y > hi_v) continue;
          if (use_distance && occupied.AnyWithin(p, options_.min_distance_px)) continue;
        }
        int& n = count[static_cast<size_t>(CellOf(p))];
        if (n >= quota_) continue;
        std::shared_ptr<const Anchor> anchor;
        if (options_.anchor_refine) {
          anchor = MakeAnchor(gray, p, options_.anchor_half_window);
          if (!anchor) continue;  // the position could not be refined later
        }
        occupied.Insert(p);
        tracks->push_back({next_id_++, p, 0, cv::Point2f(), std::move(anchor), cv::Matx22f::eye()});
        ++n;
        ++total;
        break;
      }
    }
  }
}

}  // namespace objscan
