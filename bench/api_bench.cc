// api_bench: REST against gRPC on the same skimapd, the same map and the same requests
// (issue 12; docs/benchmarks.md, "REST vs gRPC"). A plain program, not a test; a markdown
// table on stdout, progress on stderr:
//
//   build/release/bench/api_bench [--poses=32] [--requests=40] [--seconds=4] [--clients=4]
//
// One real skimapd process (tests/common/skimapd_process.h) on loopback sockets, a map of
// 2 cm voxels made from --poses frames (640x480, RAW_U16) of the analytic floor-and-box
// scene of the server tests (tests/common/synthetic_scene.h), seen from a circle of poses
// 3 m around the box. Then, for each request, side by side:
//   grid        GetOccupancyGrid of the whole map: gRPC (protobuf) vs REST JSON
//               (GET /v1/maps/m/occupancyGrid) and REST PGM (?format=pgm)
//   voxels 10k  GetVoxels, the first page of 10 000 voxels: gRPC vs REST JSON and REST
//               protobuf (Accept: application/x-protobuf, what the viewer reads)
//   voxels 100k GetVoxels, the first page of 100 000 voxels: the same three
// Latency: --requests calls one after the other (gRPC and REST alternating), from the send
// to the decoded message (protobuf parse for gRPC and REST protobuf, JSON parse into the
// same message for REST JSON, PGM decoded into grid cells); for REST also the part until the
// body was in (the server's work, JSON printing included, and the transfer). Throughput:
// --clients threads calling for --seconds each, requests/s and decoded MB/s (the gRPC
// message's size).
//
// Checks (CHECK FAILED and exit 1): every REST answer decodes to exactly the gRPC answer
// (the same message for JSON; the same size and cells for PGM), before and during timing.
#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/message_differencer.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "tests/common/skimapd_process.h"
#include "tests/common/synthetic_scene.h"

// After Eigen (synthetic_scene.h): httplib pulls <resolv.h>, whose `_res` macro breaks
// Eigen's headers.
#include <httplib.h>

ABSL_FLAG(int, poses, 32, "frames streamed into the map (one per pose on the circle)");
ABSL_FLAG(int, requests, 40, "sequential requests per protocol and request (latency)");
ABSL_FLAG(double, seconds, 4, "seconds per protocol and request (throughput)");
ABSL_FLAG(int, clients, 4, "concurrent client threads (throughput)");

namespace skimap::bench {
namespace {

using Clock = std::chrono::steady_clock;
double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

[[noreturn]] void CheckFailed(const std::string& what) {
  std::fprintf(stderr, "CHECK FAILED: %s\n", what.c_str());
  std::exit(1);
}

// The time the last REST call of this thread took until its body was in (before decoding);
// negative after a gRPC call (whose decoding is inside the call).
thread_local double http_ms = -1;

// One way to ask for one thing: returns the answer decoded into a message (the gRPC reply's
// type), or fails the run.
using Fetch = std::function<void(google::protobuf::Message* out)>;

template <class T>
void ParseJsonInto(const httplib::Result& r, const std::string& what, T* out) {
  if (!r || r->status != 200) CheckFailed(absl::StrCat(what, ": HTTP ", r ? r->status : 0));
  if (!google::protobuf::util::JsonStringToMessage(r->body, out).ok()) {
    CheckFailed(absl::StrCat(what, ": the reply is not a ", out->GetTypeName()));
  }
}

// A ROS map_server PGM reply (P5, trinary: 0 occupied, 254 free, 205 unknown; the image's
// first row is the grid's top, +y) decoded into an OccupancyGrid with the geometry of the
// X-Skimap-* headers.
void DecodePgm(const httplib::Result& r, v1::OccupancyGrid* out) {
  if (!r || r->status != 200) CheckFailed("grid PGM: no 200 reply");
  int width = 0, height = 0, max = 0, offset = 0;
  if (std::sscanf(r->body.c_str(), "P5 %d %d %d%n", &width, &height, &max, &offset) != 3 ||
      max != 255) {
    CheckFailed("grid PGM: bad header");
  }
  const char* pixels = r->body.data() + offset + 1;  // one whitespace after maxval
  if (r->body.size() != size_t(offset + 1) + size_t(width) * height) {
    CheckFailed("grid PGM: size");
  }
  std::string cells(size_t(width) * height, '\0');
  for (int row = 0; row < height; ++row) {
    for (int x = 0; x < width; ++x) {
      const uint8_t p = uint8_t(pixels[size_t(row) * width + x]);
      const int8_t cell = p == 0 ? 100 : p == 254 ? 0 : -1;
      cells[size_t(height - 1 - row) * width + x] = char(cell);
    }
  }
  out->Clear();
  double resolution = 0;
  if (!absl::SimpleAtod(r->get_header_value("X-Skimap-Resolution"), &resolution)) {
    CheckFailed("grid PGM: X-Skimap-Resolution");
  }
  out->set_resolution(resolution);
  out->set_width(width);
  out->set_height(height);
  out->set_data(std::move(cells));
}

struct Row {
  std::string request, protocol;
  double p50 = 0, p99 = 0, mean = 0;  // ms
  double http_p50 = -1;               // ms until the REST body was in (the rest of p50: decoding)
  double rps = 0, mbps = 0;
  size_t wire_bytes = 0;  // reply body on the wire
};

double Percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(p * double(v.size() - 1) + 0.5))];
}

