// skimap-ros's overhead, side by side with `skimap stream` on the same frames.
//
// Starts a rosmaster, skimapd and the bridge as processes (binaries of this build), and
// publishes the real 640x480 YCB-Video frames (cycled to --frames, tf per frame, depth
// 16UC1 + rgb8 + camera_info, stamped now) as a camera driver would:
//   - at --rate Hz (30: a Kinect / RealSense stream): does the bridge keep up (frames
//     acknowledged / published, dropped), its latency (frame reaches the node -> ack,
//     p50 / p95), and the CPU it takes (user + sys of the bridge process / wall time);
//   - at 2x and 3x that rate: the bridge's throughput, acknowledged frames per second of
//     publishing, with what it dropped (its queue full) and what never reached it (ROS's
//     own subscriber queues overflowing: published - offered).
// Then the same frames as ROS 1 bags through `skimap stream BAG`, colour raw and as JPEG
// (frames/s from the CLI's summary, the CPU per frame of the CLI and of skimapd). Every run writes
// into its own fresh 2 cm map. Exits 1 unless each bag's map holds every frame, the two bags'
// maps hold the same voxels with the same weights (only colour differs), and the bridge's
// 30 Hz map equals the raw bag's voxel for voxel.
//
// Usage: ros_bridge_bench [--frames=300] [--rate=30] [--keep_dir] [--bags_only] [--skimapd=PATH]
//                         [--scene=DIR]
//   --scene: the frames of another BOP or TUM scene (default: ycbv-0000's test/000000);
//   the bridge runs at rate, 2x and 3x; --bags_only: the bags through the CLI only;
//   --skimapd: another server binary (e.g. one built from an older commit);
//   --keep_dir leaves the bags, the data dir and the logs in /tmp/ros_bridge_bench_PID
#include <fcntl.h>
#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <tf2_msgs/TFMessage.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <tuple>

#include "absl/strings/str_cat.h"
#include "client/map_client.h"
#include "tests/common/free_port.h"
#include "tests/ros/ros_test_data.h"

extern char** environ;

namespace {

using skimap::testing::MmFrame;
namespace fs = std::filesystem;

pid_t Spawn(const std::vector<std::string>& args, const std::string& log) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (!log.empty()) {
    posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0600);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
  }
  pid_t pid = -1;
  if (posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&actions);
  return pid;
}

// Waits for `pid`; its CPU seconds (user + sys).
double Reap(pid_t pid) {
  int status = 0;
  rusage usage{};
  wait4(pid, &status, 0, &usage);
  return usage.ru_utime.tv_sec + usage.ru_utime.tv_usec / 1e6 + usage.ru_stime.tv_sec +
         usage.ru_stime.tv_usec / 1e6;
}

// CPU seconds (user + sys) a live process has used so far, from /proc/PID/stat.
double ProcessCpu(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t close = stat.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream fields(stat.substr(close + 2));
  std::string field;
  double ticks = 0;
  for (int i = 3; fields >> field; ++i) {
    if (i == 14 || i == 15) ticks += std::stod(field);
    if (i == 15) break;
  }
  return ticks / sysconf(_SC_CLK_TCK);
}

