// Mesh primitives and PLY export. See mesh.h for the contract.
#include "sim/mesh.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "absl/strings/str_cat.h"
#include "codec/image_files.h"

namespace skimap::sim {

Texture FlatTexture(uint8_t b, uint8_t g, uint8_t r) {
  return std::make_shared<const cv::Mat>(1, 1, CV_8UC3, cv::Scalar(b, g, r));
}

void Mesh::Append(const Mesh& other, const Eigen::Affine3f& T) {
  const int base = static_cast<int>(positions.size());
  const int tex_base = static_cast<int>(textures.size());
  for (const Eigen::Vector3f& p : other.positions) positions.push_back(T * p);
  uvs.insert(uvs.end(), other.uvs.begin(), other.uvs.end());
  for (const auto& t : other.triangles)
    triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  for (int m : other.tri_texture) tri_texture.push_back(m + tex_base);
  textures.insert(textures.end(), other.textures.begin(), other.textures.end());
}

Eigen::AlignedBox3f Mesh::Bounds() const {
  Eigen::AlignedBox3f b;
  for (const Eigen::Vector3f& p : positions) b.extend(p);
  return b;
}

float Mesh::Diameter() const {
  float best = 0;
  for (size_t i = 0; i < positions.size(); ++i) {
    for (size_t j = i + 1; j < positions.size(); ++j) {
      best = std::max(best, (positions[i] - positions[j]).squaredNorm());
    }
  }
  return std::sqrt(best);
}

namespace {

// Adds quad a,b,c,d (CCW from outside) with uv corners (0,1),(1,1),(1,0),(0,0) * tiles.
void AddQuad(Mesh& m, const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c,
             const Eigen::Vector3f& d, float tu, float tv, int tex) {
  const int i = static_cast<int>(m.positions.size());
  m.positions.insert(m.positions.end(), {a, b, c, d});
  m.uvs.insert(m.uvs.end(), {{0, tv}, {tu, tv}, {tu, 0}, {0, 0}});
  m.triangles.push_back({i, i + 1, i + 2});
  m.triangles.push_back({i, i + 2, i + 3});
  m.tri_texture.insert(m.tri_texture.end(), {tex, tex});
}

}  // namespace

Mesh MakeBox(const Eigen::Vector3f& size, Texture tex, float uv_tiles) {
  Mesh m;
  m.textures.push_back(std::move(tex));
  const Eigen::Vector3f h = size / 2;
  auto P = [&](float sx, float sy, float sz) {
    return Eigen::Vector3f(sx * h.x(), sy * h.y(), sz * h.z());
  };
  const float t = uv_tiles;
  AddQuad(m, P(-1, -1, -1), P(1, -1, -1), P(1, -1, 1), P(-1, -1, 1), t, t, 0);  // -y
  AddQuad(m, P(1, -1, -1), P(1, 1, -1), P(1, 1, 1), P(1, -1, 1), t, t, 0);      // +x
  AddQuad(m, P(1, 1, -1), P(-1, 1, -1), P(-1, 1, 1), P(1, 1, 1), t, t, 0);      // +y
  AddQuad(m, P(-1, 1, -1), P(-1, -1, -1), P(-1, -1, 1), P(-1, 1, 1), t, t, 0);  // -x
  AddQuad(m, P(-1, -1, 1), P(1, -1, 1), P(1, 1, 1), P(-1, 1, 1), t, t, 0);      // +z
  AddQuad(m, P(-1, 1, -1), P(1, 1, -1), P(1, -1, -1), P(-1, -1, -1), t, t, 0);  // -z
  return m;
}

Mesh MakePrintedBox(const Eigen::Vector3f& size, Texture tex) {
  Mesh m = MakeBox(size, std::move(tex), 1);
  // AddQuad gave every face uv (0,1),(1,1),(1,0),(0,0); squeeze face f into atlas cell f.
  for (size_t face = 0; face < 6; ++face) {
    const float u0 = static_cast<float>(face % 3) / 3, v0 = static_cast<float>(face / 3) / 2;
    for (size_t k = 0; k < 4; ++k) {
      Eigen::Vector2f& uv = m.uvs[face * 4 + k];
      uv = {u0 + uv.x() / 3, v0 + uv.y() / 2};
    }
  }
  return m;
}

Mesh MakeFrustum(float r0, float r1, float z0, float z1, int segments, Texture side, Texture cap) {
  Mesh m;
  m.textures.push_back(std::move(side));
  const bool caps = cap != nullptr;
  if (caps) m.textures.push_back(std::move(cap));
  for (int s = 0; s < segments; ++s) {
    const float a0 = 2 * static_cast<float>(M_PI) * s / segments;
    const float a1 = 2 * static_cast<float>(M_PI) * (s + 1) / segments;
    const Eigen::Vector3f b0(r0 * std::cos(a0), r0 * std::sin(a0), z0);
    const Eigen::Vector3f b1(r0 * std::cos(a1), r0 * std::sin(a1), z0);
    const Eigen::Vector3f t0(r1 * std::cos(a0), r1 * std::sin(a0), z1);
    const Eigen::Vector3f t1(r1 * std::cos(a1), r1 * std::sin(a1), z1);
    const int i = static_cast<int>(m.positions.size());
    const float u0 = static_cast<float>(s) / segments, u1 = static_cast<float>(s + 1) / segments;
    m.positions.insert(m.positions.end(), {b0, b1, t1, t0});
    m.uvs.insert(m.uvs.end(), {{u0, 1}, {u1, 1}, {u1, 0}, {u0, 0}});
    m.triangles.push_back({i, i + 1, i + 2});
    m.triangles.push_back({i, i + 2, i + 3});
    m.tri_texture.insert(m.tri_texture.end(), {0, 0});
    if (!caps) continue;
    const int c = static_cast<int>(m.positions.size());
    auto uv = [](float a) {
      return Eigen::Vector2f(0.5f + 0.5f * std::cos(a), 0.5f + 0.5f * std::sin(a));
    };
    m.positions.insert(m.positions.end(),
                       {Eigen::Vector3f(0, 0, z1), t0, t1, Eigen::Vector3f(0, 0, z0), b1, b0});
    m.uvs.insert(m.uvs.end(), {{0.5f, 0.5f}, uv(a0), uv(a1), {0.5f, 0.5f}, uv(a1), uv(a0)});
    m.triangles.push_back({c, c + 1, c + 2});      // top, CCW seen from +z
    m.triangles.push_back({c + 3, c + 4, c + 5});  // bottom, CCW seen from -z
    m.tri_texture.insert(m.tri_texture.end(), {1, 1});
  }
  return m;
}

absl::Status WritePlyMm(const Mesh& mesh, const std::string& path) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) return absl::InternalError(absl::StrCat(path, ": cannot open for writing"));
  const size_t nt = mesh.triangles.size();
  out << "ply\nformat ascii 1.0\ncomment skimap-sim model, units: millimetres\n"
      << "element vertex " << nt * 3 << "\nproperty float x\nproperty float y\nproperty float z\n"
      << "property uchar red\nproperty uchar green\nproperty uchar blue\n"
      << "element face " << nt << "\nproperty list uchar int vertex_indices\nend_header\n";
  char line[128];
  for (size_t t = 0; t < nt; ++t) {
    const cv::Mat& tex = *mesh.textures[mesh.tri_texture[t]];
    for (int k = 0; k < 3; ++k) {
      const int v = mesh.triangles[t][k];
      const Eigen::Vector3f p = mesh.positions[v] * 1000.f;
      const cv::Vec3b c = SampleTexture(tex, mesh.uvs[v].x(), mesh.uvs[v].y());
      std::snprintf(line, sizeof(line), "%.3f %.3f %.3f %d %d %d\n", p.x(), p.y(), p.z(), c[2],
                    c[1], c[0]);
      out << line;
    }
  }
  for (size_t t = 0; t < nt; ++t)
    out << "3 " << 3 * t << " " << 3 * t + 1 << " " << 3 * t + 2 << "\n";
  out.close();
  if (!out) return absl::InternalError(absl::StrCat(path, ": write failed"));
  return absl::OkStatus();
}

