// Echo: a client's string as it may appear in an error message.
//
//   return absl::InvalidArgumentError(absl::StrCat("name: ", Echo(name), " is not ..."));
//
// Error messages travel back in response headers (gRPC status, HTTP reason), whose size is
// limited: a 100 kB name echoed whole overflows them and the client gets a transport error
// instead of the answer. Echo quotes the text, escapes anything unprintable, and keeps at
// most kMaxEchoBytes of it, saying how much was cut: "\"abc...\" (+99940 bytes)".
//
// Thread safety: pure function.
#ifndef BASE_ECHO_H_
#define BASE_ECHO_H_

#include <cstddef>
#include <string>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"

namespace skimap {

inline constexpr size_t kMaxEchoBytes = 64;

inline std::string Echo(absl::string_view client_text) {
  const absl::string_view kept = client_text.substr(0, kMaxEchoBytes);
  std::string out = absl::StrCat("\"", absl::CHexEscape(kept), "\"");
  if (kept.size() < client_text.size()) {
    absl::StrAppend(&out, " (+", client_text.size() - kept.size(), " bytes)");
  }
  return out;
}

}  // namespace skimap

#endif  // BASE_ECHO_H_
