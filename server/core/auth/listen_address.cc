#include "server/core/auth/listen_address.h"

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace skimap::server {

bool IsLoopbackAddress(const std::string& address) {
  if (absl::StartsWith(address, "unix:")) return true;  // a socket file: local by nature
  const size_t colon = address.rfind(':');
  if (colon == std::string::npos) return false;
  absl::string_view host(address.data(), colon);
  if (!absl::ConsumePrefix(&host, "ipv4:")) absl::ConsumePrefix(&host, "ipv6:");
  if (host == "localhost" || host == "[::1]") return true;
  // 127.0.0.0/8, written as four decimal octets.
  const std::vector<absl::string_view> octets = absl::StrSplit(host, '.');
  if (octets.size() != 4 || octets[0] != "127") return false;
  for (absl::string_view o : octets) {
    int v = 0;
    if (!absl::SimpleAtoi(o, &v) || v < 0 || v > 255) return false;
  }
  return true;
}

absl::Status CheckListenAddress(const std::string& address, bool insecure, const char* flag) {
  if (insecure || IsLoopbackAddress(address)) return absl::OkStatus();
  return absl::FailedPreconditionError(absl::StrCat(
      flag, " ", address,
      " listens beyond loopback without authentication; give --auth_tokens_file (bearer "
      "tokens, docs/operations.md) or pass --insecure to allow anyone who reaches the port to "
      "read and write every map"));
}

}  // namespace skimap::server
