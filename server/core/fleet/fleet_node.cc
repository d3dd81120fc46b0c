#include "server/core/fleet/fleet_node.h"

#include <cstdio>
#include <map>

#include "absl/strings/str_cat.h"
#include "server/core/fleet/redirect.h"
#include "server/core/logging/log.h"

namespace skimap::server {
namespace {

void SetUnixMs(int64_t ms, google::protobuf::Timestamp* t) {
  t->set_seconds(ms / 1000);
  t->set_nanos(int32_t(ms % 1000) * 1000000);
}

}  // namespace

FleetNode::FleetNode(storage::LeaseStore* leases, const Options& options)
    : leases_(leases), options_(options) {}

FleetNode::~FleetNode() { StopThread(); }

void FleetNode::OnLost(std::function<void(const std::string&)> lost) { lost_ = std::move(lost); }

absl::Status FleetNode::Start() {
  absl::StatusOr<std::vector<std::string>> first =
      leases_->Heartbeat(options_.address, options_.lease_ttl);
  if (!first.ok()) return first.status();
  heartbeat_ = std::thread([this] { HeartbeatLoop(); });
  return absl::OkStatus();
}

void FleetNode::StopThread() {
  {
    MutexLock lock(&mu_);
    stopping_ = true;
  }
  cv_.SignalAll();
  if (heartbeat_.joinable()) heartbeat_.join();
}

absl::Status FleetNode::Leave() {
  StopThread();
  {
    MutexLock lock(&mu_);
    owned_.clear();
  }
  return leases_->Leave();
}

void FleetNode::HeartbeatLoop() {
  const auto period = absl::ToChronoMilliseconds(options_.lease_ttl / 3);
  MutexLock lock(&mu_);
  while (!stopping_) {
    const auto deadline = std::chrono::steady_clock::now() + period;
    while (!stopping_ && cv_.WaitUntil(&mu_, deadline)) {
    }
    if (stopping_) break;
    lock.Unlock();
    absl::StatusOr<std::vector<std::string>> lost =
        leases_->Heartbeat(options_.address, options_.lease_ttl);
    if (!lost.ok()) {
      // The leases run out locally; writes stay fenced in the store meanwhile.
      LogWarning(absl::StrCat("fleet heartbeat: ", lost.status().ToString()));
    } else {
      for (const std::string& id : *lost) Lost(id);
    }
    lock.Lock();
  }
}

void FleetNode::Lost(const std::string& id) {
  {
    MutexLock lock(&mu_);
    if (owned_.erase(id) == 0) return;
  }
  LogWarning(absl::StrCat("lost the lease of map ", id, " to another node"));
  if (lost_) lost_(id);
}

bool FleetNode::Own(const std::string& id, int64_t token, bool loaded) {
  MutexLock lock(&mu_);
  auto [it, inserted] = owned_.try_emplace(id, token);
  if (inserted) return !loaded;
  if (it->second == token) return false;
  it->second = token;
  return true;
}

absl::StatusOr<bool> FleetNode::Claim(const std::string& id) {
  if (std::optional<storage::LeaseStore::Held> held = leases_->HeldLease(id)) {
    // Held without a claim: created or imported here (the registry has it, current).
    return Own(id, held->token, /*loaded=*/true);
  }
  absl::StatusOr<storage::Lease> lease = leases_->AcquireLease(id, options_.lease_ttl);
  if (absl::IsNotFound(lease.status())) Lost(id);
  if (!lease.ok()) return lease.status();
  if (lease->node != node_id()) {
    Lost(id);  // if it was served here, it is not any more
    return RedirectError(id, lease->node, lease->address);
  }
  // Renewed with the same token after it ran out locally: nobody else took it, the copy
  // here is current. A new token, or a map not served here yet: load it from the store.
  return Own(id, lease->token, /*loaded=*/false);
}

absl::StatusOr<std::map<std::string, MapOwnership::Owner>> FleetNode::Owners() {
  absl::StatusOr<std::vector<storage::Lease>> leases = leases_->ListLeases();
  if (!leases.ok()) return leases.status();
  std::map<std::string, Owner> out;
  for (const storage::Lease& l : *leases) {
    const bool here = l.node == node_id() && leases_->HeldLease(l.map).has_value();
    out[l.map] = Owner{l.node, l.address, l.live, here};
  }
  return out;
}

absl::StatusOr<v1::ListNodesResponse> FleetNode::ListNodes() {
  absl::StatusOr<std::vector<storage::NodeInfo>> nodes =
      leases_->ListNodes(10 * options_.lease_ttl);
  if (!nodes.ok()) return nodes.status();
  absl::StatusOr<std::vector<storage::Lease>> leases = leases_->ListLeases();
  if (!leases.ok()) return leases.status();
  std::map<std::string, std::vector<std::string>> maps;
  for (const storage::Lease& l : *leases) {
    if (l.live) maps[l.node].push_back(absl::StrCat("maps/", l.map));
  }
  v1::ListNodesResponse response;
  for (const storage::NodeInfo& n : *nodes) {
    v1::Node* node = response.add_nodes();
    node->set_id(n.id);
    node->set_address(n.address);
    SetUnixMs(n.started_unix_ms, node->mutable_start_time());
    SetUnixMs(n.heartbeat_unix_ms, node->mutable_heartbeat_time());
    node->set_live(n.live);
    for (const std::string& m : maps[n.id]) node->add_maps(m);
    node->set_answering(n.id == node_id());
  }
  return response;
}

}  // namespace skimap::server
