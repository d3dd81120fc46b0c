#include "server/http/map_events.h"

#include <chrono>
#include <memory>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/http/rest_messages.h"

namespace skimap::server {

// What a stream's wake tells its HTTP thread. Shared with the map's watcher, which may
// run until the watch is destroyed.
struct MapEvents::Stream {
  uint64_t changes = 0;  // guarded by MapEvents::mu_
};

MapEvents::MapEvents(MapService& maps, const Options& options) : maps_(maps), options_(options) {}

MapEvents::~MapEvents() { Stop(); }

void MapEvents::Stop() {
  MutexLock lock(&mu_);
  stopping_ = true;
  changed_.SignalAll();
}

int MapEvents::open_streams() {
  MutexLock lock(&mu_);
  return open_;
}

std::string ServerSentEvent(absl::string_view type, absl::string_view data) {
  return absl::StrCat("event: ", type, "\ndata: ", data, "\n\n");
}

absl::StatusOr<RestReply> MapEvents::Open(const RestCall& call) {
  const std::string name = absl::StrCat("maps/", call.path.at("map"));
  {
    MutexLock lock(&mu_);
    if (stopping_) return absl::UnavailableError("the server is shutting down");
    if (open_ >= options_.max_clients) {
      return absl::ResourceExhaustedError(
          absl::StrCat("events: ", open_, " event streams are open, the limit is ",
                       options_.max_clients, " (skimapd --http_max_event_streams)"));
    }
    ++open_;
  }
  // The slot is taken from here on; it is given back when the stream (or this reply,
  // unsent) is gone.
  auto slot = std::shared_ptr<void>(nullptr, [this](void*) {
    MutexLock lock(&mu_);
    --open_;
  });
  auto stream = std::make_shared<Stream>();
  v1::GetMapRequest request;
  request.set_name(name);
  absl::StatusOr<std::unique_ptr<MapService::MapWatch>> watch =
      maps_.WatchMap(request, [this, stream] {
        MutexLock lock(&mu_);
        ++stream->changes;
        changed_.SignalAll();
      });
  if (!watch.ok()) return watch.status();
  RestReply reply;
  reply.content_type = "text/event-stream";
  reply.headers.emplace_back("Cache-Control", "no-cache");
  reply.headers.emplace_back("X-Accel-Buffering", "no");  // proxies: do not buffer
  std::shared_ptr<MapService::MapWatch> shared_watch = *std::move(watch);
  reply.stream = [this, name, stream, slot,
                  shared_watch](const std::function<bool(std::string_view)>& write) {
    Run(name, *stream, *shared_watch, write);
  };
  return reply;
}

void MapEvents::Run(const std::string& name, Stream& stream, MapService::MapWatch& watch,
                    const std::function<bool(std::string_view)>& write) {
  v1::GetMapRequest request;
  request.set_name(name);
  uint64_t sent = UINT64_MAX;  // the first event goes out at once
  for (;;) {
    uint64_t changes = 0;
    bool heartbeat = false;
    {
      MutexLock lock(&mu_);
      const auto deadline =
          std::chrono::steady_clock::now() + absl::ToChronoMilliseconds(options_.heartbeat);
      while (!stopping_ && stream.changes == sent) {
        if (!changed_.WaitUntil(&mu_, deadline) && std::chrono::steady_clock::now() >= deadline) {
          heartbeat = true;
          break;
        }
      }
      if (stopping_) return;
      changes = stream.changes;
    }
    if (heartbeat && changes == sent) {
      if (!write(": keep-alive\n\n")) return;
      continue;
    }
    sent = changes;
    if (watch.gone()) {
      write(ServerSentEvent("gone", absl::StrCat("{\"name\":\"", name, "\"}")));
      return;
    }
    absl::StatusOr<v1::Map> map = maps_.GetMap(request);
    if (!map.ok()) {
      write(ServerSentEvent("gone", absl::StrCat("{\"name\":\"", name, "\"}")));
      return;
    }
    if (!write(ServerSentEvent("map", ToJson(*map)))) return;
  }
}

}  // namespace skimap::server
