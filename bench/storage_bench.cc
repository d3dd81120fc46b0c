// storage_bench: map persistence (issue 10; docs/benchmarks.md, "Map storage"). A plain
// program, not a test; markdown tables on stdout, progress on stderr:
//
//   build/bench/bench/storage_bench [--frames=150] [--resolutions=0.05,0.02] [--rate=30]
//       [--repetitions=2] [--big_frames=50] [--incremental_frames=3] [--data_dir=DIR]
//       [--parts=ingest,persist]
//
// 1. Ingestion over loopback gRPC (MapClient FrameStream, window 8, into in-process
//    Servers): frames/s with the journal on (maps_db_path: SqliteMapStore, WAL,
//    synchronous=FULL, so every frame is fsynced before its ack) and off (no store), for one
//    stream and for four streams into four maps (four client threads), at the maximum rate
//    and paced at --rate frames/s per stream, with the ack latency of each; beside them the
//    disk's fsync rate (write + fdatasync on the data dir's filesystem) and the latency of
//    AppendJournal alone. Snapshots are off during these runs (the journal alone is
//    measured; snapshot costs are part 2's).
// 2. Persistence of one map of >= 10 M voxels at 1 cm built by MapService::IntegrateFrame
//    with a store: the first (full) snapshot, then an incremental one after a few frames of
//    new space and another after a few frames re-observing mapped space
//    (MapService::SnapshotAll); bytes per voxel of the snapshot's chunks and of maps.sqlite;
//    reload (a fresh SqliteMapStore + MapService::Recover) in voxels/s; journal replay (a
//    store holding the same journal records and no snapshot) in frames/s; export of the
//    map to one file (MapService::ExportMap, without and with the journal) and import of it
//    (MapService::ImportMap) in MB/s, in-process (the gRPC adapters only move the pieces;
//    the import's voxel count is checked). Side by side:
//    OctoMap 1.9 OcTree (.bt, writeBinary) and ColorOcTree (.ot, write) holding the same
//    voxels (the stored voxels' centres, log-odds from their weight, their mean colour),
//    written and read back.
//
// Frames: 640x480 (fx = fy = 525), 16-bit PNG depth (millimetres, with Kinect-like axial
// noise sigma(z) = 1.2 mm + 1.9 mm (z - 0.4 m)^2) and JPEG colour (quality 90; surfaces
// textured with the opencv-doc photographs), ray-cast up front along a straight aisle: a
// new pose every 5 m looking sideways at shelves and a wall 3 m away, so every frame is new
// space and each map keeps growing.
//
// Checks (a failure prints CHECK FAILED and the program exits 1, so scripts/bench.sh writes
// no docs): every frame acknowledged OK; every run of a case, journal on and off, ends with
// the same voxel count; the reload and the replay give the map's voxel count (and the
// replay its frame count); both OctoMap trees, before writing and after reading, hold
// exactly the map's voxels (a pruned leaf counts as the 8^n voxels it stands for).
#include <fcntl.h>
#include <octomap/ColorOcTree.h>
#include <octomap/OcTree.h>
#include <sys/statfs.h>
#include <sys/utsname.h>
#include <unistd.h>
#include <zstd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "Eigen/Geometry"
#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "client/map_client.h"
#include "codec/image_codec.h"
#include "opencv2/imgcodecs.hpp"
#include "server/app/server.h"
#include "server/core/maps/map_config.h"
#include "server/core/maps/map_service.h"
#include "server/core/transfer/chunk_codec.h"
#include "server/core/transfer/map_exporter.h"
#include "server/core/transfer/map_importer.h"
#include "server/core/transfer/map_transfer.h"
#include "skimap/voxel.h"
#include "skimap/voxel_batch.h"
#include "storage/sqlite_map_store.h"
#include "tests/common/synthetic_scene.h"

ABSL_FLAG(int, frames, 150, "ingestion frames per run on one stream (4 streams: frames/2 each)");
ABSL_FLAG(std::string, resolutions, "0.05,0.02", "map resolutions of the ingestion runs, metres");
ABSL_FLAG(double, rate, 30, "paced ingestion: frames/s per stream");
ABSL_FLAG(int, repetitions, 2,
          "ingestion runs per case and side, interleaved; the fastest of each side is kept");
ABSL_FLAG(int, worker_threads, 2, "skimapd integration threads (its default)");
ABSL_FLAG(int, big_frames, 50, "frames of the 1 cm map (the default makes >= 10 M voxels)");
ABSL_FLAG(int, incremental_frames, 3, "frames added before the incremental snapshot");
ABSL_FLAG(int64_t, min_big_voxels, 10000000, "the 1 cm map must reach this many voxels");
ABSL_FLAG(std::string, data_dir, "",
          "where the stores and files go (\"\": a new directory under /tmp, removed at the end)");
ABSL_FLAG(bool, keep_data, false, "keep --data_dir's contents at the end");
ABSL_FLAG(std::string, textures, "/usr/share/doc/opencv-doc/examples/data",
          "directory of the opencv-doc photographs used as surface textures");
ABSL_FLAG(std::string, parts, "ingest,persist", "ingest (part 1) and/or persist (part 2)");

namespace skimap::bench {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

std::atomic<int> failures{0};  // Check may run on client threads
void Check(bool ok, const std::string& what) {
  if (ok) return;
  ++failures;
  std::fprintf(stderr, "CHECK FAILED: %s\n", what.c_str());
  std::printf("\n**CHECK FAILED: %s**\n", what.c_str());
}
void Die(const std::string& what) {
  std::fprintf(stderr, "storage_bench: %s\n", what.c_str());
  std::exit(1);
}
void Progress(const std::string& what) {
  std::fprintf(stderr, "storage_bench: %s\n", what.c_str());
  std::fflush(stderr);
}

// ---------------------------------------------------------------------------------------
// The world and the frames.

constexpr int kWidth = 640, kHeight = 480;
constexpr double kFx = 525, kFy = 525, kCx = 319.5, kCy = 239.5;
constexpr double kWallY = 3.0;    // the wall the camera looks at
constexpr double kStep = 5.0;     // metres between poses; a frame spans ~3.7 m of wall
constexpr double kX0 = -100.0;    // first pose: the 1 cm map stays well inside OctoMap's
                                  // +-327 m key range at 1 cm
constexpr double kTexel = 0.004;  // metres per texture pixel

struct Box {
  Eigen::Vector3d min, max;
  int texture;
};

// A 10 cm wall at y = 3 m, shelves of varying size in front of it and crates on the floor,
// from x_begin - 10 to x_end + 10.
std::vector<Box> MakeAisle(double x_begin, double x_end, int textures) {
  std::vector<Box> boxes = {{{x_begin - 10, kWallY, 0}, {x_end + 10, kWallY + 0.1, 3}, 0}};
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  int i = 0;
  for (double x = x_begin - 8; x < x_end + 8; x += 1.2 + u(rng), ++i) {
    const double w = 0.4 + 0.6 * u(rng), depth = 0.3 + 0.4 * u(rng), h = 0.3 + 1.8 * u(rng);
    boxes.push_back({{x, kWallY - 0.05 - depth, 0}, {x + w, kWallY - 0.05, h}, 2 + i % textures});
    if (i % 3 == 0) {  // a crate in the aisle
      const double s = 0.3 + 0.4 * u(rng), y = 1.0 + 0.6 * u(rng);
      boxes.push_back({{x + 0.3, y, 0}, {x + 0.3 + s, y + s, s}, 2 + (i + 1) % textures});
    }
  }
  return boxes;
}

// The boxes within `reach` metres of x (in x): what a frame taken at x can see.
std::vector<Box> Near(const std::vector<Box>& boxes, double x, double reach) {
  std::vector<Box> out;
  for (const Box& b : boxes) {
    if (b.max.x() >= x - reach && b.min.x() <= x + reach) out.push_back(b);
  }
  return out;
}

struct Hit {
  double t = std::numeric_limits<double>::infinity();
  int texture = 1;  // 1: the floor
  int axis = 2;     // axis of the face hit
};

Hit Cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const std::vector<Box>& boxes) {
  Hit hit;
  if (d.z() < 0) hit.t = -o.z() / d.z();
  for (const Box& b : boxes) {
    double t0 = 0, t1 = hit.t;
    int axis = -1;
    for (int a = 0; a < 3 && t0 <= t1; ++a) {
      if (std::abs(d[a]) < 1e-12) {
        if (o[a] < b.min[a] || o[a] > b.max[a]) t0 = t1 + 1;
        continue;
      }
      double ta = (b.min[a] - o[a]) / d[a], tb = (b.max[a] - o[a]) / d[a];
      if (ta > tb) std::swap(ta, tb);
      if (ta > t0) t0 = ta, axis = a;
      t1 = std::min(t1, tb);
    }
    if (t0 <= t1 && t0 < hit.t && axis >= 0) hit = {t0, b.texture, axis};
  }
  return hit;
}