std::string Slurp(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

double JsonNumber(const std::string& json, const std::string& key) {
  std::smatch m;
  if (!std::regex_search(json, m, std::regex("\"" + key + "\": ([0-9.e+-]+)"))) return -1;
  return std::stod(m[1]);
}

MmFrame Nth(const std::vector<MmFrame>& frames, int i, ros::Time stamp) {
  MmFrame f = frames[i % frames.size()];
  f.stamp = stamp;
  return f;
}

struct BridgeRun {
  double rate = 0;
  int published = 0;
  double publish_seconds = 0;
  std::string stats;
  double cpu = 0;  // of the bridge process, its whole life
  uint64_t map_frames = 0;
};

BridgeRun RunBridge(const std::vector<MmFrame>& frames, int count, double rate,
                    const std::string& server, const fs::path& dir, const std::string& map,
                    skimap::client::MapClient& client) {
  BridgeRun run;
  run.rate = rate;
  const std::string ns = "/" + map;
  const pid_t bridge =
      Spawn({SKIMAP_ROS_PATH, "__ns:=" + ns, "__name:=skimap_ros", "_server:=" + server,
             "_map:=" + map, "_resolution:=0.02", "_fixed_frame:=world", "_publish_rate:=1.0",
             "_stats_file:=" + (dir / (map + ".json")).string()},
            (dir / (map + ".log")).string());
  ros::NodeHandle nh;
  ros::Publisher depth = nh.advertise<sensor_msgs::Image>(ns + "/depth/image", 30);
  ros::Publisher rgb = nh.advertise<sensor_msgs::Image>(ns + "/rgb/image", 30);
  ros::Publisher info = nh.advertise<sensor_msgs::CameraInfo>(ns + "/rgb/camera_info", 30);
  ros::Publisher tf = nh.advertise<tf2_msgs::TFMessage>("/tf", 100);
  ros::Publisher tf_static = nh.advertise<tf2_msgs::TFMessage>("/tf_static", 1, true);
  tf_static.publish(skimap::testing::LinkToOptical());
  for (int i = 0; i < 600 && (depth.getNumSubscribers() == 0 || rgb.getNumSubscribers() == 0 ||
                              info.getNumSubscribers() == 0 || tf.getNumSubscribers() == 0);
       ++i) {
    ros::WallDuration(0.05).sleep();
  }
  ros::WallDuration(1.0).sleep();
  // Messages built before the clock starts: the publisher costs what a driver's would.
  const ros::WallTime start = ros::WallTime::now();
  for (int i = 0; i < count; ++i) {
    if (rate > 0) {
      const ros::WallTime due = start + ros::WallDuration(i / rate);
      const ros::WallDuration wait = due - ros::WallTime::now();
      if (wait > ros::WallDuration(0)) wait.sleep();
    }
    const MmFrame f = Nth(frames, i, ros::Time::now());
    tf.publish(skimap::testing::WorldToLink(f));
    depth.publish(skimap::testing::DepthMessage(f));
    rgb.publish(skimap::testing::ColorMessage(f));
    info.publish(skimap::testing::InfoMessage(f));
  }
  run.publish_seconds = (ros::WallTime::now() - start).toSec();
  run.published = count;
  ros::WallDuration(2.0).sleep();  // the last frames' acks
  kill(bridge, SIGINT);
  run.cpu = Reap(bridge);
  run.stats = Slurp(dir / (map + ".json"));
  auto m = client.GetMap("maps/" + map);
  run.map_frames = m.ok() ? m->stats().frames() : 0;
  return run;
}

}  // namespace

