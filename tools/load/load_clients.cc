#include "tools/load/load_clients.h"

#include <httplib.h>

#include <chrono>
#include <condition_variable>
#include <random>

#include "absl/strings/str_cat.h"

namespace skimap::load {
namespace {

using Clock = std::chrono::steady_clock;
constexpr int kW = 160, kH = 120;

double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

}  // namespace

Position RobotPosition(int index, uint64_t frames) {
  const uint64_t step = frames % 10000;  // 100 x 100 positions, then over again
  const double row = static_cast<double>(step / 100);
  const double col = static_cast<double>(step % 100);
  return {.x = 60.0 * index + 0.5 * (static_cast<uint64_t>(row) % 2 ? 99 - col : col),
          .y = 0.5 * row};
}

v1::Frame RobotFrame(const std::string& map, int index, uint64_t sequence) {
  const Position p = RobotPosition(index, sequence);
  v1::Frame f;
  f.set_map(map);
  f.set_sequence(sequence);
  // Looking straight down: 180 degrees about x (camera z -> world -z).
  f.mutable_pose()->mutable_rotation()->set_x(1);
  f.mutable_pose()->mutable_translation()->set_x(p.x);
  f.mutable_pose()->mutable_translation()->set_y(p.y);
  f.mutable_pose()->mutable_translation()->set_z(1.5);
  v1::CameraIntrinsics& k = *f.mutable_intrinsics();
  k.set_width(kW);
  k.set_height(kH);
  k.set_fx(140);
  k.set_fy(140);
  k.set_cx(kW / 2.0);
  k.set_cy(kH / 2.0);
  f.set_depth_encoding(v1::DEPTH_ENCODING_RAW_U16);
  std::string depth(size_t{kW} * kH * 2, '\0');
  for (int v = 0; v < kH; ++v) {
    for (int u = 0; u < kW; ++u) {
      // The floor 1.5 m below, with a 20 cm ramp across the image (boxes, steps).
      const uint16_t mm = static_cast<uint16_t>(1500 - (u * 200) / kW);
      const size_t i = 2 * (static_cast<size_t>(v) * kW + static_cast<size_t>(u));
      depth[i] = static_cast<char>(mm & 0xff);
      depth[i + 1] = static_cast<char>(mm >> 8);
    }
  }
  f.set_depth(std::move(depth));
  f.set_depth_scale(0.001);
  return f;
}

RobotStream::RobotStream(v1::MapService::Stub* stub, const Options& options)
    : stub_(stub), options_(options) {}

RobotStream::~RobotStream() { Stop(); }

void RobotStream::Start() {
  thread_ = std::thread([this] { Run(); });
}

void RobotStream::Stop() {
  stop_ = true;
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void RobotStream::Run() {
  grpc::ClientContext ctx;
  ctx.AddMetadata("x-request-id", absl::StrCat("load-robot-", options_.index));
  auto stream = stub_->StreamFrames(&ctx);
  auto fail = [this](const std::string& what) {
    errors_.fetch_add(1);
    std::lock_guard<std::mutex> lock(mu_);
    if (first_error_.empty()) first_error_ = what;
  };
  std::thread reader([&] {
    v1::FrameAck ack;
    while (stream->Read(&ack)) {
      if (ack.code() != 0) {
        fail(absl::StrCat("frame ", ack.sequence(), ": code ", ack.code(), " ", ack.message()));
      } else {
        acked_.fetch_add(1);
      }
      std::lock_guard<std::mutex> lock(mu_);
      --in_flight_;
      cv_.notify_all();
    }
  });
  const auto period = std::chrono::duration<double>(1.0 / options_.fps);
  Clock::time_point next = Clock::now();
  for (uint64_t seq = 0; !stop_; ++seq) {
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait(lock, [&] { return stop_ || in_flight_ < options_.window; });
      if (stop_) break;
      ++in_flight_;
    }
    if (!stream->Write(RobotFrame(options_.map, options_.index, seq))) {
      fail("stream broken on write");
      break;
    }
    next += std::chrono::duration_cast<Clock::duration>(period);
    std::this_thread::sleep_until(next);
  }
  stream->WritesDone();
  reader.join();
  if (grpc::Status s = stream->Finish(); !s.ok()) {
    fail(absl::StrCat("stream finished with ", s.error_code(), " ", s.error_message()));
  }
}

QueryClient::QueryClient(v1::MapService::Stub* stub, const std::vector<RobotStream*>& robots,
                         const std::vector<std::string>& maps, const Options& options)
    : stub_(stub), robots_(robots), maps_(maps), options_(options) {}

QueryClient::~QueryClient() { Stop(); }

void QueryClient::Start() {
  thread_ = std::thread([this] { Run(); });
}

void QueryClient::Stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void QueryClient::Run() {
  std::mt19937 random(options_.seed);
  std::unique_ptr<httplib::Client> http;
  if (options_.rest) {
    http = std::make_unique<httplib::Client>("127.0.0.1", options_.http_port);
    http->set_read_timeout(30);
  }
  const std::string transport = options_.rest ? "rest" : "grpc";
  for (int n = 0; !stop_; ++n) {
    const size_t r = random() % maps_.size();
    const std::string& map = maps_[r];
    const std::string map_id = map.substr(5);  // "maps/" prefix
    const Position p = robots_[r]->position();
    const int kind = n % 3;
    const char* kinds[] = {"grid", "voxels", "radius"};
    const std::string name = absl::StrCat(transport, " ", kinds[kind]);
    std::string error;
    const Clock::time_point start = Clock::now();
    if (!options_.rest) {
      grpc::ClientContext ctx;
      ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
      grpc::Status s;
      if (kind == 0) {
        v1::GetOccupancyGridRequest q;
        q.set_map(map);
        q.mutable_region()->set_min_x(p.x - 5);
        q.mutable_region()->set_min_y(p.y - 5);
        q.mutable_region()->set_max_x(p.x + 5);
        q.mutable_region()->set_max_y(p.y + 5);
        v1::OccupancyGrid grid;
        s = stub_->GetOccupancyGrid(&ctx, q, &grid);
      } else if (kind == 1) {
        v1::GetVoxelsRequest q;
        q.set_map(map);
        q.set_page_size(5000);
        *q.mutable_box()->mutable_min() = [&] {
          v1::Vec3 v;
          v.set_x(p.x - 2);
          v.set_y(p.y - 2);
          v.set_z(-1);
          return v;
        }();
        q.mutable_box()->mutable_max()->set_x(p.x + 2);
        q.mutable_box()->mutable_max()->set_y(p.y + 2);
        q.mutable_box()->mutable_max()->set_z(1);
        v1::GetVoxelsResponse page;
        s = stub_->GetVoxels(&ctx, q, &page);
      } else {
        v1::RadiusSearchRequest q;
        q.set_map(map);
        q.mutable_center()->set_x(p.x);
        q.mutable_center()->set_y(p.y);
        q.set_radius(1.0);
        v1::RadiusSearchResponse found;
        s = stub_->RadiusSearch(&ctx, q, &found);
      }
      if (!s.ok()) error = absl::StrCat(name, ": code ", s.error_code(), " ", s.error_message());
    } else {
      httplib::Result res = [&] {
        if (kind == 0) {
          return http->Get(absl::StrCat("/v1/maps/", map_id, "/occupancyGrid?region=", p.x - 5, ",",
                                        p.y - 5, ",", p.x + 5, ",", p.y + 5));
        }
        if (kind == 1) {
          return http->Get(absl::StrCat("/v1/maps/", map_id, "/voxels?pageSize=5000&box=", p.x - 2,
                                        ",", p.y - 2, ",-1,", p.x + 2, ",", p.y + 2, ",1"));
        }
        return http->Post(absl::StrCat("/v1/maps/", map_id, ":radiusSearch"),
                          absl::StrCat(R"({"center": {"x": )", p.x, R"(, "y": )", p.y,
                                       R"(, "z": 0}, "radius": 1.0})"),
                          "application/json");
      }();
      if (!res) {
        error = absl::StrCat(name, ": ", httplib::to_string(res.error()));
      } else if (res->status != 200) {
        error = absl::StrCat(name, ": HTTP ", res->status, " ", res->body.substr(0, 200));
      }
    }
    log_.latency_ms[name].push_back(Ms(Clock::now() - start));
    if (!error.empty()) {
      ++log_.errors[name];
      if (log_.first_error.empty()) log_.first_error = error;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(options_.think_ms));
  }
}

}  // namespace skimap::load
