// Object catalogue. See objects.h for the contract.
#include "sim/objects.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "codec/image_files.h"

namespace skimap::sim {
namespace {

using Eigen::Affine3f;
using Eigen::Vector3f;

Affine3f At(float x, float y, float z) { return Affine3f(Eigen::Translation3f(x, y, z)); }

Texture Darker(const Texture& t, double f) {
  auto m = std::make_shared<cv::Mat>();
  t->convertTo(*m, -1, f);
  return m;
}

// A cylinder standing on z = 0.
Mesh Cyl(float r, float h, Texture side, Texture cap, int seg = 24) {
  return MakeFrustum(r, r, 0, h, seg, std::move(side), std::move(cap));
}

// A printed box (every face different, as on real packaging) standing on z = 0.
Mesh BoxOnFloor(Vector3f size, Texture t) {
  Mesh m;
  m.Append(MakePrintedBox(size, std::move(t)), At(0, 0, size.z() / 2));
  return m;
}

Mesh Design(int index, const Texture& t, const Texture& alt) {
  const Texture grey = FlatTexture(200, 200, 200);
  const Texture dark = FlatTexture(40, 40, 40);
  Mesh m;
  switch (index) {
    case 0:  // "Boxgreen": a ~5 cm cube
      return BoxOnFloor({0.05f, 0.05f, 0.05f}, t);
    case 1:  // cereal box
      return BoxOnFloor({0.19f, 0.07f, 0.28f}, t);
    case 2:  // tea box
      return BoxOnFloor({0.15f, 0.08f, 0.07f}, t);
    case 3:  // mug: cylinder + handle from three boxes
      m = Cyl(0.042f, 0.10f, t, dark);
      m.Append(MakeBox({0.03f, 0.012f, 0.012f}, alt), At(0.055f, 0, 0.085f));
      m.Append(MakeBox({0.012f, 0.012f, 0.06f}, alt), At(0.064f, 0, 0.05f));
      m.Append(MakeBox({0.03f, 0.012f, 0.012f}, alt), At(0.055f, 0, 0.015f));
      return m;
    case 4:  // can
      return Cyl(0.033f, 0.12f, t, grey);
    case 5:  // bottle: body, shoulder, neck, cap
      m = Cyl(0.035f, 0.17f, t, grey);
      m.Append(MakeFrustum(0.035f, 0.014f, 0.17f, 0.21f, 24, alt, nullptr));
      m.Append(Cyl(0.014f, 0.04f, alt, nullptr), At(0, 0, 0.21f));
      m.Append(Cyl(0.016f, 0.02f, dark, dark), At(0, 0, 0.25f));
      return m;
    case 6:  // jar with lid
      m = Cyl(0.05f, 0.11f, t, grey);
      m.Append(Cyl(0.053f, 0.025f, alt, alt), At(0, 0, 0.11f));
      return m;
    case 7:  // book lying flat
      return BoxOnFloor({0.15f, 0.22f, 0.035f}, t);
    case 8:  // shampoo: flat box bottle + cap
      m = BoxOnFloor({0.08f, 0.045f, 0.16f}, t);
      m.Append(Cyl(0.015f, 0.03f, alt, alt), At(0, 0, 0.16f));
      return m;
    case 9:  // desk lamp-like composite: base, pole, head
      m = BoxOnFloor({0.12f, 0.12f, 0.025f}, alt);
      m.Append(Cyl(0.012f, 0.18f, grey, grey, 12), At(0, 0, 0.025f));
      m.Append(MakePrintedBox({0.14f, 0.07f, 0.06f}, t), At(0.03f, 0, 0.235f));
      return m;
    case 10:  // paper cup (tapered)
      return MakeFrustum(0.03f, 0.042f, 0, 0.095f, 24, t, dark);
    default:  // tall chips tube
      m = Cyl(0.038f, 0.25f, t, alt);
      return m;
  }
}

const char* kNames[kNumObjectDesigns] = {"boxgreen", "cereal", "teabox",  "mug",  "can", "bottle",
                                         "jar",      "book",   "shampoo", "lamp", "cup", "chips"};

}  // namespace

void CentreMesh(Mesh& mesh) {
  const Vector3f c = mesh.Bounds().center();
  for (Vector3f& p : mesh.positions) p -= c;
}

namespace {

// The picture in `file` if usable as a texture (colour, at least 64x64 px), else empty.
cv::Mat ReadTexturePicture(const std::string& file) {
  cv::Mat img = perception::ReadImageFile(file, perception::ImageMode::kColor).value_or(cv::Mat());
  if (img.empty() || img.cols < 64 || img.rows < 64) return {};
  // Skip nearly grey images (calibration boards, masks): they make poor object textures.
  cv::Mat hsv;
  cv::cvtColor(img, hsv, cv::COLOR_BGR2HSV);
  if (cv::mean(hsv)[1] < 40) return {};
  return img;
}

Texture Scaled(const cv::Mat& img, int max_side) {
  const double s = std::min(1.0, static_cast<double>(max_side) / std::max(img.cols, img.rows));
  cv::Mat small;
  cv::resize(img, small, cv::Size(), s, s, cv::INTER_AREA);
  return std::make_shared<const cv::Mat>(std::move(small));
}

}  // namespace

absl::StatusOr<std::vector<Texture>> LoadTextures(const std::string& dir, int max_side,
                                                  int min_count) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    return absl::NotFoundError(absl::StrCat(dir, ": texture folder not found"));
  }
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (e.is_regular_file() &&
        (ext == ".jpg" || ext == ".jpeg" || ext == ".png" || ext == ".webp")) {
      files.push_back(e.path().string());
    }
  }
  std::sort(files.begin(), files.end());
  std::vector<Texture> out;
  std::vector<std::string> usable;
  for (const std::string& f : files) {
    const cv::Mat img = ReadTexturePicture(f);
    if (img.empty()) continue;
    out.push_back(Scaled(img, max_side));
    usable.push_back(f);
  }
  if (out.empty()) {
    return absl::NotFoundError(absl::StrCat(dir, ": no colour .jpg/.png image of >= 64x64 px"));
  }
  if (static_cast<int>(out.size()) >= min_count) return out;
  int k = 2;
  while (k < 4 && static_cast<int>(usable.size()) * k * k < min_count) ++k;
  // Read again rather than kept: wallpapers are 4096 px square (48 MB each decoded).
  std::vector<Texture> tiles;
  for (const std::string& f : usable) {
    const cv::Mat img = ReadTexturePicture(f);
    const int w = img.cols / k, h = img.rows / k;
    if (w < 64 || h < 64) {
      tiles.push_back(Scaled(img, max_side));
      continue;
    }
    for (int ty = 0; ty < k; ++ty) {
      for (int tx = 0; tx < k; ++tx)
        tiles.push_back(Scaled(img(cv::Rect(tx * w, ty * h, w, h)), max_side));
    }
  }
  return tiles;
}