int main(int argc, char** argv) {
  int count = 300;
  double rate = 30;
  bool keep_dir = false;
  bool bags_only = false;
  std::string skimapd_path = SKIMAPD_PATH;
  std::string scene = SKIMAP_BENCH_YCBV_SCENE;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--frames=", 0) == 0) count = std::stoi(a.substr(9));
    if (a.rfind("--rate=", 0) == 0) rate = std::stod(a.substr(7));
    if (a == "--keep_dir") keep_dir = true;
    if (a == "--bags_only") bags_only = true;
    if (a.rfind("--skimapd=", 0) == 0) skimapd_path = a.substr(10);
    if (a.rfind("--scene=", 0) == 0) scene = a.substr(8);
  }
  const std::vector<MmFrame> frames = skimap::testing::LoadMmFrames(scene);
  if (frames.empty()) {
    std::fprintf(stderr, "no frames in %s\n", scene.c_str());
    return 1;
  }
  const fs::path dir = fs::temp_directory_path() / absl::StrCat("ros_bridge_bench_", getpid());
  fs::create_directories(dir);
  const int master_port = skimap::testing::FreePort();
  setenv("ROS_MASTER_URI", absl::StrCat("http://127.0.0.1:", master_port).c_str(), 1);
  setenv("ROS_IP", "127.0.0.1", 1);
  const pid_t master =
      Spawn({"/usr/bin/python3", "/usr/bin/rosmaster", "--core", "-p", std::to_string(master_port)},
            (dir / "master.log").string());
  const std::string server = absl::StrCat("127.0.0.1:", skimap::testing::FreePort());
  const pid_t skimapd = Spawn({skimapd_path, "--address=" + server,
                               "--http_address=", "--data_dir=" + (dir / "data").string()},
                              (dir / "skimapd.log").string());
  auto client = skimap::client::MapClient::Connect(server);
  if (!client->WaitForServer(absl::Seconds(30)).ok()) {
    std::fprintf(stderr, "skimapd did not start\n");
    return 1;
  }
  ros::init(argc, argv, "ros_bridge_bench", ros::init_options::NoSigintHandler);
  for (int i = 0; i < 300 && !ros::master::check(); ++i) ros::WallDuration(0.1).sleep();
  ros::AsyncSpinner spinner(1);
  spinner.start();

  std::printf("ros_bridge_bench: %d frames of %dx%d from %s (%zu, cycled), 2 cm maps\n", count,
              frames[0].width, frames[0].height, scene.c_str(), frames.size());
  for (double r : {rate, 2 * rate, 3 * rate}) {
    if (bags_only) break;
    const std::string map = absl::StrCat("bridge", int(r));
    const BridgeRun run = RunBridge(frames, count, r, server, dir, map, *client);
    const double acked = JsonNumber(run.stats, "acked");
    const double wall = JsonNumber(run.stats, "wall_seconds");
    std::printf(
        "bridge at %.0f Hz: published %d in %.2f s (%.1f frames/s), reached the node %.0f, "
        "acknowledged %.0f (%.1f frames/s of publishing), dropped %.0f, no pose %.0f; latency "
        "p50 %.1f ms p95 %.1f ms max %.1f ms; bridge CPU %.2f s = %.1f ms/frame, %.0f%% of a "
        "core over its %.1f s; map frames %llu\n",
        r, run.published, run.publish_seconds, run.published / run.publish_seconds,
        JsonNumber(run.stats, "offered"), acked, acked / run.publish_seconds,
        JsonNumber(run.stats, "dropped"), JsonNumber(run.stats, "no_pose"),
        JsonNumber(run.stats, "latency_p50_ms"), JsonNumber(run.stats, "latency_p95_ms"),
        JsonNumber(run.stats, "latency_max_ms"), run.cpu, acked > 0 ? 1e3 * run.cpu / acked : 0,
        100 * run.cpu / wall, wall, (unsigned long long)run.map_frames);
  }

  // The same frames as ROS 1 bags, through the CLI: raw colour (rgb8, as the bridge got
  // it), then colour as image_transport's JPEG (what robots usually record).
  // Each bag's map must hold every frame (checked below).
  bool bags_whole = true;
  const auto stream_bag = [&](const std::string& name, bool jpeg_color) {
    const std::string bag_path = (dir / (name + ".bag")).string();
    {
      rosbag::Bag bag(bag_path, rosbag::bagmode::Write);
      bag.write("/tf_static", ros::Time(1000.0), skimap::testing::LinkToOptical());
      for (int i = 0; i < count; ++i) {
        const MmFrame f = Nth(frames, i, ros::Time(1000.0 + i / 30.0));
        bag.write("/tf", f.stamp, skimap::testing::WorldToLink(f));
        bag.write("/camera/color/camera_info", f.stamp, skimap::testing::InfoMessage(f));
        bag.write("/camera/depth/image_raw", f.stamp, skimap::testing::DepthMessage(f));
        if (jpeg_color) {
          bag.write("/camera/color/image_raw/compressed", f.stamp,
                    skimap::testing::CompressedColorMessage(f));
        } else {
          bag.write("/camera/color/image_raw", f.stamp, skimap::testing::ColorMessage(f));
        }
      }
    }
    const double skimapd_cpu_before = ProcessCpu(skimapd);
    const pid_t cli = Spawn({SKIMAP_CLI_PATH, "--server=" + server, "stream", bag_path,
                             "--map=" + name, "--resolution=0.02"},
                            (dir / (name + ".log")).string());
    const double cli_cpu = Reap(cli);
    const double skimapd_cpu = ProcessCpu(skimapd) - skimapd_cpu_before;
    const std::string cli_log = Slurp(dir / (name + ".log"));
    std::smatch m;
    double cli_fps = 0;
    if (std::regex_search(cli_log, m, std::regex("\\(([0-9.]+) frames/s\\)"))) {
      cli_fps = std::stod(m[1]);
    }
    auto cli_map = client->GetMap("maps/" + name);
    std::printf(
        "skimap stream BAG (%s colour): %.1f frames/s, CPU per frame: CLI %.1f ms, skimapd "
        "%.1f ms; map frames %llu\n",
        jpeg_color ? "JPEG" : "raw", cli_fps, 1e3 * cli_cpu / count, 1e3 * skimapd_cpu / count,
        (unsigned long long)(cli_map.ok() ? cli_map->stats().frames() : 0));
    bags_whole = bags_whole && cli_map.ok() && cli_map->stats().frames() == uint64_t(count);
  };
  stream_bag("cli", false);
  stream_bag("cli_jpeg", true);

  // Both sides fused the same frames: the bridge's 30 Hz map (every frame acknowledged)
  // must hold exactly the CLI's voxels.
  const auto voxels = [&](const std::string& map) {
    skimap::v1::GetVoxelsRequest request;
    request.set_map("maps/" + map);
    request.set_min_voxel_weight(0);
    std::set<std::tuple<double, double, double, float, uint32_t>> out;
    auto all = client->GetAllVoxels(request);
    if (all.ok()) {
      for (const skimap::v1::Voxel& v : *all) {
        out.insert({v.center().x(), v.center().y(), v.center().z(), v.weight(), v.rgb()});
      }
    }
    return out;
  };
  // The two bags differ only in how colour is coded (JPEG is lossy): the same voxels with
  // the same weights.
  const auto geometry = [](const auto& with_colour) {
    std::set<std::tuple<double, double, double, float>> out;
    for (const auto& [x, y, z, w, rgb] : with_colour) out.insert({x, y, z, w});
    return out;
  };
  const auto raw_voxels = voxels("cli");
  bool same =
      bags_whole && !raw_voxels.empty() && geometry(raw_voxels) == geometry(voxels("cli_jpeg"));
  std::printf("skimap stream BAG, raw and JPEG colour: %s voxel geometry (%zu), %s\n",
              same ? "the same" : "DIFFERENT", raw_voxels.size(),
              bags_whole ? "every frame in both maps" : "FRAMES MISSING");
  if (!bags_only) {
    const auto bridge_voxels = voxels(absl::StrCat("bridge", int(rate)));
    const bool bridge_same = !bridge_voxels.empty() && bridge_voxels == raw_voxels;
    std::printf("bridge at %.0f Hz and skimap stream BAG: %s voxels (%zu)\n", rate,
                bridge_same ? "the same" : "DIFFERENT", bridge_voxels.size());
    same = same && bridge_same;
  }

  spinner.stop();
  ros::shutdown();
  kill(skimapd, SIGTERM);
  Reap(skimapd);
  kill(master, SIGTERM);
  Reap(master);
  if (!keep_dir) fs::remove_all(dir);
  return same ? 0 : 1;
}