// Pose k: (kX0 + 5 k, 0, 1.2), looking at the wall (+y) and 15 degrees down.
Eigen::Isometry3d PoseOf(int k) {
  return testing::LookingAlong({kX0 + kStep * k, 0, 1.2}, {0, 1, -0.27});
}

// RGB textures (the opencv-doc photographs), or procedural ones when they are missing.
std::vector<cv::Mat> LoadTextures(const std::string& dir) {
  std::vector<cv::Mat> out;
  for (const char* name : {"building.jpg", "home.jpg", "fruits.jpg", "baboon.jpg", "board.jpg",
                           "graf1.png", "lena.jpg", "butterfly.jpg"}) {
    cv::Mat bgr = cv::imread(dir + "/" + name, cv::IMREAD_COLOR);
    if (!bgr.empty()) out.push_back(bgr);
  }
  if (out.size() < 3) {
    std::fprintf(stderr,
                 "storage_bench: WARNING: photographs not found in %s; procedural "
                 "textures (JPEG sizes will be smaller than real ones)\n",
                 dir.c_str());
    out.clear();
    for (int i = 0; i < 3; ++i) {
      cv::Mat m(256, 256, CV_8UC3);
      for (int y = 0; y < 256; ++y) {
        for (int x = 0; x < 256; ++x) {
          m.at<cv::Vec3b>(y, x) = cv::Vec3b(uchar((x * (i + 1)) & 255), uchar((y * 3) & 255),
                                            uchar(((x / 16 + y / 16) % 2) * 200));
        }
      }
      out.push_back(m);
    }
  }
  return out;
}

struct Rendered {
  perception::DepthImage depth;
  perception::ColorImage color;
};

Rendered Render(const Eigen::Isometry3d& pose, const std::vector<Box>& boxes,
                const std::vector<cv::Mat>& textures, uint32_t seed) {
  Rendered r{{kWidth, kHeight, std::vector<uint16_t>(kWidth * kHeight, 0)},
             {kWidth, kHeight, std::vector<uint8_t>(kWidth * kHeight * 3, 0)}};
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0, 1);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const Eigen::Vector3d ray((u - kCx) / kFx, (v - kCy) / kFy, 1);  // z = 1: t is depth
      const Eigen::Vector3d dir = pose.linear() * ray;
      const Hit hit = Cast(pose.translation(), dir, boxes);
      if (!(hit.t < 8.0)) continue;
      const double sigma = 0.0012 + 0.0019 * (hit.t - 0.4) * (hit.t - 0.4);
      const double z = hit.t + sigma * gauss(rng);
      if (z <= 0) continue;
      const size_t i = size_t(v) * kWidth + u;
      r.depth.pixels[i] = uint16_t(std::min<long>(65535, std::lround(z * 1000)));
      const Eigen::Vector3d p = pose.translation() + hit.t * dir;
      const double s = hit.axis == 0 ? p.y() : p.x(), t = hit.axis == 2 ? p.y() : p.z();
      const cv::Mat& tex = textures[size_t(hit.texture) % textures.size()];
      auto wrap = [](double c, int n) {
        const long k = long(std::floor(c / kTexel)) % n;
        return int(k < 0 ? k + n : k);
      };
      const cv::Vec3b bgr = tex.at<cv::Vec3b>(tex.rows - 1 - wrap(t, tex.rows), wrap(s, tex.cols));
      r.color.rgb[3 * i] = bgr[2];
      r.color.rgb[3 * i + 1] = bgr[1];
      r.color.rgb[3 * i + 2] = bgr[0];
    }
  }
  return r;
}

// One encoded frame per pose: the images and the pose, without map and sequence.
struct Encoded {
  Eigen::Isometry3d pose;
  std::string depth_png, color_jpeg;
};

v1::Frame MakeFrame(const std::string& map, uint64_t sequence, const Encoded& e) {
  v1::Frame f;
  f.set_map(map);
  f.set_sequence(sequence);
  const Eigen::Quaterniond q(e.pose.linear());
  auto* p = f.mutable_pose();
  p->mutable_rotation()->set_w(q.w());
  p->mutable_rotation()->set_x(q.x());
  p->mutable_rotation()->set_y(q.y());
  p->mutable_rotation()->set_z(q.z());
  p->mutable_translation()->set_x(e.pose.translation().x());
  p->mutable_translation()->set_y(e.pose.translation().y());
  p->mutable_translation()->set_z(e.pose.translation().z());
  auto* k = f.mutable_intrinsics();
  k->set_fx(kFx);
  k->set_fy(kFy);
  k->set_cx(kCx);
  k->set_cy(kCy);
  k->set_width(kWidth);
  k->set_height(kHeight);
  f.set_depth_encoding(v1::DEPTH_ENCODING_PNG16);
  f.set_depth(e.depth_png);
  f.set_depth_scale(0.001);
  f.set_color_encoding(v1::COLOR_ENCODING_JPEG);
  f.set_color(e.color_jpeg);
  return f;
}

// Renders and encodes poses 0..n-1 on every core.
std::vector<Encoded> RenderFrames(int n, const std::vector<cv::Mat>& textures) {
  const std::vector<Box> world = MakeAisle(kX0, kX0 + kStep * n, int(textures.size()) - 2);
  std::vector<Encoded> out(n);
  std::atomic<int> next{0};
  std::vector<std::thread> threads;
  for (unsigned t = 0; t < std::max(1u, std::thread::hardware_concurrency()); ++t) {
    threads.emplace_back([&] {
      for (int k; (k = next++) < n;) {
        const Eigen::Isometry3d pose = PoseOf(k);
        const Rendered r = Render(pose, Near(world, pose.translation().x(), 8), textures, 1000 + k);
        absl::StatusOr<std::string> d =
            perception::EncodeDepth(perception::DepthCodec::kPng16, r.depth);
        absl::StatusOr<std::string> c =
            perception::EncodeColor(perception::ColorCodec::kJpeg, r.color);
        if (!d.ok() || !c.ok()) Die("encoding a frame failed");
        out[k] = {pose, *std::move(d), *std::move(c)};
      }
    });
  }
  for (std::thread& t : threads) t.join();
  return out;
}

// ---------------------------------------------------------------------------------------
// Machine and disk.

std::string UtcNow() {
  const std::time_t now = std::time(nullptr);
  char buf[64];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  return buf;
}

std::string FirstLineOf(const std::string& path, const std::string& prefix) {
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(prefix, 0) == 0) return line.substr(line.find(':') + 2);
  }
  return "?";
}

double MemoryGb() {
  std::ifstream in("/proc/meminfo");
  std::string name;
  double kb = 0;
  in >> name >> kb;
  return kb / 1048576.0;
}

std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return absl::StrCat(a, " ", b, " ", c);
}

