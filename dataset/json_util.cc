#include "dataset/json_util.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include "absl/strings/str_cat.h"

namespace skimap::dataset::internal {

absl::StatusOr<std::string> ReadTextFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(path, ": cannot open"));
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

absl::Status WriteTextFile(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) return absl::InternalError(absl::StrCat(path, ": cannot open for writing"));
  out << text;
  out.close();
  if (!out) return absl::InternalError(absl::StrCat(path, ": write failed"));
  return absl::OkStatus();
}

absl::StatusOr<nlohmann::json> ReadJsonFile(const std::string& path) {
  absl::StatusOr<std::string> text = ReadTextFile(path);
  if (!text.ok()) return text.status();
  nlohmann::json j = nlohmann::json::parse(*text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return absl::InvalidArgumentError(absl::StrCat(path, ": invalid JSON"));
  return j;
}

absl::StatusOr<double> GetNumber(const nlohmann::json& obj, const std::string& key,
                                 const std::string& file, const std::string& where) {
  if (!obj.is_object() || !obj.contains(key)) {
    return absl::InvalidArgumentError(absl::StrCat(file, ": ", where, ".", key, ": missing"));
  }
  const nlohmann::json& v = obj[key];
  if (!v.is_number()) {
    return absl::InvalidArgumentError(absl::StrCat(file, ": ", where, ".", key, ": not a number"));
  }
  return v.get<double>();
}

absl::StatusOr<std::vector<double>> GetNumbers(const nlohmann::json& obj, const std::string& key,
                                               size_t n, const std::string& file,
                                               const std::string& where) {
  if (!obj.is_object() || !obj.contains(key)) {
    return absl::InvalidArgumentError(absl::StrCat(file, ": ", where, ".", key, ": missing"));
  }
  const nlohmann::json& v = obj[key];
  if (!v.is_array() || v.size() != n) {
    return absl::InvalidArgumentError(
        absl::StrCat(file, ": ", where, ".", key, ": expected an array of ", n, " numbers"));
  }
  std::vector<double> out;
  out.reserve(n);
  for (const nlohmann::json& e : v) {
    if (!e.is_number()) {
      return absl::InvalidArgumentError(
          absl::StrCat(file, ": ", where, ".", key, ": element is not a number"));
    }
    out.push_back(e.get<double>());
  }
  return out;
}

std::string FormatDouble(double v) {
  if (!std::isfinite(v)) return "0";
  if (v == 0) return "0.0";
  char buf[64];
  auto res = std::to_chars(buf, buf + sizeof(buf), v);
  std::string s(buf, res.ptr);
  if (s.find_first_of(".e") == std::string::npos) s += ".0";
  return s;
}

}  // namespace skimap::dataset::internal