// Compares `got` with the reference; for PGM grids only the cells and size (the PGM has
// no origin or frame count).
void Compare(const google::protobuf::Message& want, const google::protobuf::Message& got,
             bool cells_only, const std::string& what) {
  if (cells_only) {
    const auto& w = static_cast<const v1::OccupancyGrid&>(want);
    const auto& g = static_cast<const v1::OccupancyGrid&>(got);
    if (w.width() != g.width() || w.height() != g.height() || w.data() != g.data() ||
        std::abs(w.resolution() - g.resolution()) > 1e-12) {
      CheckFailed(absl::StrCat(what, ": the PGM's cells differ from gRPC's grid"));
    }
    return;
  }
  if (!google::protobuf::util::MessageDifferencer::Equals(want, got)) {
    CheckFailed(absl::StrCat(what, ": the decoded answer differs from gRPC's"));
  }
}

struct Way {
  std::string protocol;
  std::function<std::unique_ptr<google::protobuf::Message>()> make;  // an empty reply
  // Fetches with the given per-thread client index; sets wire bytes.
  std::function<void(int client, google::protobuf::Message* out, size_t* wire)> fetch;
  bool cells_only = false;
};

}  // namespace

int Main() {
  const char* binary = SKIMAPD_PATH;
  testing::SkimapdProcess server(binary, {"--worker_threads=2", "--http_threads=8"});
  if (absl::Status s = server.Start(); !s.ok()) CheckFailed(s.ToString());
  const int clients = absl::GetFlag(FLAGS_clients);

  // The map.
  auto maps = client::MapClient::Connect(server.address());
  v1::CreateMapRequest create;
  create.set_map_id("m");
  create.mutable_options()->set_resolution(0.02);
  if (!maps->CreateMap(create).ok()) CheckFailed("CreateMap");
  const testing::SyntheticCamera camera{640, 480, 525, 525, 319.5, 239.5};
  const int poses = absl::GetFlag(FLAGS_poses);
  {
    std::unique_ptr<client::FrameStream> stream = maps->OpenFrameStream({.window = 8}, "maps/m");
    for (int k = 0; k < poses; ++k) {
      const double a = 2 * M_PI * k / poses;
      const Eigen::Vector3d at(0.5 + 3 * std::cos(a), 3 * std::sin(a), 1.5);
      const Eigen::Isometry3d pose = testing::LookingAlong(at, Eigen::Vector3d(0.5, 0, 0.25) - at);
      if (!stream->Send(testing::MakeFrame("maps/m", k + 1, pose, camera)).ok()) break;
    }
    absl::StatusOr<std::vector<v1::FrameAck>> acks = stream->Finish();
    if (!acks.ok() || int(acks->size()) != poses) CheckFailed("streaming the frames");
    for (const v1::FrameAck& a : *acks) {
      if (a.code() != 0) CheckFailed(a.message());
    }
  }
  absl::StatusOr<v1::Map> map = maps->GetMap("maps/m");
  if (!map.ok()) CheckFailed("GetMap");
  std::fprintf(stderr, "map maps/m: %llu voxels from %d frames\n",
               (unsigned long long)map->stats().voxels(), poses);

  // Per-thread clients: one gRPC channel and one keep-alive HTTP connection each.
  std::vector<std::unique_ptr<client::MapClient>> grpc;
  std::vector<std::unique_ptr<httplib::Client>> http;
  for (int i = 0; i < clients; ++i) {
    grpc.push_back(client::MapClient::Connect(
        server.address(), {.timeout = absl::Seconds(60), .transfer_timeout = absl::Minutes(1)}));
    http.push_back(std::make_unique<httplib::Client>("127.0.0.1", server.http_port()));
    http.back()->set_keep_alive(true);
    http.back()->set_read_timeout(60);
  }

  v1::GetOccupancyGridRequest grid_request;
  grid_request.set_map("maps/m");
  auto voxels_request = [](int page) {
    v1::GetVoxelsRequest r;
    r.set_map("maps/m");
    r.set_page_size(page);
    return r;
  };
  struct Request {
    std::string name;
    std::vector<Way> ways;  // ways[0]: gRPC, the reference
  };
  std::vector<Request> requests;
  {
    Request grid{"grid (whole map)"};
    grid.ways.push_back({"gRPC", [] { return std::make_unique<v1::OccupancyGrid>(); },
                         [&](int c, google::protobuf::Message* out, size_t* wire) {
                           grpc::ClientContext context;
                           http_ms = -1;
                           auto* g = static_cast<v1::OccupancyGrid*>(out);
                           if (!grpc[c]->stub().GetOccupancyGrid(&context, grid_request, g).ok()) {
                             CheckFailed("gRPC GetOccupancyGrid");
                           }
                           *wire = g->ByteSizeLong();
                         }});
    grid.ways.push_back({"REST JSON", [] { return std::make_unique<v1::OccupancyGrid>(); },
                         [&](int c, google::protobuf::Message* out, size_t* wire) {
                           const Clock::time_point t0 = Clock::now();
                           httplib::Result r = http[c]->Get("/v1/maps/m/occupancyGrid");
                           http_ms = Ms(Clock::now() - t0);
                           ParseJsonInto(r, "REST grid", static_cast<v1::OccupancyGrid*>(out));
                           *wire = r->body.size();
                         }});
    grid.ways.push_back({"REST PGM", [] { return std::make_unique<v1::OccupancyGrid>(); },
                         [&](int c, google::protobuf::Message* out, size_t* wire) {
                           const Clock::time_point t0 = Clock::now();
                           httplib::Result r = http[c]->Get("/v1/maps/m/occupancyGrid?format=pgm");
                           http_ms = Ms(Clock::now() - t0);
                           DecodePgm(r, static_cast<v1::OccupancyGrid*>(out));
                           *wire = r->body.size();
                         },
                         /*cells_only=*/true});
    requests.push_back(std::move(grid));
  }
  for (int page : {10000, 100000}) {
    Request voxels{absl::StrCat("voxels, page of ", page / 1000, "k")};
    const v1::GetVoxelsRequest request = voxels_request(page);
    voxels.ways.push_back({"gRPC", [] { return std::make_unique<v1::GetVoxelsResponse>(); },
                           [&, request](int c, google::protobuf::Message* out, size_t* wire) {
                             grpc::ClientContext context;
                             http_ms = -1;
                             auto* v = static_cast<v1::GetVoxelsResponse*>(out);
                             if (!grpc[c]->stub().GetVoxels(&context, request, v).ok()) {
                               CheckFailed("gRPC GetVoxels");
                             }
                             *wire = v->ByteSizeLong();
                           }});
    voxels.ways.push_back(
        {"REST JSON", [] { return std::make_unique<v1::GetVoxelsResponse>(); },
         [&, page](int c, google::protobuf::Message* out, size_t* wire) {
           const Clock::time_point t0 = Clock::now();
           httplib::Result r = http[c]->Get(absl::StrCat("/v1/maps/m/voxels?pageSize=", page));
           http_ms = Ms(Clock::now() - t0);
           ParseJsonInto(r, "REST voxels", static_cast<v1::GetVoxelsResponse*>(out));
           *wire = r->body.size();
         }});
    // The same route in the protobuf binary encoding (Accept: application/x-protobuf), as
    // the viewer reads voxel pages: the same bytes as gRPC's answer, over HTTP/1.1.
    voxels.ways.push_back(
        {"REST protobuf", [] { return std::make_unique<v1::GetVoxelsResponse>(); },
         [&, page](int c, google::protobuf::Message* out, size_t* wire) {
           const Clock::time_point t0 = Clock::now();
           httplib::Result r = http[c]->Get(absl::StrCat("/v1/maps/m/voxels?pageSize=", page),
                                            {{"Accept", "application/x-protobuf"}});
           http_ms = Ms(Clock::now() - t0);
           if (!r || r->status != 200 ||
               r->get_header_value("Content-Type") != "application/x-protobuf" ||
               !out->ParseFromString(r->body)) {
             CheckFailed("REST protobuf voxels");
           }
           *wire = r->body.size();
         }});
    requests.push_back(std::move(voxels));
  }

  const int n = absl::GetFlag(FLAGS_requests);
  const double seconds = absl::GetFlag(FLAGS_seconds);
  std::vector<Row> rows;
  for (Request& req : requests) {
    // The reference answer, and every way's answer checked against it.
    std::unique_ptr<google::protobuf::Message> want = req.ways[0].make();
    size_t wire = 0;
    req.ways[0].fetch(0, want.get(), &wire);
    const double decoded_mb = double(want->ByteSizeLong()) / 1e6;
    std::vector<Row> req_rows(req.ways.size());
    std::vector<std::vector<double>> latencies(req.ways.size()), http_parts(req.ways.size());
    for (size_t w = 0; w < req.ways.size(); ++w) {
      std::unique_ptr<google::protobuf::Message> got = req.ways[w].make();
      req.ways[w].fetch(0, got.get(), &req_rows[w].wire_bytes);
      Compare(*want, *got, req.ways[w].cells_only, req.name + " " + req.ways[w].protocol);
    }
    // Latency, the ways alternating.
    for (int i = 0; i < n; ++i) {
      for (size_t w = 0; w < req.ways.size(); ++w) {
        std::unique_ptr<google::protobuf::Message> got = req.ways[w].make();
        const Clock::time_point t0 = Clock::now();
        req.ways[w].fetch(0, got.get(), &wire);
        latencies[w].push_back(Ms(Clock::now() - t0));
        http_parts[w].push_back(http_ms);
        Compare(*want, *got, req.ways[w].cells_only, req.name + " " + req.ways[w].protocol);
      }
    }
    // Throughput.
    for (size_t w = 0; w < req.ways.size(); ++w) {
      std::atomic<long> done{0};
      const Clock::time_point start = Clock::now();
      const Clock::time_point end = start + std::chrono::duration_cast<Clock::duration>(
                                                std::chrono::duration<double>(seconds));
      std::vector<std::thread> threads;
      for (int c = 0; c < clients; ++c) {
        threads.emplace_back([&, c] {
          size_t bytes = 0;
          while (Clock::now() < end) {
            std::unique_ptr<google::protobuf::Message> got = req.ways[w].make();
            req.ways[w].fetch(c, got.get(), &bytes);
            if (done.fetch_add(1) % 16 == 0) {
              Compare(*want, *got, req.ways[w].cells_only, req.name + " " + req.ways[w].protocol);
            }
          }
        });
      }
      for (std::thread& t : threads) t.join();
      const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
      Row& row = req_rows[w];
      row.request = req.name;
      row.protocol = req.ways[w].protocol;
      row.p50 = Percentile(latencies[w], 0.5);
      row.p99 = Percentile(latencies[w], 0.99);
      row.http_p50 = Percentile(http_parts[w], 0.5);
      double sum = 0;
      for (double l : latencies[w]) sum += l;
      row.mean = sum / double(latencies[w].size());
      row.rps = double(done.load()) / elapsed;
      row.mbps = row.rps * decoded_mb;
      std::fprintf(stderr, "%s %s: p50 %.2f ms, %.1f req/s\n", row.request.c_str(),
                   row.protocol.c_str(), row.p50, row.rps);
    }
    rows.insert(rows.end(), req_rows.begin(), req_rows.end());
  }

  std::printf(
      "map: %llu voxels (2 cm), %d frames; %d sequential requests per way (latency), "
      "%d clients x %.0f s (throughput)\n\n",
      (unsigned long long)map->stats().voxels(), poses, n, clients, seconds);
  std::printf(
      "| request | protocol | reply bytes | p50 ms | of which HTTP ms | p99 ms | req/s | "
      "decoded MB/s | p50 / gRPC | req/s / gRPC |\n|---|---|---|---|---|---|---|---|---|---|\n");
  const Row* reference = nullptr;
  for (const Row& r : rows) {
    if (r.protocol == "gRPC") reference = &r;
    const std::string http_part = r.http_p50 < 0 ? "-" : absl::StrFormat("%.2f", r.http_p50);
    std::printf("| %s | %s | %zu | %.2f | %s | %.2f | %.1f | %.1f | %.2f | %.2f |\n",
                r.request.c_str(), r.protocol.c_str(), r.wire_bytes, r.p50, http_part.c_str(),
                r.p99, r.rps, r.mbps, r.p50 / reference->p50, r.rps / reference->rps);
  }
  server.Stop();
  return 0;
}

}  // namespace skimap::bench

int main(int argc, char** argv) {
  absl::ParseCommandLine(argc, argv);
  return skimap::bench::Main();
}