namespace {

// ORB keypoints of the 8-bit descriptors d (one per row) with no other descriptor within
// `bits` Hamming bits. The rows are packed into 64-bit words first: all pairs are compared,
// and cv::norm on row views cost a fifth of a render under ASan.
int DistinctDescriptors(const cv::Mat& d, int bits) {
  const size_t words = (static_cast<size_t>(d.cols) + 7) / 8;
  std::vector<uint64_t> packed(words * static_cast<size_t>(d.rows), 0);
  for (int r = 0; r < d.rows; ++r) std::memcpy(&packed[r * words], d.ptr<uint8_t>(r), d.cols);
  int distinct = 0;
  for (size_t a = 0; a < static_cast<size_t>(d.rows); ++a) {
    const uint64_t* pa = &packed[a * words];
    bool twin = false;
    for (size_t b = 0; b < static_cast<size_t>(d.rows) && !twin; ++b) {
      if (b == a) continue;
      const uint64_t* pb = &packed[b * words];
      int dist = 0;
      for (size_t k = 0; k < words; ++k) dist += std::popcount(pa[k] ^ pb[k]);
      twin = dist <= bits;
    }
    distinct += !twin;
  }
  return distinct;
}

}  // namespace

std::vector<size_t> RankByDetail(const std::vector<Texture>& textures) {
  // Detail: ORB keypoints whose descriptor has no near twin (Hamming > 50) elsewhere in the
  // same picture, per pixel: a repeated pattern has many keypoints but few distinct ones.
  cv::Ptr<cv::ORB> orb = cv::ORB::create(500);
  std::vector<std::pair<double, size_t>> score;
  std::vector<cv::Mat> thumbs;
  std::vector<double> colourful;
  std::vector<int> keypoint_count;
  for (size_t i = 0; i < textures.size(); ++i) {
    cv::Mat gray;
    cv::cvtColor(*textures[i], gray, cv::COLOR_BGR2GRAY);
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat d;
    orb->detectAndCompute(gray, cv::noArray(), keypoints, d);
    const int distinct = DistinctDescriptors(d, 50);
    score.push_back({static_cast<double>(distinct) / gray.total(), i});
    keypoint_count.push_back(static_cast<int>(keypoints.size()));
    // Colourfulness (Hasler and Suesstrunk 2003): printed packaging is colourful.
    cv::Mat f;
    textures[i]->convertTo(f, CV_32F);
    std::vector<cv::Mat> bgr;
    cv::split(f, bgr);
    cv::Scalar m_rg, s_rg, m_yb, s_yb;
    cv::meanStdDev(bgr[2] - bgr[1], m_rg, s_rg);
    cv::meanStdDev(0.5 * (bgr[2] + bgr[1]) - bgr[0], m_yb, s_yb);
    colourful.push_back(std::hypot(s_rg[0], s_yb[0]) + 0.3 * std::hypot(m_rg[0], m_yb[0]));
    cv::Mat t;
    cv::resize(gray, t, cv::Size(16, 16), 0, 0, cv::INTER_AREA);
    t.convertTo(t, CV_32F);
    cv::Scalar mean, sd;
    cv::meanStdDev(t, mean, sd);
    thumbs.push_back((t - mean[0]) / (sd[0] + 1e-6));
  }
  std::stable_sort(score.begin(), score.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  // Near twins (stereo pairs, frames of one sequence), dull pictures (colourfulness under
  // 40: a green circuit board, grey facades) and blurred or plain ones (ORB finds fewer
  // than 300 of its 500 keypoints) go to the end: objects must differ and look like
  // packaging.
  std::vector<size_t> out, twins;
  for (const auto& entry : score) {
    const size_t i = entry.second;  // named, not bound: the lambda captures it (clang 14)
    const bool twin = std::any_of(out.begin(), out.end(), [&](size_t k) {
      return thumbs[i].dot(thumbs[k]) / thumbs[i].total() > 0.6;
    });
    (twin || colourful[i] < 40 || keypoint_count[i] < 300 ? twins : out).push_back(i);
  }
  out.insert(out.end(), twins.begin(), twins.end());
  return out;
}

std::vector<ObjectModel> MakeDatabaseObjects(const std::vector<Texture>& textures,
                                             const std::vector<size_t>& rank, int count) {
  std::vector<ObjectModel> out;
  const size_t n = textures.size();
  for (int i = 0; i < count && i < kNumObjectDesigns; ++i) {
    ObjectModel o;
    o.obj_id = i + 1;
    o.name = kNames[i];
    // Secondary parts (handles, caps, lids) take pictures after every object's own, so that
    // no object carries another's print.
    o.mesh =
        Design(i, textures[rank[i % n]], Darker(textures[rank[(kNumObjectDesigns + i) % n]], 0.8));
    CentreMesh(o.mesh);
    out.push_back(std::move(o));
  }
  return out;
}

std::vector<Mesh> MakeDistractors(const std::vector<Texture>& textures,
                                  const std::vector<size_t>& rank, int count) {
  std::vector<Mesh> out;
  const size_t n = textures.size();
  for (int i = 0; i < count; ++i) {
    const Texture& t = textures[rank[n - 1 - (i % n)]];
    Mesh m;
    switch (i % 4) {
      case 0:  // vase
        m = MakeFrustum(0.06f, 0.035f, 0, 0.22f, 20, t, FlatTexture(30, 30, 30));
        break;
      case 1:  // shoe-box
        m = BoxOnFloor({0.30f, 0.18f, 0.12f}, t);
        break;
      case 2:  // flower pot with plant block
        m = MakeFrustum(0.05f, 0.07f, 0, 0.12f, 20, FlatTexture(60, 90, 160), nullptr);
        m.Append(MakePrintedBox({0.10f, 0.10f, 0.12f}, t),
                 Affine3f(Eigen::Translation3f(0, 0, 0.18f)));
        break;
      default:  // stack of two boxes
        m = BoxOnFloor({0.12f, 0.12f, 0.08f}, t);
        m.Append(MakeBox({0.08f, 0.08f, 0.08f}, FlatTexture(50, 120, 200)),
                 Affine3f(Eigen::Translation3f(0, 0, 0.12f)));
        break;
    }
    CentreMesh(m);
    out.push_back(std::move(m));
  }
  return out;
}

}  // namespace skimap::sim
