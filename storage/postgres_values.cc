// postgres.h: PgParams and PgResult, the values of statements and their answers.
#include <libpq-fe.h>

#include "storage/postgres.h"

namespace skimap::storage {
namespace {

// Type OIDs of the parameters (pg_type.h).
constexpr unsigned int kInt8Oid = 20;
constexpr unsigned int kTextOid = 25;
constexpr unsigned int kByteaOid = 17;
constexpr unsigned int kBoolOid = 16;

std::string BigEndian(uint64_t v, int bytes) {
  std::string out(bytes, '\0');
  for (int i = bytes - 1; i >= 0; --i, v >>= 8) out[i] = char(v & 0xff);
  return out;
}

}  // namespace

PgParams& PgParams::Int(int64_t v) {
  values_.push_back(BigEndian(uint64_t(v), 8));
  types_.push_back(kInt8Oid);
  return *this;
}
PgParams& PgParams::Text(std::string_view v) {
  values_.emplace_back(v);
  types_.push_back(kTextOid);
  return *this;
}
PgParams& PgParams::Bytes(std::string_view v) {
  values_.emplace_back(v);
  types_.push_back(kByteaOid);
  return *this;
}
PgParams& PgParams::Bool(bool v) {
  values_.emplace_back(1, v ? '\1' : '\0');
  types_.push_back(kBoolOid);
  return *this;
}

PgResult& PgResult::operator=(PgResult&& o) noexcept {
  if (this != &o) {
    if (r_ != nullptr) PQclear(r_);
    r_ = o.r_;
    o.r_ = nullptr;
  }
  return *this;
}
PgResult::~PgResult() {
  if (r_ != nullptr) PQclear(r_);
}
int PgResult::rows() const { return PQntuples(r_); }
int64_t PgResult::affected() const {
  const char* n = PQcmdTuples(r_);
  return (n == nullptr || *n == '\0') ? 0 : std::strtoll(n, nullptr, 10);
}
bool PgResult::IsNull(int row, int col) const { return PQgetisnull(r_, row, col) != 0; }
int64_t PgResult::Int(int row, int col) const {
  const auto* p = reinterpret_cast<const unsigned char*>(PQgetvalue(r_, row, col));
  const int n = PQgetlength(r_, row, col);  // 8 (int8), 4 (int4) or 2 (int2)
  uint64_t v = 0;
  for (int i = 0; i < n; ++i) v = v << 8 | p[i];
  if (n < 8 && n > 0 && (p[0] & 0x80)) v |= ~uint64_t{0} << (8 * n);  // sign-extend
  return int64_t(v);
}
bool PgResult::Bool(int row, int col) const { return PQgetvalue(r_, row, col)[0] != 0; }
std::string PgResult::tag() const { return PQcmdStatus(r_); }
std::string PgResult::Bytes(int row, int col) const {
  return std::string(PQgetvalue(r_, row, col), PQgetlength(r_, row, col));
}

}  // namespace skimap::storage
