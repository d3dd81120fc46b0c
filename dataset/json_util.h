// Internal helpers for reading and writing the dataset JSON files without exceptions.
// Not part of the public API. Thread safety: pure functions.
#ifndef SKIMAP_DATASET_JSON_UTIL_H_
#define SKIMAP_DATASET_JSON_UTIL_H_

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace skimap::dataset::internal {

// Reads and parses a JSON file. kNotFound if it does not exist, kInvalidArgument naming
// the file if it does not parse.
absl::StatusOr<nlohmann::json> ReadJsonFile(const std::string& path);

// Reads a whole file into a string. kNotFound if it cannot be opened.
absl::StatusOr<std::string> ReadTextFile(const std::string& path);

// Writes `text` to `path` (truncating). kInternal naming the file on failure.
absl::Status WriteTextFile(const std::string& path, const std::string& text);

// obj[key] as a number. Error "<file>: <where>.<key>: missing" / "not a number".
absl::StatusOr<double> GetNumber(const nlohmann::json& obj, const std::string& key,
                                 const std::string& file, const std::string& where);

// obj[key] as an array of exactly n numbers.
absl::StatusOr<std::vector<double>> GetNumbers(const nlohmann::json& obj, const std::string& key,
                                               size_t n, const std::string& file,
                                               const std::string& where);

// Formats a double for JSON: shortest representation that round-trips, deterministic.
std::string FormatDouble(double v);

}  // namespace skimap::dataset::internal

#endif  // SKIMAP_DATASET_JSON_UTIL_H_