std::string FilesystemOf(const std::string& dir) {
  struct statfs s;
  if (statfs(dir.c_str(), &s) != 0) return "?";
  switch (static_cast<unsigned long>(s.f_type)) {
    case 0xEF53:
      return "ext4";
    case 0x58465342:
      return "xfs";
    case 0x9123683E:
      return "btrfs";
    case 0x01021994:
      return "tmpfs (fsync is free: not a disk)";
    case 0x794c7630:
      return "overlayfs";
    default:
      return absl::StrCat("f_type 0x", absl::Hex(s.f_type));
  }
}

// The mount holding `dir` as /proc/mounts names it ("/dev/vda on / (ext4)").
std::string MountOf(const std::string& dir) {
  const std::string path = fs::weakly_canonical(dir).string();
  std::ifstream in("/proc/mounts");
  std::string best, best_dev;
  for (std::string dev, mnt, type, rest; in >> dev >> mnt >> type && std::getline(in, rest);) {
    const bool under = path == mnt || path.rfind(mnt == "/" ? mnt : mnt + "/", 0) == 0;
    if (under && mnt.size() >= best.size()) best = mnt, best_dev = dev;
  }
  return absl::StrCat(best_dev, " on ", best);
}

// write(bytes) + fdatasync per iteration for ~`seconds` on `dir`'s filesystem: appends to
// a growing file (as a log does) or overwrites its first block.
double FsyncRate(const std::string& dir, size_t bytes, bool append, double seconds = 0.5) {
  const std::string path = dir + "/fsync-probe";
  const int fd = ::open(path.c_str(), O_CREAT | O_TRUNC | O_WRONLY, 0644);
  if (fd < 0) Die("cannot create " + path);
  std::string buf(bytes, '\0');
  std::mt19937 rng(5);
  for (char& c : buf) c = char(rng());
  int n = 0;
  const Clock::time_point start = Clock::now();
  while (Seconds(Clock::now() - start) < seconds && n < 5000) {
    const ssize_t w = append ? ::write(fd, buf.data(), bytes) : ::pwrite(fd, buf.data(), bytes, 0);
    if (w != ssize_t(bytes) || ::fdatasync(fd) != 0) Die("fsync probe: write/fdatasync failed");
    ++n;
  }
  const double rate = n / Seconds(Clock::now() - start);
  ::close(fd);
  fs::remove(path);
  return rate;
}

void SyncFile(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0 || ::fdatasync(fd) != 0) Die("cannot fdatasync " + path);
  ::close(fd);
}

uint64_t FileBytes(const std::string& path) {
  std::error_code ec;
  const uint64_t n = fs::file_size(path, ec);
  return ec ? 0 : n;
}

uint64_t ZstdBytes(const std::string& path, int level) {
  std::ifstream in(path, std::ios::binary);
  const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::string out(ZSTD_compressBound(data.size()), '\0');
  const size_t n = ZSTD_compress(out.data(), out.size(), data.data(), data.size(), level);
  if (ZSTD_isError(n)) Die("zstd failed on " + path);
  return n;
}

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(p * v.size()))];
}

std::string Fmt(double v, int digits = 1) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

// ---------------------------------------------------------------------------------------
// Part 1: ingestion over gRPC, journal on and off.

void CreateMap(client::MapClient& client, const std::string& id, double resolution) {
  v1::CreateMapRequest request;
  request.set_map_id(id);
  request.mutable_options()->set_resolution(resolution);
  if (auto map = client.CreateMap(request); !map.ok()) {
    Die(absl::StrCat("CreateMap ", id, ": ", map.status().ToString()));
  }
}

struct StreamResult {
  int sent = 0, ok = 0;
  uint64_t touched = 0;  // voxels_touched summed over the acks
  Clock::time_point end;
  std::vector<double> latency_ms;
};

// Sends frames first..first+n-1 (poses of the same index) to maps/{id} from `start`, paced
// at `rate` frames/s (0: as fast as the window allows).
StreamResult RunStream(client::MapClient& client, const std::string& id, int first, int n,
                       double rate, Clock::time_point start, const std::vector<Encoded>& frames) {
  StreamResult r;
  std::vector<std::atomic<int64_t>> sent_ns(n);
  std::mutex mu;
  client::FrameStream::Options options;
  options.window = 8;
  options.on_ack = [&](const v1::FrameAck& ack) {
    const int64_t now = Clock::now().time_since_epoch().count();
    const int64_t i = int64_t(ack.sequence()) - first;
    std::lock_guard<std::mutex> lock(mu);
    if (i >= 0 && i < n) r.latency_ms.push_back((now - sent_ns[i].load()) * 1e-6);
  };
  static_assert(std::is_same_v<Clock::duration, std::chrono::nanoseconds>);
  std::unique_ptr<client::FrameStream> stream = client.OpenFrameStream(options);
  const std::string map = absl::StrCat("maps/", id);
  std::this_thread::sleep_until(start);
  for (int i = 0; i < n; ++i) {
    if (rate > 0) {
      std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(
                                                std::chrono::duration<double>(i / rate)));
    }
    const v1::Frame frame = MakeFrame(map, first + i, frames[first + i]);
    sent_ns[i] = Clock::now().time_since_epoch().count();
    if (!stream->Send(frame).ok()) break;
    ++r.sent;
  }
  absl::StatusOr<std::vector<v1::FrameAck>> acks = stream->Finish();
  r.end = Clock::now();
  if (!acks.ok()) {
    Check(false, absl::StrCat("stream into ", map, ": ", acks.status().ToString()));
    return r;
  }
  for (const v1::FrameAck& a : *acks) {
    if (a.code() == 0) {
      ++r.ok;
      r.touched += a.voxels_touched();
    }
  }
  return r;
}

struct RunResult {
  int sent = 0, ok = 0;
  double fps = 0;
  uint64_t voxels = 0, touched = 0;
  std::vector<double> latency_ms;
};

int map_counter = 0;

// `streams` concurrent streams, each into its own new map, `n` frames each; stream s sends
// poses s*7 .. s*7+n-1. Deletes the maps afterwards.
RunResult RunIngest(client::MapClient& client, double resolution, int streams, int n, double rate,
                    const std::vector<Encoded>& frames) {
  std::vector<std::string> ids;
  for (int s = 0; s < streams; ++s) {
    ids.push_back(absl::StrCat("ingest", map_counter++));
    CreateMap(client, ids.back(), resolution);
  }
  std::vector<StreamResult> results(streams);
  const Clock::time_point start = Clock::now() + std::chrono::milliseconds(50);
  std::vector<std::thread> threads;
  for (int s = 0; s < streams; ++s) {
    threads.emplace_back(
        [&, s] { results[s] = RunStream(client, ids[s], s * 7, n, rate, start, frames); });
  }
  for (std::thread& t : threads) t.join();
  RunResult out;
  Clock::time_point end = start;
  for (const StreamResult& r : results) {
    out.sent += r.sent;
    out.ok += r.ok;
    out.touched += r.touched;
    end = std::max(end, r.end);
    out.latency_ms.insert(out.latency_ms.end(), r.latency_ms.begin(), r.latency_ms.end());
  }
  out.fps = out.ok / Seconds(end - start);
  for (const std::string& id : ids) {
    absl::StatusOr<v1::Map> map = client.GetMap(absl::StrCat("maps/", id));
    if (!map.ok()) Die(map.status().ToString());
    out.voxels += map->stats().voxels();
    (void)client.DeleteMap(absl::StrCat("maps/", id));
  }
  return out;
}

std::unique_ptr<storage::SqliteMapStore> OpenStore(const std::string& path) {
  absl::StatusOr<std::unique_ptr<storage::SqliteMapStore>> store =
      storage::SqliteMapStore::Open(path);
  if (!store.ok()) Die(absl::StrCat(path, ": ", store.status().ToString()));
  return *std::move(store);
}

