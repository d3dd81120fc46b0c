// Page tokens: opaque, checksummed, and bound to the query that issued them.
//
//   const uint32_t query = QueryFingerprint(map.incarnation(), "GetVoxels", box_bytes);
//   response.set_next_page_token(EncodePageToken(query, position));
//   absl::StatusOr<std::string> position = DecodePageToken(request.page_token(), query);
//
// A token is base64url(version 1 | query fingerprint u32 | position bytes | CRC-32C u32).
// DecodePageToken refuses, with InvalidArgument naming "page_token", a token that is not
// base64url, truncated or altered (the CRC), or issued for another query: another map,
// the same map id deleted and created again, another box, filter or RPC (the fingerprint).
// Tokens are integrity checks against mistakes, not secrets: they are not encrypted.
//
// Thread safety: pure functions.
#ifndef SERVER_CORE_COMMON_PAGE_TOKEN_H_
#define SERVER_CORE_COMMON_PAGE_TOKEN_H_

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"

namespace skimap::server {

// A fingerprint of everything a page depends on but its position: the map's incarnation,
// the RPC, and its filters encoded as bytes by the caller.
uint32_t QueryFingerprint(uint64_t incarnation, const std::string& rpc, const std::string& filters);

std::string EncodePageToken(uint32_t query, const std::string& position);
// The position of a token EncodePageToken(query, position) made; InvalidArgument otherwise.
absl::StatusOr<std::string> DecodePageToken(const std::string& token, uint32_t query);

}  // namespace skimap::server

#endif  // SERVER_CORE_COMMON_PAGE_TOKEN_H_
