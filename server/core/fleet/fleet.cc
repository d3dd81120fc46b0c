#include "server/core/fleet/fleet.h"

#include <unistd.h>

#include <random>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace skimap::server {
namespace {

std::string NewNodeId() {
  char host[64] = {};
  if (gethostname(host, sizeof host - 1) != 0 || host[0] == '\0') std::snprintf(host, 8, "node");
  return absl::StrFormat("%s-%06x", host, std::random_device()() & 0xffffff);
}

}  // namespace

absl::StatusOr<std::unique_ptr<Fleet>> Fleet::Open(const std::string& store_url,
                                                   const FleetNode::Options& options,
                                                   storage::PostgresMapStore::Options store) {
  const std::string& a = options.address;
  if (a.empty() || absl::StartsWith(a, "0.0.0.0:") || absl::StartsWith(a, "[::]:") ||
      absl::EndsWith(a, ":0")) {
    return absl::InvalidArgumentError(
        absl::StrCat("advertise address '", a,
                     "': other nodes and clients must reach this node there (host:port, "
                     "not a wildcard host or port 0)"));
  }
  std::unique_ptr<Fleet> fleet(new Fleet());
  store.node_id = NewNodeId();
  store.lease_ttl = options.lease_ttl;
  absl::StatusOr<std::unique_ptr<storage::PostgresMapStore>> opened =
      storage::PostgresMapStore::Open(store_url, store);
  if (!opened.ok()) return opened.status();
  fleet->store_ = *std::move(opened);
  fleet->node_ = std::make_unique<FleetNode>(fleet->store_.get(), options);
  if (absl::Status s = fleet->node_->Start(); !s.ok()) return s;
  return fleet;
}

}  // namespace skimap::server