// The journal's own cost per frame: SqliteMapStore::AppendJournal of one real frame record
// (pose 0's, as the server journals it), `n` times into a fresh store on the data dir, ms
// per call.
std::vector<double> AppendLatencies(const std::string& data_dir, const Encoded& frame, int n) {
  const std::string dir = data_dir + "/append-probe";
  fs::create_directories(dir);
  std::vector<double> ms;
  {
    std::unique_ptr<storage::SqliteMapStore> store = OpenStore(dir + "/maps.sqlite");
    if (absl::Status s = store->CreateMap("probe", ""); !s.ok()) Die(s.ToString());
    for (int i = 0; i < n; ++i) {
      const std::string record = MakeFrame("maps/probe", i, frame).SerializeAsString();
      const Clock::time_point t0 = Clock::now();
      absl::StatusOr<uint64_t> position =
          store->AppendJournal("probe", {{storage::JournalRecord::kFrame, record}});
      ms.push_back(Seconds(Clock::now() - t0) * 1e3);
      if (!position.ok()) Die(position.status().ToString());
    }
  }
  fs::remove_all(dir);
  return ms;
}

void RunIngestionPart(const std::string& data_dir, const std::vector<Encoded>& frames,
                      double record_bytes) {
  const int n1 = absl::GetFlag(FLAGS_frames), n4 = n1 / 2;
  const double rate = absl::GetFlag(FLAGS_rate);
  const int reps = std::max(1, absl::GetFlag(FLAGS_repetitions));
  const std::vector<std::string> res_list = absl::StrSplit(absl::GetFlag(FLAGS_resolutions), ',');

  Progress("fsync probe");
  const double fsync_4k = FsyncRate(data_dir, 4096, false);
  const double fsync_rec = FsyncRate(data_dir, size_t(record_bytes), true);
  const std::vector<double> append_ms = AppendLatencies(data_dir, frames[0], 200);
  double append_mean = 0;
  for (double m : append_ms) append_mean += m / append_ms.size();

  server::Server::Options options;
  options.grpc.address = "127.0.0.1:0";
  options.maps.worker_threads = absl::GetFlag(FLAGS_worker_threads);
  // The journal alone: no snapshot during the runs (they are measured in part 2).
  options.maps.snapshot_interval = absl::InfiniteDuration();
  options.maps.snapshot_records = std::numeric_limits<uint64_t>::max();
  auto off = server::Server::Start(options);
  fs::create_directories(data_dir + "/ingest");
  options.maps_db_path = data_dir + "/ingest/maps.sqlite";
  auto on = server::Server::Start(options);
  if (!off.ok() || !on.ok()) Die("cannot start the servers");
  auto client_off = client::MapClient::Connect(absl::StrCat("127.0.0.1:", (*off)->grpc_port()));
  auto client_on = client::MapClient::Connect(absl::StrCat("127.0.0.1:", (*on)->grpc_port()));

  std::printf(
      "\n### Ingestion over loopback gRPC, journal on vs off\n\n"
      "Journal on: SqliteMapStore (WAL, synchronous=FULL), every frame appended and fsynced "
      "before its ack; snapshots off during these runs. Off: no store. %d frames on one "
      "stream; %d on each of 4 streams into 4 maps. Paced: %.0f frames/s per stream "
      "offered. Mean journal record %.0f kB (PNG16 depth + JPEG colour + pose). Each side: "
      "the fastest of %d runs, interleaved with the other side's (throughput from the first "
      "send to the last ack; ack latency from Send to the ack's arrival, that run's).\n\n",
      n1, n4, rate, record_bytes / 1024, reps);
  std::printf(
      "Disk (data dir's filesystem): %.0f fsyncs/s overwriting 4 kB, %.0f fsyncs/s appending "
      "%.0f kB records (write + fdatasync).\n\n",
      fsync_4k, fsync_rec, record_bytes / 1024);
  std::printf(
      "The journal alone: SqliteMapStore::AppendJournal of one %.0f kB frame record (%zu "
      "calls, one thread, no ingestion): mean %.2f ms, p50 %.2f ms, p99 %.2f ms, i.e. at most "
      "%.0f records/s (WAL checkpoints included).\n\n",
      frames[0].depth_png.size() / 1024.0 + frames[0].color_jpeg.size() / 1024.0, append_ms.size(),
      append_mean, Percentile(append_ms, 0.5), Percentile(append_ms, 0.99), 1000 / append_mean);
  std::printf(
      "| resolution | streams | offered | journal off frames/s | journal on frames/s | on / off "
      "| ack p50 off / on ms | ack p99 off / on ms | voxels (each side) | new-voxel share |\n"
      "|---|---|---|---|---|---|---|---|---|---|\n");
  std::fflush(stdout);
  struct Paced {
    std::string label;
    double ratio, offered, off_fps;
  };
  std::vector<Paced> paced;
  int order = 0;
  for (const std::string& res_text : res_list) {
    const double resolution = std::stod(res_text);
    for (int streams : {1, 4}) {
      const int n = streams == 1 ? n1 : n4;
      for (double r : {0.0, rate}) {
        Progress(absl::StrCat("ingest ", res_text, " m, ", streams, " stream(s), ",
                              r > 0 ? absl::StrCat(r, " fps each") : "max rate"));
        // Repetitions interleave the two sides, alternating which runs first, so that drift
        // in the machine's load hits both; the fastest run of each side is kept.
        RunResult a, b;
        std::vector<uint64_t> voxel_counts;
        std::vector<int> acked;
        for (int rep = 0; rep < reps; ++rep) {
          RunResult x, y;
          if (order++ % 2 == 0) {
            x = RunIngest(*client_off, resolution, streams, n, r, frames);
            y = RunIngest(*client_on, resolution, streams, n, r, frames);
          } else {
            y = RunIngest(*client_on, resolution, streams, n, r, frames);
            x = RunIngest(*client_off, resolution, streams, n, r, frames);
          }
          for (const RunResult* z : {&x, &y}) {
            voxel_counts.push_back(z->voxels);
            acked.push_back(z->ok);
          }
          if (rep == 0 || x.fps > a.fps) a = std::move(x);
          if (rep == 0 || y.fps > b.fps) b = std::move(y);
        }
        const std::string label =
            absl::StrCat(Fmt(resolution * 100, 0), " cm, ", streams, " stream(s)");
        for (size_t i = 0; i < acked.size(); ++i) {
          Check(acked[i] == streams * n,
                absl::StrCat(label, ", run ", i, " (", i % 2 ? "on" : "off", "): ", acked[i],
                             " frames acknowledged OK of ", streams * n));
          Check(voxel_counts[i] == voxel_counts[0],
                absl::StrCat(label, ", run ", i, " (", i % 2 ? "on" : "off", "): ", voxel_counts[i],
                             " voxels, run 0 (off): ", voxel_counts[0]));
        }
        const double ratio = b.fps / a.fps;
        std::printf(
            "| %.0f cm | %d | %s | %.1f | %.1f | %.2f | %.1f / %.1f | %.1f / %.1f | %llu "
            "| %.0f %% |\n",
            resolution * 100, streams,
            r > 0 ? absl::StrCat(Fmt(r, 0), "/s per stream").c_str() : "max", a.fps, b.fps, ratio,
            Percentile(a.latency_ms, 0.5), Percentile(b.latency_ms, 0.5),
            Percentile(a.latency_ms, 0.99), Percentile(b.latency_ms, 0.99),
            static_cast<unsigned long long>(a.voxels),
            100.0 * double(a.voxels) / double(std::max<uint64_t>(1, a.touched)));
        std::fflush(stdout);
        if (r > 0) paced.push_back({label, ratio, r * streams, a.fps});
      }
    }
  }
  std::printf(
      "\n| claim (issue 10) | offered (total) | journal off reaches | measured on / off "
      "| result |\n|---|---|---|---|---|\n");
  for (const Paced& p : paced) {
    // Beyond what the machine can ingest without the journal, the paced run is a max-rate
    // run: say so beside the verdict.
    const bool saturated = p.off_fps < 0.95 * p.offered;
    std::printf(
        "| at %.0f frames/s per stream the journal costs < 10 %% of the throughput "
        "(%s) | %.0f frames/s | %.1f frames/s%s | %.2f | %s |\n",
        rate, p.label.c_str(), p.offered, p.off_fps,
        saturated ? " (saturated: above this machine's capacity)" : "", p.ratio,
        p.ratio >= 0.9 ? "PASS" : "**FAIL**");
  }
  std::fflush(stdout);
}

