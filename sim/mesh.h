// Triangle meshes for the synthetic scenes: textured primitives (box, cylinder, frustum),
// composition, bounds, and PLY export (BOP models: millimetres, vertex colours).
//
// Conventions: model frame in metres, triangles counter-clockwise seen from outside (the
// rasterizer culls back faces), uv in texture units (1 = one copy of the texture; values
// outside [0, 1] repeat).
//
// Thread safety: Mesh is a value; const access from several threads is safe. Textures are
// shared immutable images (std::shared_ptr<const cv::Mat>).
#ifndef SKIMAP_SIM_MESH_H_
#define SKIMAP_SIM_MESH_H_

#include <Eigen/Geometry>
#include <array>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"

namespace skimap::sim {

// An immutable CV_8UC3 (BGR) image used as a texture.
using Texture = std::shared_ptr<const cv::Mat>;

// A one-pixel texture of a flat BGR colour.
Texture FlatTexture(uint8_t b, uint8_t g, uint8_t r);

// Triangle mesh with per-vertex uv and one texture per triangle.
struct Mesh {
  std::vector<Eigen::Vector3f> positions;     // metres
  std::vector<Eigen::Vector2f> uvs;           // one per position
  std::vector<std::array<int, 3>> triangles;  // indices into positions, CCW from outside
  std::vector<int> tri_texture;               // index into textures, one per triangle
  std::vector<Texture> textures;

  // Appends `other` transformed by T (positions only; T must be rigid or scaling).
  void Append(const Mesh& other, const Eigen::Affine3f& T = Eigen::Affine3f::Identity());
  // Axis-aligned bounds of the positions. REQUIRES: non-empty.
  Eigen::AlignedBox3f Bounds() const;
  // Largest distance between two vertices (metres); O(n^2), meant for object-sized meshes.
  float Diameter() const;
};

// Box of extent `size` centred at the origin; each face shows `uv_tiles` copies of `tex`.
Mesh MakeBox(const Eigen::Vector3f& size, Texture tex, float uv_tiles = 1);

// A printed box (a package): each of the six faces shows a different part of `tex` (the
// cells of a 3 x 2 grid over it), so that no two faces look alike, as on real packaging.
// (MakeBox's faces all show the same picture: a box that looks the same from front and
// back, whose orientation no view can tell.)
Mesh MakePrintedBox(const Eigen::Vector3f& size, Texture tex);

// Closed frustum (cylinder when r0 == r1) around the z axis from z0 to z1 with `segments`
// sides. The side wraps `side` once around; caps use `cap` (nullptr: no cap).
Mesh MakeFrustum(float r0, float r1, float z0, float z1, int segments, Texture side, Texture cap);

// Writes the mesh as an ASCII PLY in millimetres with per-vertex colour sampled from the
// textures (vertices are split per triangle so colours stay per face). kInternal on I/O error.
[[nodiscard]] absl::Status WritePlyMm(const Mesh& mesh, const std::string& path);

// Writes the mesh as a Wavefront OBJ in metres with its textures: `path` (.obj), the .mtl
// beside it (same stem) and one PNG per texture (stem_texN.png), what a textured CAD or
// scan export looks like. uv v is flipped (OBJ's origin is the image's bottom left).
// kInternal on I/O error.
[[nodiscard]] absl::Status WriteObj(const Mesh& mesh, const std::string& path);

// Samples `tex` at uv (repeat wrap, nearest). REQUIRES: tex non-empty.
inline const cv::Vec3b& SampleTexture(const cv::Mat& tex, float u, float v) {
  int x = static_cast<int>((u - std::floor(u)) * tex.cols);
  int y = static_cast<int>((v - std::floor(v)) * tex.rows);
  x = x >= tex.cols ? tex.cols - 1 : x;
  y = y >= tex.rows ? tex.rows - 1 : y;
  return tex.at<cv::Vec3b>(y, x);
}

}  // namespace skimap::sim

#endif  // SKIMAP_SIM_MESH_H_
