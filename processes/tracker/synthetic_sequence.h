// Test/benchmark helper (not part of the library): a richly textured plane seen through known affine motions.
// The texture (seeded noise blurred at several scales) lives on a 2x supersampled grid; frame k is
// warpAffine(texture, A_k) with INTER_LINEAR at 2x resolution, then area-downsampled by 2 and quantised to 8 bit
// (optionally with Gaussian sensor noise). Ground truth: a texture point t (supersampled px) is seen in frame k at
// pixel u = (A_k t - 0.5) / 2, because output pixel u averages supersampled pixels 2u and 2u+1 (centre 2u + 0.5).
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace objscan {
namespace testing_support {

class SyntheticSequence {
 public:
  // width x height output frames; margin_px: texture extends this far beyond the frame on each side (frame px).
  SyntheticSequence(int width, int height, int margin_px, uint64_t seed) : width_(width), height_(height) {
    const int tw = 2 * (width + 2 * margin_px), th = 2 * (height + 2 * margin_px);
    offset_ = 2.0 * margin_px;
    cv::RNG rng(seed);
    cv::Mat sum = cv::Mat::zeros(th, tw, CV_32F);
    const double sigmas[] = {2.0, 5.0, 12.0};
    const double weights[] = {1.0, 1.2, 1.6};
    for (int i = 0; i < 3; ++i) {
      cv::Mat noise(th, tw, CV_32F), blurred;
      rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
      cv::GaussianBlur(noise, blurred, cv::Size(0, 0), sigmas[i], sigmas[i], cv::BORDER_REFLECT_101);
      cv::Scalar mean, stddev;
      cv::meanStdDev(blurred, mean, stddev);
      sum += (blurred - mean[0]) * (weights[i] / stddev[0]);
    }
    cv::Scalar mean, stddev;
    cv::meanStdDev(sum, mean, stddev);
    texture_ = (sum - mean[0]) * (40.0 / stddev[0]) + 128.0;  // mean 128, std 40 gray levels
  }

  // Affine map texture(super px) -> frame(super px) for a frame shifted by (tx, ty) frame px, rotated by angle rad
  // and scaled by scale about the frame centre. (tx, ty) = (0, 0), angle 0, scale 1 shows the texture centre.
  cv::Matx23d Motion(double tx, double ty, double angle, double scale) const {
    const double c = std::cos(angle) * scale, s = std::sin(angle) * scale;
    const double cx = width_, cy = height_;  // frame centre in super px
    // frame_super = R * (t - offset - centre) + centre + 2 * (tx, ty)
    const double ox = offset_ + cx, oy = offset_ + cy;
    return cv::Matx23d(c, -s, -(c * ox - s * oy) + cx + 2 * tx, s, c, -(s * ox + c * oy) + cy + 2 * ty);
  }

  // Renders a frame (CV_8UC1) under motion A with Gaussian sensor noise of noise_sigma gray levels.
  cv::Mat Render(const cv::Matx23d& A, double noise_sigma = 0.0, uint64_t noise_seed = 1) const {
    cv::Mat super, small;
    cv::warpAffine(texture_, super, cv::Mat(A), cv::Size(2 * width_, 2 * height_), cv::INTER_LINEAR,
                   cv::BORDER_REFLECT_101);
    cv::resize(super, small, cv::Size(width_, height_), 0, 0, cv::INTER_AREA);
    if (noise_sigma > 0) {
      cv::Mat noise(small.size(), CV_32F);
      cv::RNG rng(noise_seed);
      rng.fill(noise, cv::RNG::NORMAL, 0.0, noise_sigma);
      small += noise;
    }
    cv::Mat out;
    small.convertTo(out, CV_8U);  // rounds and saturates
    return out;
  }

  // Texture point (super px) seen at frame pixel u under motion A, and back.
  static cv::Point2d TexturePoint(const cv::Matx23d& A, const cv::Point2d& u) {
    cv::Matx23d inv;
    cv::invertAffineTransform(A, inv);
    const cv::Point2d s(2 * u.x + 0.5, 2 * u.y + 0.5);
    return {inv(0, 0) * s.x + inv(0, 1) * s.y + inv(0, 2), inv(1, 0) * s.x + inv(1, 1) * s.y + inv(1, 2)};
  }
  static cv::Point2d FramePoint(const cv::Matx23d& A, const cv::Point2d& t) {
    const cv::Point2d s(A(0, 0) * t.x + A(0, 1) * t.y + A(0, 2), A(1, 0) * t.x + A(1, 1) * t.y + A(1, 2));
    return {(s.x - 0.5) / 2, (s.y - 0.5) / 2};
  }

  int width() const { return width_; }
  int height() const { return height_; }

 private:
  int width_, height_;
  double offset_;
  cv::Mat texture_;  // CV_32F, supersampled
};

}  // namespace testing_support
}  // namespace objscan
