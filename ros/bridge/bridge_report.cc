#include "ros/bridge/bridge_report.h"

#include <ros/ros.h>
#include <sys/resource.h>

#include <algorithm>
#include <fstream>
#include <vector>

namespace skimap::rosbridge {
namespace {

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5))];
}

}  // namespace

void WriteReport(const SenderStats& s, uint64_t no_pose, uint64_t bad, double wall,
                 const std::string& stats_file) {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const double cpu = usage.ru_utime.tv_sec + usage.ru_utime.tv_usec / 1e6 + usage.ru_stime.tv_sec +
                     usage.ru_stime.tv_usec / 1e6;
  ROS_INFO(
      "skimap-ros: %llu frames offered, %llu sent, %llu acknowledged, %llu failed, "
      "%llu dropped (queue full), %llu without a pose, %llu bad, %llu lost; latency "
      "p50 %.1f ms p95 %.1f ms; CPU %.1f s in %.1f s",
      (unsigned long long)s.offered, (unsigned long long)s.sent, (unsigned long long)s.acked_ok,
      (unsigned long long)s.acked_failed, (unsigned long long)s.dropped,
      (unsigned long long)no_pose, (unsigned long long)bad, (unsigned long long)s.lost,
      Percentile(s.latencies_ms, 0.5), Percentile(s.latencies_ms, 0.95), cpu, wall);
  if (!stats_file.empty()) {
    std::ofstream out(stats_file);
    out << "{\"offered\": " << s.offered << ", \"sent\": " << s.sent
        << ", \"acked\": " << s.acked_ok << ", \"failed\": " << s.acked_failed
        << ", \"dropped\": " << s.dropped << ", \"no_pose\": " << no_pose << ", \"bad\": " << bad
        << ", \"lost\": " << s.lost << ", \"latency_p50_ms\": " << Percentile(s.latencies_ms, 0.5)
        << ", \"latency_p95_ms\": " << Percentile(s.latencies_ms, 0.95)
        << ", \"latency_max_ms\": " << Percentile(s.latencies_ms, 1.0)
        << ", \"cpu_seconds\": " << cpu << ", \"wall_seconds\": " << wall << "}\n";
  }
}

}  // namespace skimap::rosbridge