// ---------------------------------------------------------------------------------------
// Part 2: snapshot, sizes, reload and replay of a >= 10 M voxel map, beside OctoMap.

// Integrates the frames of poses [first, first + n) into maps/{id} in-process, 8 in flight,
// with sequences sequence0 + pose index.
void IntegrateFrames(server::MapService& service, const std::string& id, int first, int n,
                     const std::vector<Encoded>& frames, uint64_t sequence0 = 0) {
  std::mutex mu;
  std::condition_variable cv;
  int in_flight = 0, ok = 0, done = 0;
  std::string error;
  for (int i = first; i < first + n; ++i) {
    {
      std::unique_lock<std::mutex> lock(mu);
      cv.wait(lock, [&] { return in_flight < 8; });
      ++in_flight;
    }
    auto frame =
        std::make_shared<v1::Frame>(MakeFrame(absl::StrCat("maps/", id), sequence0 + i, frames[i]));
    service.IntegrateFrame(frame, [&](absl::StatusOr<v1::FrameAck> ack) {
      std::lock_guard<std::mutex> lock(mu);
      --in_flight;
      ++done;
      if (ack.ok()) {
        ++ok;
      } else if (error.empty()) {
        error = ack.status().ToString();
      }
      cv.notify_all();
    });
  }
  std::unique_lock<std::mutex> lock(mu);
  cv.wait(lock, [&] { return done == n; });
  Check(ok == n, absl::StrCat("1 cm map: ", ok, " of ", n, " frames OK; first error: ", error));
}

v1::MapStats StatsOf(server::MapService& service, const std::string& id) {
  v1::GetMapRequest request;
  request.set_name(absl::StrCat("maps/", id));
  absl::StatusOr<v1::Map> map = service.GetMap(request);
  if (!map.ok()) Die(map.status().ToString());
  return map->stats();
}

server::MapService::Options ServiceOptions(storage::MapStore* store) {
  server::MapService::Options o;
  o.worker_threads = absl::GetFlag(FLAGS_worker_threads);
  o.store = store;
  o.snapshot_interval = absl::InfiniteDuration();  // snapshots only when the bench asks
  o.snapshot_records = std::numeric_limits<uint64_t>::max();
  return o;
}

std::string ChunkName(const storage::ChunkKey& k) {
  return absl::StrCat(k.volume, "/", k.x, "/", k.y, "/", k.z);
}

// What the latest snapshot holds: every chunk, with a hash of its bytes.
struct SnapshotContents {
  std::vector<storage::Chunk> chunks;
  std::map<std::string, std::pair<size_t, size_t>> hashes;  // name -> (hash, bytes)
  uint64_t rgb_bytes = 0, rgb_chunks = 0, other_bytes = 0;
};

SnapshotContents ReadSnapshotContents(storage::MapStore& store, const std::string& id) {
  SnapshotContents c;
  absl::StatusOr<uint64_t> covered = store.ReadSnapshot(id, [&](const storage::Chunk& chunk) {
    c.hashes[ChunkName(chunk.key)] = {std::hash<std::string>()(chunk.bytes), chunk.bytes.size()};
    if (chunk.key.volume == "rgb") {
      c.rgb_bytes += chunk.bytes.size();
      ++c.rgb_chunks;
    } else {
      c.other_bytes += chunk.bytes.size();
    }
    c.chunks.push_back(chunk);
    return absl::OkStatus();
  });
  if (!covered.ok()) Die(covered.status().ToString());
  return c;
}

// Voxels in an OctoMap tree: a pruned leaf at depth d stands for 8^(16 - d) voxels.
template <class Tree>
uint64_t OctoVoxels(const Tree& tree) {
  uint64_t n = 0;
  const unsigned max_depth = tree.getTreeDepth();
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    n += uint64_t{1} << (3 * (max_depth - it.getDepth()));
  }
  return n;
}

// One export or import of the 1 cm map, in-process through the service core (the gRPC
// adapters only move these pieces).
struct Transfer {
  std::string what;
  uint64_t bytes = 0;
  double seconds = 0;
};

// Writes maps/{id}'s export file (MapService::ExportMap, pieces of 1 MiB appended to a file,
// fdatasync at the end) and returns what it cost.
Transfer ExportToFile(server::MapService& service, const std::string& id, bool with_journal,
                      const std::string& path) {
  Transfer t{absl::StrCat("export", with_journal ? " with journal" : "", " (ExportMap → file, ",
                          "fdatasync)")};
  v1::ExportMapRequest request;
  request.set_name(absl::StrCat("maps/", id));
  request.set_with_journal(with_journal);
  const Clock::time_point t0 = Clock::now();
  absl::StatusOr<std::unique_ptr<server::MapExporter>> exporter =
      server::MapTransfer(&service).Export(request);
  if (!exporter.ok()) Die(exporter.status().ToString());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  while (true) {
    absl::StatusOr<std::optional<std::string>> piece = (*exporter)->Next();
    if (!piece.ok()) Die(piece.status().ToString());
    if (!piece->has_value()) break;
    out.write((*piece)->data(), std::streamsize((*piece)->size()));
    t.bytes += (*piece)->size();
  }
  out.close();
  SyncFile(path);
  t.seconds = Seconds(Clock::now() - t0);
  return t;
}

// Imports `path` as maps/{as} (MapService::ImportMap: the file read in pieces of 1 MiB,
// written to the store as they come, then loaded and every chunk checked).
Transfer ImportFromFile(server::MapService& service, const std::string& path,
                        const std::string& as) {
  Transfer t{"import with journal (file → ImportMap: store writes + load)"};
  const Clock::time_point t0 = Clock::now();
  absl::StatusOr<std::unique_ptr<server::MapImporter>> importer =
      server::MapTransfer(&service).Import(as);
  if (!importer.ok()) Die(importer.status().ToString());
  std::ifstream in(path, std::ios::binary);
  std::string piece(size_t{1} << 20, '\0');
  while (in) {
    in.read(piece.data(), std::streamsize(piece.size()));
    const size_t n = size_t(in.gcount());
    if (n == 0) break;
    if (absl::Status s = (*importer)->Add(std::string_view(piece.data(), n)); !s.ok()) {
      Die(s.ToString());
    }
    t.bytes += n;
  }
  if (absl::StatusOr<v1::Map> map = server::MapTransfer(&service).Finish(**importer); !map.ok()) {
    Die(map.status().ToString());
  }
  t.seconds = Seconds(Clock::now() - t0);
  return t;
}

std::vector<Transfer> MeasureTransfers(server::MapService& service, const std::string& id,
                                       const std::string& data_dir, uint64_t voxels) {
  std::vector<Transfer> out;
  const std::string plain = data_dir + "/big.skmx", full = data_dir + "/big-journal.skmx";
  Progress("export (without and with the journal)");
  out.push_back(ExportToFile(service, id, false, plain));
  out.push_back(ExportToFile(service, id, true, full));
  Progress("import (with the journal)");
  out.push_back(ImportFromFile(service, full, "imported"));
  const v1::MapStats imported = StatsOf(service, "imported");
  Check(imported.voxels() == voxels,
        absl::StrCat("import: ", imported.voxels(), " voxels, want ", voxels));
  v1::DeleteMapRequest del;
  del.set_name("maps/imported");
  (void)service.DeleteMap(del);
  fs::remove(plain);
  fs::remove(full);
  return out;
}

