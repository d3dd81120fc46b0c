#include "server/core/fleet/redirect.h"

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"

namespace skimap::server {
namespace {

constexpr char kRedirectUrl[] = "type.googleapis.com/skimap.v1.MapRedirect";

}  // namespace

absl::Status RedirectError(const std::string& id, const std::string& node,
                           const std::string& address) {
  v1::MapRedirect r;
  r.set_map(absl::StrCat("maps/", id));
  r.set_node(node);
  r.set_address(address);
  absl::Status s = absl::UnavailableError(
      address.empty() ? absl::StrCat("map ", r.map(), " is served by node ", node,
                                     ", which has not registered its address yet; retry")
                      : absl::StrCat("map ", r.map(), " is served by node ", node, " at ", address,
                                     "; send the request there (see the status details)"));
  s.SetPayload(kRedirectUrl, absl::Cord(r.SerializeAsString()));
  return s;
}

std::optional<v1::MapRedirect> RedirectOf(const absl::Status& status) {
  absl::optional<absl::Cord> payload = status.GetPayload(kRedirectUrl);
  if (!payload.has_value()) return std::nullopt;
  v1::MapRedirect r;
  if (!r.ParseFromString(std::string(*payload)) || r.address().empty()) return std::nullopt;
  return r;
}

std::string StatusDetailsOf(const absl::Status& status, const std::string& message) {
  std::optional<v1::MapRedirect> r = RedirectOf(status);
  if (!r.has_value()) return "";
  v1::StatusDetails details;
  details.set_code(static_cast<int>(status.code()));
  details.set_message(message);
  details.add_details()->PackFrom(*r);
  return details.SerializeAsString();
}

}  // namespace skimap::server
