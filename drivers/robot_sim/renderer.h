// Deterministic CPU renderer of a robot_sim Scene (no GPU / GL): every object is tessellated into triangles that are
// clipped at the near plane, rasterized with a z-buffer on 1/z (pixel centres at integer (u, v)), then each visible
// pixel is shaded once: perspective-correct texture coordinates and Gouraud-interpolated Lambert shading (directional
// light + ambient, per vertex), mip level chosen from the pixel footprint (|d(uv)/du|, |d(uv)/dv| in texels) with
// bilinear filtering inside the level (or trilinear between levels), plus additive Gaussian sensor noise drawn from
// a precomputed table at a per-frame offset (deterministic for noise_seed and the frame key).
// Outputs the image, the depth along the optical axis and the object id behind every pixel.
// Lens distortion is not rendered (the simulated camera is an ideal pinhole). Not thread-safe (scratch buffers).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "common/camera_model.h"
#include "drivers/robot_sim/scene.h"

namespace objscan {

struct RenderOptions {
  double noise_sigma = 2.0;  // grey levels (0..255), std of the additive Gaussian noise per channel; 0 = none
  uint64_t noise_seed = 1;   // seed of the noise table
  bool trilinear = false;    // blend the two nearest mip levels (slower); false = nearest level, bilinear
  double near_mm = 10.0;     // mm, near clipping plane
};

struct RenderOutput {
  cv::Mat rgb;              // CV_8UC3, BGR order (OpenCV), height x width
  cv::Mat depth_mm;         // CV_32F, mm along the optical axis (camera z) of the surface at the pixel centre; 0 = none
  cv::Mat object_id;        // CV_32S, Scene object index visible at the pixel centre; -1 = background
  int triangles_drawn = 0;  // triangles that reached the rasterizer (after culling / clipping)
};

class Renderer {
 public:
  // Keeps a reference to the scene: it must outlive the renderer. Builds the noise table (throws
  // std::invalid_argument for a negative noise sigma or near plane <= 0).
  Renderer(const Scene& scene, const RenderOptions& options = {});

  // Renders the view of a camera at world_from_camera (mm; camera frame x right, y down, z forward). The camera must
  // be valid (camera.IsValid()); distortion coefficients are ignored. frame_key selects the noise pattern
  // (same key -> same image). Throws std::invalid_argument for an invalid camera.
  void Render(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera, RenderOutput* out,
              uint64_t frame_key = 0);

  const RenderOptions& options() const { return options_; }
  const Scene& scene() const { return scene_; }

 private:
  struct Vertex {
    Eigen::Vector3d position;  // world
    float u, v;                // texels
    float shade;               // Lambert factor (ambient + diffuse * max(0, n.l))
  };
  struct Triangle {
    int v[3];
    int object;
    bool cull;
  };
  struct Setup {  // screen-space planes a*x + b*y + c of q = 1/z, u*q, v*q, shade*q
    float q[3], u[3], v[3], s[3];
    int object;
    int max_level;                 // last mip level of the object's texture
    const Texture::Level* levels;  // the object's mip chain
  };

  // Culls a triangle (camera-frame vertices in camera_points_, mm) behind the near plane, outside a frustum side plane
  // (side_planes: inside = dot >= 0), back-facing or edge-on; otherwise fills its screen-space setup and the plane of
  // q = 1/z (1/mm) in double precision (qp) and returns true.
  bool SetUpTriangle(const Triangle& tri, const PinholeCamera& camera, const Eigen::Vector3d side_planes[4],
                     Setup* setup, double qp[3]) const;
  // Clips a triangle at the near plane, projects it to pixels and z-buffers its fan into qbuffer_ / setup_index_
  // (tagged setup_id) using the q plane qp; returns whether any pixel was won.
  bool RasterizeTriangle(const Triangle& tri, const PinholeCamera& camera, const double qp[3], int setup_id);
  // Shades every pixel of a width x height image once from setup_index_ / setups_ (texture, Lambert shade, sensor
  // noise of frame_key) into out's rgb, depth_mm (mm along camera z) and object_id.
  void ShadePixels(int width, int height, uint64_t frame_key, RenderOutput* out) const;

  const Scene& scene_;
  RenderOptions options_;
  std::vector<Vertex> vertices_;
  std::vector<Triangle> triangles_;
  std::vector<const Texture*> textures_;  // per object
  std::vector<float> noise_table_;        // N(0,1) samples, power-of-two size
  // scratch
  std::vector<Eigen::Vector3d> camera_points_;
  std::vector<Setup> setups_;
  std::vector<float> qbuffer_;
  std::vector<int32_t> setup_index_;
};

// The 3-D surface point behind pixel (u, v) (any real pixel position), from the rendered depth: bilinear
// interpolation of 1/depth over the 4 neighbouring pixel centres (exact for planar surfaces), back-projected with the
// pinhole model and mapped to the world. Returns false outside the image, on background, where the four pixels do
// not all show the same object, or across a depth edge (neighbour depths differing by more than 5 % or 20 mm).
bool SurfacePointAt(const RenderOutput& render, const PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera,
                    double u, double v, Eigen::Vector3d* point_in_world);

}  // namespace objscan