void RunPersistPart(const std::string& data_dir, const std::vector<Encoded>& frames) {
  const int big = absl::GetFlag(FLAGS_big_frames), extra = absl::GetFlag(FLAGS_incremental_frames);
  const double res = 0.01;
  const std::string id = "big";
  const std::string dir = data_dir + "/big", db = dir + "/maps.sqlite";
  fs::create_directories(dir);

  // --- Build the map with the journal on, then snapshot it.
  std::unique_ptr<storage::SqliteMapStore> store = OpenStore(db);
  auto service = std::make_unique<server::MapService>(ServiceOptions(store.get()));
  if (absl::Status s = service->Recover(); !s.ok()) Die(s.ToString());
  v1::CreateMapRequest create;
  create.set_map_id(id);
  create.mutable_options()->set_resolution(res);
  if (auto m = service->CreateMap(create); !m.ok()) Die(m.status().ToString());
  Progress(absl::StrCat("1 cm map: integrating ", big, " frames (journal on)"));
  Clock::time_point t0 = Clock::now();
  IntegrateFrames(*service, id, 0, big, frames);
  const double build_s = Seconds(Clock::now() - t0);
  const v1::MapStats built = StatsOf(*service, id);
  Check(built.voxels() >= uint64_t(absl::GetFlag(FLAGS_min_big_voxels)),
        absl::StrCat("the 1 cm map has ", built.voxels(), " voxels, fewer than --min_big_voxels=",
                     absl::GetFlag(FLAGS_min_big_voxels), " (raise --big_frames)"));

  Progress("full snapshot");
  t0 = Clock::now();
  service->SnapshotAll();
  const double full_s = Seconds(Clock::now() - t0);
  const SnapshotContents first = ReadSnapshotContents(*store, id);
  Check(StatsOf(*service, id).snapshot_position() == uint64_t(big),
        "the full snapshot was not written");

  // Incremental snapshots: after `extra` frames of new space (the next poses), then after
  // `extra` frames re-observing mapped space (poses 0.. again, new sequences: same voxels,
  // heavier).
  struct Incremental {
    const char* what;
    uint64_t new_voxels = 0;
    size_t changed = 0, added = 0, total = 0;
    uint64_t bytes = 0;
    double seconds = 0;
  };
  std::vector<Incremental> increments;
  SnapshotContents before = first, latest;
  for (const char* what : {"new space", "revisited space"}) {
    const bool revisit = increments.size() == 1;
    Progress(absl::StrCat("incremental snapshot after ", extra, " frames of ", what));
    const uint64_t voxels_before = StatsOf(*service, id).voxels();
    if (revisit) {
      IntegrateFrames(*service, id, 0, extra, frames, /*sequence0=*/big + extra);
    } else {
      IntegrateFrames(*service, id, big, extra, frames);
    }
    Incremental inc{what};
    inc.new_voxels = StatsOf(*service, id).voxels() - voxels_before;
    t0 = Clock::now();
    service->SnapshotAll();
    inc.seconds = Seconds(Clock::now() - t0);
    latest = ReadSnapshotContents(*store, id);
    for (const auto& [name, hash] : latest.hashes) {
      auto it = before.hashes.find(name);
      if (it == before.hashes.end()) {
        ++inc.added;
        inc.bytes += hash.second;
      } else if (it->second.first != hash.first) {
        ++inc.changed;
        inc.bytes += hash.second;
      }
    }
    inc.total = latest.hashes.size();
    increments.push_back(inc);
    before = latest;
    before.chunks.clear();
  }
  SnapshotContents& second = latest;
  const int total_frames = big + 2 * extra;
  const uint64_t voxels = StatsOf(*service, id).voxels();
  Check(StatsOf(*service, id).snapshot_position() == uint64_t(total_frames),
        "the incremental snapshots were not written");
  // The server's journal records, for the replay store.
  std::vector<storage::JournalRecord> journal;
  uint64_t journal_bytes = 0;
  if (absl::Status s = store->ReadJournal(id, 0, std::numeric_limits<size_t>::max(),
                                          [&](const storage::JournalRecord& r) {
                                            journal.push_back(r);
                                            journal_bytes += r.payload.size();
                                            return absl::OkStatus();
                                          });
      !s.ok()) {
    Die(s.ToString());
  }
  Check(journal.size() == size_t(total_frames),
        absl::StrCat("journal holds ", journal.size(), " records, want ", total_frames));
  service.reset();
  store.reset();  // closes the database: the WAL is checkpointed into maps.sqlite
  const uint64_t db_bytes = FileBytes(db) + FileBytes(db + "-wal");

  // --- Reload: a fresh store and service over the same file (the snapshot covers it all).
  Progress("reload (Open + Recover)");
  t0 = Clock::now();
  store = OpenStore(db);
  service = std::make_unique<server::MapService>(ServiceOptions(store.get()));
  if (absl::Status s = service->Recover(); !s.ok()) Die(s.ToString());
  const double reload_s = Seconds(Clock::now() - t0);
  const v1::MapStats reloaded = StatsOf(*service, id);
  Check(reloaded.voxels() == voxels,
        absl::StrCat("reload: ", reloaded.voxels(), " voxels, want ", voxels));
  // --- Export (with and without the journal) and import of the reloaded map.
  const std::vector<Transfer> transfers = MeasureTransfers(*service, id, data_dir, voxels);
  service.reset();
  store.reset();

  // --- The same snapshot alone in a store: what maps.sqlite costs per voxel without the
  // journal (the chunks' bytes as written, in SQLite pages).
  const std::string snap_db = data_dir + "/snapshot-only/maps.sqlite";
  fs::create_directories(data_dir + "/snapshot-only");
  {
    std::unique_ptr<storage::SqliteMapStore> s = OpenStore(snap_db);
    const std::string options =
        server::ToProto(*server::ResolveMapOptions(create.options())).SerializeAsString();
    if (absl::Status st = s->CreateMap(id, options); !st.ok()) Die(st.ToString());
    if (absl::Status st = s->WriteSnapshot(id, 0, second.chunks, {}); !st.ok()) {
      Die(st.ToString());
    }
  }
  const uint64_t snap_db_bytes = FileBytes(snap_db) + FileBytes(snap_db + "-wal");

  // --- Journal replay: a store with the same journal records and no snapshot.
  const std::string replay_db = data_dir + "/replay/maps.sqlite";
  fs::create_directories(data_dir + "/replay");
  {
    std::unique_ptr<storage::SqliteMapStore> s = OpenStore(replay_db);
    const std::string options =
        server::ToProto(*server::ResolveMapOptions(create.options())).SerializeAsString();
    if (absl::Status st = s->CreateMap(id, options); !st.ok()) Die(st.ToString());
    absl::StatusOr<uint64_t> last = s->AppendJournal(id, journal);
    if (!last.ok()) Die(last.status().ToString());
  }
  journal.clear();
  Progress("journal replay (Open + Recover, no snapshot)");
  t0 = Clock::now();
  store = OpenStore(replay_db);
  service = std::make_unique<server::MapService>(ServiceOptions(store.get()));
  if (absl::Status s = service->Recover(); !s.ok()) Die(s.ToString());
  const double replay_s = Seconds(Clock::now() - t0);
  const v1::MapStats replayed = StatsOf(*service, id);
  Check(replayed.voxels() == voxels && replayed.frames() == uint64_t(total_frames),
        absl::StrCat("replay: ", replayed.voxels(), " voxels and ", replayed.frames(),
                     " frames, want ", voxels, " and ", total_frames));
  v1::DeleteMapRequest del;  // nothing left for the service's final snapshot to write
  del.set_name(absl::StrCat("maps/", id));
  (void)service->DeleteMap(del);
  service.reset();
  store.reset();

  // --- OctoMap: the stored voxels' centres, log-odds from the weight, mean colour.
  Progress("OctoMap trees from the stored voxels");
  octomap::OcTree tree(res);
  octomap::ColorOcTree color_tree(res);
  const float hit = tree.getProbHitLog();
  uint64_t decoded = 0, key_mismatch = 0;
  t0 = Clock::now();
  for (const storage::Chunk& c : second.chunks) {
    if (c.key.volume != "rgb") continue;
    const server::ChunkCoord coord{int32_t(c.key.x), int32_t(c.key.y), int32_t(c.key.z)};
    VoxelBatch<RGBWeightedVoxel> batch;
    if (absl::Status s = server::DecodeVoxelChunk<RGBWeightedVoxel>(coord, c.bytes, &batch);
        !s.ok()) {
      Die(s.ToString());
    }
    for (const auto& item : batch.items()) {
      const octomap::point3d centre(float((item.key.x + 0.5) * res),
                                    float((item.key.y + 0.5) * res),
                                    float((item.key.z + 0.5) * res));
      octomap::OcTreeKey key;
      if (!tree.coordToKeyChecked(centre, key) || key[0] != item.key.x + 32768 ||
          key[1] != item.key.y + 32768 || key[2] != item.key.z + 32768) {
        ++key_mismatch;
        continue;
      }
      // weight hits at once (what weight single hits give, clamped alike); lazy: inner
      // nodes once at the end.
      const float log_odds = item.data.weight * hit;
      tree.updateNode(key, log_odds, /*lazy_eval=*/true);
      octomap::ColorOcTreeNode* n = color_tree.updateNode(key, log_odds, /*lazy_eval=*/true);
      auto channel = [](float v) { return uint8_t(std::clamp<long>(std::lround(v), 0, 255)); };
      n->setColor(channel(item.data.Red()), channel(item.data.Green()), channel(item.data.Blue()));
      ++decoded;
    }
  }
  tree.updateInnerOccupancy();
  color_tree.updateInnerOccupancy();
  const double octo_build_s = Seconds(Clock::now() - t0);
  second.chunks.clear();
  second.chunks.shrink_to_fit();
  Check(decoded == voxels && key_mismatch == 0,
        absl::StrCat("stored voxels: ", decoded, " decoded (", key_mismatch,
                     " outside OctoMap's key range), want ", voxels));
  Check(OctoVoxels(tree) == voxels && OctoVoxels(color_tree) == voxels,
        absl::StrCat("OctoMap trees hold ", OctoVoxels(tree), " / ", OctoVoxels(color_tree),
                     " voxels, want ", voxels));
  const std::string bt = data_dir + "/map.bt", ot = data_dir + "/map.ot";
  Progress("OctoMap write / read");
  // writeBinary converts to maximum likelihood and prunes (lossless for occupancy).
  t0 = Clock::now();
  if (!tree.writeBinary(bt)) Die("writeBinary failed");
  SyncFile(bt);
  const double bt_write_s = Seconds(Clock::now() - t0);
  const size_t bt_leaves = tree.getNumLeafNodes();
  // Not pruned: ColorOcTree's prune ignores colour, so it would drop voxels' colours.
  t0 = Clock::now();
  if (!color_tree.write(ot)) Die("ColorOcTree::write failed");
  SyncFile(ot);
  const double ot_write_s = Seconds(Clock::now() - t0);
  const size_t ot_leaves = color_tree.getNumLeafNodes();
  tree.clear();
  color_tree.clear();

  t0 = Clock::now();
  octomap::OcTree bt_read(res);
  if (!bt_read.readBinary(bt)) Die("readBinary failed");
  const double bt_read_s = Seconds(Clock::now() - t0);
  Check(OctoVoxels(bt_read) == voxels,
        absl::StrCat(".bt read back: ", OctoVoxels(bt_read), " voxels, want ", voxels));
  bt_read.clear();
  t0 = Clock::now();
  std::unique_ptr<octomap::AbstractOcTree> ot_any(octomap::AbstractOcTree::read(ot));
  const double ot_read_s = Seconds(Clock::now() - t0);
  auto* ot_read = dynamic_cast<octomap::ColorOcTree*>(ot_any.get());
  if (ot_read == nullptr) Die(".ot did not read back as a ColorOcTree");
  Check(OctoVoxels(*ot_read) == voxels,
        absl::StrCat(".ot read back: ", OctoVoxels(*ot_read), " voxels, want ", voxels));
  ot_any.reset();
  const uint64_t bt_bytes = FileBytes(bt), ot_bytes = FileBytes(ot);
  const uint64_t bt_zstd = ZstdBytes(bt, 1), ot_zstd = ZstdBytes(ot, 1);

  // --- Tables.
  const double v = double(voxels), mv = v / 1e6;
  const double full_per_voxel = full_s / double(built.voxels());
  std::printf(
      "\n### Persistence of a %.1f M voxel map (1 cm, colour) beside OctoMap %s\n\n"
      "%d frames integrated in-process with the journal on (%.1f frames/s, %.0f voxels per "
      "frame), full snapshot; %d frames of new space (the next poses), incremental snapshot; "
      "%d frames re-observing mapped space (the first poses again), incremental snapshot. "
      "Then the OctoMap trees get the stored %llu voxels (checked, before writing and after "
      "reading back).\n\n",
      mv, SKIMAP_OCTOMAP_VERSION, big, big / build_s, double(built.voxels()) / big, extra, extra,
      static_cast<unsigned long long>(voxels));
  std::printf(
      "| write | map voxels | chunks written | bytes written | time s | M voxels/s | time per "
      "voxel / SkiMap full snapshot's |\n|---|---|---|---|---|---|---|\n");
  std::printf(
      "| SkiMap full snapshot (SnapshotAll: encode + one SQLite commit, fsynced) | "
      "%llu | %zu | %.1f MB | %.2f | %.2f | 1.00× |\n",
      static_cast<unsigned long long>(built.voxels()), first.hashes.size(),
      (first.rgb_bytes + first.other_bytes) / 1e6, full_s, built.voxels() / full_s / 1e6);
  for (const Incremental& inc : increments) {
    std::printf(
        "| SkiMap incremental snapshot after %d frames of %s (+%llu voxels) | – | %zu "
        "(%zu changed, %zu new, of %zu) | %.1f MB | %.2f | – | – |\n",
        extra, inc.what, static_cast<unsigned long long>(inc.new_voxels), inc.changed + inc.added,
        inc.changed, inc.added, inc.total, inc.bytes / 1e6, inc.seconds);
  }
  std::printf(
      "| OctoMap OcTree::writeBinary (.bt) + fdatasync | %llu | – | %.1f MB | %.2f | "
      "%.2f | %.2f× |\n",
      static_cast<unsigned long long>(voxels), bt_bytes / 1e6, bt_write_s, mv / bt_write_s,
      bt_write_s / v / full_per_voxel);
  std::printf(
      "| OctoMap ColorOcTree::write (.ot) + fdatasync | %llu | – | %.1f MB | %.2f | "
      "%.2f | %.2f× |\n\n",
      static_cast<unsigned long long>(voxels), ot_bytes / 1e6, ot_write_s, mv / ot_write_s,
      ot_write_s / v / full_per_voxel);

  const double chunk_bytes = double(second.rgb_bytes);
  std::printf(
      "| on disk | bytes | bytes / voxel | zstd -1 bytes / voxel | / SkiMap chunks | holds |\n"
      "|---|---|---|---|---|---|\n");
  std::printf(
      "| SkiMap snapshot: rgb chunks (%llu chunks, zstd -1 inside) | %.1f MB | %.2f | "
      "– | 1.00× | key, colour sums, weight (4 floats) per voxel |\n",
      static_cast<unsigned long long>(second.rgb_chunks), chunk_bytes / 1e6, chunk_bytes / v);
  std::printf(
      "| maps.sqlite holding only this snapshot | %.1f MB | %.2f | – | %.2f× | + frame "
      "index chunks (%.1f kB), SQLite pages |\n",
      snap_db_bytes / 1e6, snap_db_bytes / v, snap_db_bytes / chunk_bytes,
      second.other_bytes / 1e3);
  std::printf(
      "| maps.sqlite as the server left it | %.1f MB | %.2f | – | %.2f× | + the journal "
      "(%d frame records, %.1f MB) |\n",
      db_bytes / 1e6, db_bytes / v, db_bytes / chunk_bytes, total_frames, journal_bytes / 1e6);
  std::printf(
      "| OctoMap .bt (OcTree, max-likelihood, pruned: %zu leaves) | %.1f MB | %.2f | "
      "%.2f | %.2f× | occupied or not: 2 bits per child of each inner node |\n",
      bt_leaves, bt_bytes / 1e6, bt_bytes / v, bt_zstd / v, bt_bytes / chunk_bytes);
  std::printf(
      "| OctoMap .ot (ColorOcTree, %zu leaves) | %.1f MB | %.2f | %.2f | %.2f× | "
      "log-odds (float) + colour (3 bytes) + child mask (1 byte) per node, inner nodes "
      "included |\n\n",
      ot_leaves, ot_bytes / 1e6, ot_bytes / v, ot_zstd / v, ot_bytes / chunk_bytes);

  const double reload_rate = v / reload_s;
  std::printf("| load | time s | M voxels/s | time / SkiMap reload |\n|---|---|---|---|\n");
  std::printf(
      "| SkiMap reload: SqliteMapStore::Open + MapService::Recover (snapshot) | %.2f | "
      "%.2f | 1.00× |\n",
      reload_s, reload_rate / 1e6);
  std::printf("| OctoMap OcTree::readBinary (.bt) | %.2f | %.2f | %.2f× |\n", bt_read_s,
              mv / bt_read_s, bt_read_s / reload_s);
  std::printf("| OctoMap AbstractOcTree::read (.ot, ColorOcTree) | %.2f | %.2f | %.2f× |\n",
              ot_read_s, mv / ot_read_s, ot_read_s / reload_s);
  std::printf(
      "| SkiMap journal replay (no snapshot): %d frames, %.1f frames/s (their "
      "ingestion: %.1f frames/s) | %.2f | %.2f | %.2f× |\n\n",
      total_frames, total_frames / replay_s, big / build_s, replay_s, mv / replay_s,
      replay_s / reload_s);
  std::printf(
      "(OctoMap trees built from the decoded chunks in %.1f s, not part of any "
      "figure.)\n\n",
      octo_build_s);
  std::printf(
      "| export / import (one portable file, docs/formats.md) | file MB | time s | MB/s | "
      "M voxels/s | time / OctoMap .ot %s |\n|---|---|---|---|---|---|\n",
      "write or read");
  for (const Transfer& t : transfers) {
    const bool import = t.what.rfind("import", 0) == 0;
    std::printf("| SkiMap %s | %.1f | %.2f | %.1f | %.2f | %.2f× (.ot %s %.2f s) |\n",
                t.what.c_str(), t.bytes / 1e6, t.seconds, t.bytes / 1e6 / t.seconds, mv / t.seconds,
                t.seconds / (import ? ot_read_s : ot_write_s), import ? "read" : "write",
                import ? ot_read_s : ot_write_s);
  }
  std::printf("\n");
  std::printf("| floor (issue 10) | measured | result |\n|---|---|---|\n");
  std::printf("| reload ≥ 5 M voxels/s | %.2f M voxels/s | %s |\n", reload_rate / 1e6,
              reload_rate >= 5e6 ? "PASS" : "**FAIL**");
  std::printf("| reloaded voxel count equals the map's | %llu = %llu | %s |\n",
              static_cast<unsigned long long>(reloaded.voxels()),
              static_cast<unsigned long long>(voxels),
              reloaded.voxels() == voxels ? "PASS" : "**FAIL**");
  std::fflush(stdout);
}

}  // namespace
}  // namespace skimap::bench