absl::Status WriteObj(const Mesh& mesh, const std::string& path) {
  const std::filesystem::path obj(path);
  const std::string stem = obj.stem().string();
  const std::filesystem::path dir = obj.parent_path();
  const std::string mtl_name = stem + ".mtl";
  std::ofstream mtl(dir / mtl_name, std::ios::trunc);
  if (!mtl) return absl::InternalError(absl::StrCat((dir / mtl_name).string(), ": cannot open"));
  for (size_t i = 0; i < mesh.textures.size(); ++i) {
    const std::string png = absl::StrCat(stem, "_tex", i, ".png");
    if (!perception::WriteImageFile((dir / png).string(), *mesh.textures[i]).ok()) {
      return absl::InternalError(absl::StrCat((dir / png).string(), ": write failed"));
    }
    mtl << "newmtl tex" << i << "\nKd 1 1 1\nmap_Kd " << png << "\n";
  }
  std::ofstream out(path, std::ios::trunc);
  if (!out) return absl::InternalError(absl::StrCat(path, ": cannot open for writing"));
  out << "# skimap-sim model, units: metres\nmtllib " << mtl_name << "\n";
  char line[128];
  for (const Eigen::Vector3f& p : mesh.positions) {
    std::snprintf(line, sizeof(line), "v %.6f %.6f %.6f\n", p.x(), p.y(), p.z());
    out << line;
  }
  for (const Eigen::Vector2f& uv : mesh.uvs) {
    std::snprintf(line, sizeof(line), "vt %.6f %.6f\n", uv.x(), 1.f - uv.y());
    out << line;
  }
  int current = -1;
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (mesh.tri_texture[t] != current) {
      current = mesh.tri_texture[t];
      out << "usemtl tex" << current << "\n";
    }
    const auto& tri = mesh.triangles[t];
    out << "f " << tri[0] + 1 << "/" << tri[0] + 1 << " " << tri[1] + 1 << "/" << tri[1] + 1 << " "
        << tri[2] + 1 << "/" << tri[2] + 1 << "\n";
  }
  out.close();
  if (!out || !mtl) return absl::InternalError(absl::StrCat(path, ": write failed"));
  return absl::OkStatus();
}

}  // namespace skimap::sim
