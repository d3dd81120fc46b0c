// Fuzz target: every request validator of the map service core (server/core/maps/): CreateMap
// options and ids, map names, ListMaps paging, frames (envelope, decoding, pose within the
// map), UpdatePoses, and the query validators (regions, boxes, bands, weights, radii, page
// sizes and tokens, reply limits), through a real in-memory MapService with two maps that
// hold a few frames ("maps/m" plain, "maps/c" carving).
//
// Input: u8 RPC (taken modulo 10: CreateMap, GetMap, ListMaps, DeleteMap, IntegrateFrame,
// UpdatePoses, GetOccupancyGrid, GetHeightMap, GetVoxels, RadiusSearch), then the request
// message serialized. Every call must answer (the callbacks run), an error must carry a
// message, and the two fixture maps must still answer afterwards. Maps the input creates
// are deleted again, and the fixture maps are never deleted, so runs stay independent.
#include <cstdint>
#include <future>
#include <memory>
#include <string>

#include "server/core/maps/map_service.h"
#include "tests/fuzz/fuzz_input.h"

namespace skimap::fuzz {
namespace {

using server::MapService;

// A 32 x 24 frame of a wall 1 m ahead, for the fixture maps.
v1::Frame WallFrame(const std::string& map, uint64_t sequence) {
  v1::Frame f;
  f.set_map(map);
  f.set_sequence(sequence);
  f.mutable_pose()->mutable_rotation()->set_w(1);
  f.mutable_pose()->mutable_translation()->set_x(0.01 * double(sequence));
  v1::CameraIntrinsics& k = *f.mutable_intrinsics();
  k.set_width(32);
  k.set_height(24);
  k.set_fx(30);
  k.set_fy(30);
  k.set_cx(16);
  k.set_cy(12);
  f.set_depth_encoding(v1::DEPTH_ENCODING_RAW_U16);
  f.set_depth(std::string(32 * 24 * 2, '\0'));
  for (int i = 0; i < 32 * 24; ++i) {
    (*f.mutable_depth())[2 * i] = static_cast<char>(1000 & 0xff);
    (*f.mutable_depth())[2 * i + 1] = static_cast<char>(1000 >> 8);
  }
  f.set_depth_scale(0.001);
  return f;
}

void CheckError(const absl::Status& s) {
  if (!s.ok() && s.message().empty()) Fail("an error without a message");
}

absl::Status Integrate(MapService& service, const v1::Frame& frame) {
  std::promise<absl::Status> done;
  service.IntegrateFrame(std::make_shared<v1::Frame>(frame), [&](absl::StatusOr<v1::FrameAck> ack) {
    done.set_value(ack.ok() ? absl::Status(absl::StatusCode(ack->code()), ack->message())
                            : ack.status());
  });
  return done.get_future().get();
}

MapService& Service() {
  static MapService* service = [] {
    auto* s = new MapService({.worker_threads = 1,
                              .queue_capacity = 4,
                              .max_frame_bytes = 1 << 20,
                              // As a deployment would: a 8192 x 8192 frame takes seconds.
                              .max_frame_pixels = 1 << 20,
                              .max_kept_frame_bytes = 16 << 20,
                              .max_maps = 16,
                              .max_reply_bytes = 1 << 20});
    for (const char* id : {"m", "c"}) {
      v1::CreateMapRequest create;
      create.set_map_id(id);
      create.mutable_options()->set_carve_free_space(id[0] == 'c');
      if (!s->CreateMap(create).ok()) Fail("fixture map not created");
      for (uint64_t seq = 0; seq < 3; ++seq) {
        if (!Integrate(*s, WallFrame(std::string("maps/") + id, seq)).ok()) {
          Fail("fixture frame not integrated");
        }
      }
    }
    return s;
  }();
  return *service;
}

template <class Request>
bool Parse(std::string_view bytes, Request* r) {
  return r->ParseFromArray(bytes.data(), static_cast<int>(bytes.size()));
}

bool IsFixture(const std::string& name) { return name == "maps/m" || name == "maps/c"; }

}  // namespace
}  // namespace skimap::fuzz

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace skimap;
  using namespace skimap::fuzz;
  FuzzInput in(data, size);
  const int rpc = in.U8() % 10;
  const std::string_view bytes = in.Rest();
  server::MapService& service = Service();
  switch (rpc) {
    case 0: {
      v1::CreateMapRequest r;
      if (!Parse(bytes, &r)) return 0;
      absl::StatusOr<v1::Map> map = service.CreateMap(r);
      CheckError(map.status());
      if (map.ok() && !IsFixture(map->name())) {
        v1::DeleteMapRequest del;
        del.set_name(map->name());
        if (!service.DeleteMap(del).ok()) Fail("a created map cannot be deleted");
      }
      break;
    }
    case 1: {
      v1::GetMapRequest r;
      if (Parse(bytes, &r)) CheckError(service.GetMap(r).status());
      break;
    }
    case 2: {
      v1::ListMapsRequest r;
      if (Parse(bytes, &r)) CheckError(service.ListMaps(r).status());
      break;
    }
    case 3: {
      v1::DeleteMapRequest r;
      if (Parse(bytes, &r) && !IsFixture(r.name())) CheckError(service.DeleteMap(r));
      break;
    }
    case 4: {
      v1::Frame r;
      if (Parse(bytes, &r)) CheckError(Integrate(service, r));
      break;
    }
    case 5: {
      auto r = std::make_shared<v1::UpdatePosesRequest>();
      if (!Parse(bytes, r.get())) return 0;
      std::promise<absl::Status> done;
      service.UpdatePoses(r, [&](absl::StatusOr<v1::UpdatePosesResponse> response) {
        done.set_value(response.status());
      });
      CheckError(done.get_future().get());
      break;
    }
    case 6: {
      v1::GetOccupancyGridRequest r;
      if (Parse(bytes, &r)) CheckError(service.GetOccupancyGrid(r).status());
      break;
    }
    case 7: {
      v1::GetHeightMapRequest r;
      if (Parse(bytes, &r)) CheckError(service.GetHeightMap(r).status());
      break;
    }
    case 8: {
      v1::GetVoxelsRequest r;
      if (Parse(bytes, &r)) CheckError(service.GetVoxels(r).status());
      break;
    }
    default: {
      v1::RadiusSearchRequest r;
      if (Parse(bytes, &r)) CheckError(service.RadiusSearch(r).status());
    }
  }
  for (const char* name : {"maps/m", "maps/c"}) {
    v1::GetMapRequest get;
    get.set_name(name);
    absl::StatusOr<v1::Map> map = service.GetMap(get);
    if (!map.ok() || map->stats().frames() < 3) Fail("a fixture map was lost");
  }
  return 0;
}