int main(int argc, char** argv) {
  using namespace skimap;
  using namespace skimap::bench;
  absl::ParseCommandLine(argc, argv);
  const Clock::time_point start = Clock::now();
  const std::vector<std::string> parts = absl::StrSplit(absl::GetFlag(FLAGS_parts), ',');
  auto wanted = [&](const char* p) {
    return std::find(parts.begin(), parts.end(), p) != parts.end();
  };

  std::string data_dir = absl::GetFlag(FLAGS_data_dir);
  const bool temporary = data_dir.empty();
  if (temporary) {
    std::string pattern = "/tmp/storage_bench.XXXXXX";
    if (::mkdtemp(pattern.data()) == nullptr) Die("mkdtemp failed");
    data_dir = pattern;
  }
  fs::create_directories(data_dir);

  struct utsname host;
  ::uname(&host);
  std::printf(
      "Run of %s on `%s`: %u CPUs (%s), %s GB RAM; load average at start %s. Data dir %s: %s "
      "(%s).\n",
      UtcNow().c_str(), host.nodename, std::thread::hardware_concurrency(),
      FirstLineOf("/proc/cpuinfo", "model name").c_str(), Fmt(MemoryGb(), 0).c_str(),
      LoadAverage().c_str(), data_dir.c_str(), MountOf(data_dir).c_str(),
      FilesystemOf(data_dir).c_str());

  const int ingest_poses = wanted("ingest") ? std::max(absl::GetFlag(FLAGS_frames),
                                                       3 * 7 + absl::GetFlag(FLAGS_frames) / 2)
                                            : 0;
  const int persist_poses =
      wanted("persist") ? absl::GetFlag(FLAGS_big_frames) + absl::GetFlag(FLAGS_incremental_frames)
                        : 0;
  const int poses = std::max(ingest_poses, persist_poses);
  Progress(absl::StrCat("rendering ", poses, " frames (640x480 depth + colour)"));
  const std::vector<cv::Mat> textures = LoadTextures(absl::GetFlag(FLAGS_textures));
  const std::vector<Encoded> frames = RenderFrames(poses, textures);
  double depth_bytes = 0, color_bytes = 0, record_bytes = 0;
  for (size_t k = 0; k < frames.size(); ++k) {
    depth_bytes += frames[k].depth_png.size();
    color_bytes += frames[k].color_jpeg.size();
    record_bytes += MakeFrame("maps/ingest0", k, frames[k]).ByteSizeLong();
  }
  std::printf(
      "\nFrames: %d poses 5 m apart along an aisle (shelves, crates, a wall 3 m away), "
      "640×480; depth PNG16 %.0f kB, colour JPEG %.0f kB per frame (mean).\n",
      poses, depth_bytes / 1024 / poses, color_bytes / 1024 / poses);
  std::fflush(stdout);

  if (wanted("ingest")) RunIngestionPart(data_dir, frames, record_bytes / poses);
  if (wanted("persist")) RunPersistPart(data_dir, frames);

  std::printf("\nTotal run %.0f s; load average at the end %s.\n", Seconds(Clock::now() - start),
              LoadAverage().c_str());
  if (!absl::GetFlag(FLAGS_keep_data)) {
    if (temporary) {
      fs::remove_all(data_dir);
    } else {
      for (const char* sub : {"ingest", "big", "snapshot-only", "replay"}) {
        fs::remove_all(data_dir + "/" + sub);
      }
      fs::remove(data_dir + "/map.bt");
      fs::remove(data_dir + "/map.ot");
    }
  }
  if (failures > 0) {
    std::fprintf(stderr, "storage_bench: %d check(s) failed\n", failures.load());
    return 1;
  }
  return 0;
}
