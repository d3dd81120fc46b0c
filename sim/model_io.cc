// 3D model files into Meshes: checks here, Assimp in a child process (model_assimp.h), the
// result validated here. See model_io.h for the contract.
#include "sim/model_io.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "dataset/model_points.h"
#include "sim/model_assimp.h"

namespace skimap::sim {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr size_t kTextureBudget = size_t{512} << 20;  // decoded texture bytes per model
constexpr int kMaxTextureSide = 16384;

// ---- The child's answer on the pipe: a status, or the mesh as flat arrays. ----

void Put(std::string* out, const void* data, size_t bytes) {
  out->append(static_cast<const char*>(data), bytes);
}
void PutU64(std::string* out, uint64_t v) { Put(out, &v, sizeof v); }

std::string EncodeAnswer(const absl::StatusOr<Mesh>& mesh) {
  std::string out;
  if (!mesh.ok()) {
    out.push_back(0);
    PutU64(&out, static_cast<uint64_t>(mesh.status().code()));
    const absl::string_view message = mesh.status().message();
    PutU64(&out, message.size());
    Put(&out, message.data(), message.size());
    return out;
  }
  out.push_back(1);
  PutU64(&out, mesh->positions.size());
  for (const Eigen::Vector3f& p : mesh->positions) Put(&out, p.data(), 3 * sizeof(float));
  for (const Eigen::Vector2f& uv : mesh->uvs) Put(&out, uv.data(), 2 * sizeof(float));
  PutU64(&out, mesh->triangles.size());
  for (const auto& t : mesh->triangles) Put(&out, t.data(), 3 * sizeof(int));
  Put(&out, mesh->tri_texture.data(), mesh->tri_texture.size() * sizeof(int));
  PutU64(&out, mesh->textures.size());
  for (const Texture& t : mesh->textures) {
    const cv::Mat m = t->isContinuous() ? *t : t->clone();
    PutU64(&out, static_cast<uint64_t>(m.rows));
    PutU64(&out, static_cast<uint64_t>(m.cols));
    PutU64(&out, static_cast<uint64_t>(m.type()));
    Put(&out, m.data, m.total() * m.elemSize());
  }
  return out;
}

class Reader {
 public:
  explicit Reader(std::string_view in) : in_(in) {}
  bool Get(void* out, size_t bytes) {
    if (bytes > in_.size() - pos_) return false;
    std::memcpy(out, in_.data() + pos_, bytes);
    pos_ += bytes;
    return true;
  }
  bool U64(uint64_t* v) { return Get(v, sizeof *v); }
  size_t left() const { return in_.size() - pos_; }

 private:
  std::string_view in_;
  size_t pos_ = 0;
};

// The child's answer, every count and index checked: the child is not trusted either.
absl::StatusOr<Mesh> DecodeAnswer(std::string_view bytes, const std::string& path,
                                  const ModelOptions& options) {
  const absl::Status broken =
      absl::InvalidArgumentError(absl::StrCat(path, ": the model reader gave a broken answer"));
  Reader in(bytes);
  uint8_t ok = 0;
  if (!in.Get(&ok, 1)) return broken;
  if (ok == 0) {
    uint64_t code = 0, size = 0;
    if (!in.U64(&code) || !in.U64(&size) || size > in.left()) return broken;
    std::string message(size, '\0');
    in.Get(message.data(), size);
    if (code == 0 || code > 16) return broken;
    return absl::Status(static_cast<absl::StatusCode>(code), message);
  }
  Mesh mesh;
  uint64_t n = 0;
  if (!in.U64(&n) || n > in.left() / (5 * sizeof(float))) return broken;
  mesh.positions.resize(n);
  mesh.uvs.resize(n);
  for (Eigen::Vector3f& p : mesh.positions) in.Get(p.data(), 3 * sizeof(float));
  for (Eigen::Vector2f& uv : mesh.uvs) in.Get(uv.data(), 2 * sizeof(float));
  uint64_t triangles = 0;
  if (!in.U64(&triangles) || triangles > options.max_triangles ||
      triangles > in.left() / (4 * sizeof(int))) {
    return broken;
  }
  mesh.triangles.resize(triangles);
  mesh.tri_texture.resize(triangles);
  for (auto& t : mesh.triangles) in.Get(t.data(), 3 * sizeof(int));
  in.Get(mesh.tri_texture.data(), triangles * sizeof(int));
  uint64_t textures = 0;
  if (!in.U64(&textures) || textures > in.left() / 24) return broken;
  for (uint64_t i = 0; i < textures; ++i) {
    uint64_t rows = 0, cols = 0, type = 0;
    if (!in.U64(&rows) || !in.U64(&cols) || !in.U64(&type)) return broken;
    const int t = static_cast<int>(type);
    const bool known = type < 64 && (CV_MAT_DEPTH(t) == CV_8U || CV_MAT_DEPTH(t) == CV_16U) &&
                       (CV_MAT_CN(t) == 1 || CV_MAT_CN(t) == 3 || CV_MAT_CN(t) == 4);
    if (!known || rows < 1 || cols < 1 || rows > kMaxTextureSide || cols > kMaxTextureSide) {
      return broken;
    }
    cv::Mat image(static_cast<int>(rows), static_cast<int>(cols), t);
    if (!in.Get(image.data, image.total() * image.elemSize())) return broken;
    // BGR, 8 bits, no larger than max_texture_side.
    if (image.channels() == 4) cv::cvtColor(image, image, cv::COLOR_BGRA2BGR);
    if (image.channels() == 1) cv::cvtColor(image, image, cv::COLOR_GRAY2BGR);
    if (image.depth() != CV_8U) image.convertTo(image, CV_8U, 1.0 / 257);
    const int longer = std::max(image.cols, image.rows);
    if (longer > options.max_texture_side) {
      const double f = double(options.max_texture_side) / longer;
      cv::resize(image, image, cv::Size(), f, f, cv::INTER_AREA);
    }
    mesh.textures.push_back(std::make_shared<const cv::Mat>(std::move(image)));
  }
  if (in.left() != 0) return broken;
  for (const auto& t : mesh.triangles) {
    for (int v : t) {
      if (v < 0 || static_cast<uint64_t>(v) >= n) return broken;
    }
  }
  for (int t : mesh.tri_texture) {
    if (t < 0 || static_cast<size_t>(t) >= mesh.textures.size()) return broken;
  }
  return mesh;
}

// The child: limits itself, reads, writes its answer, exits without running destructors
// or atexit handlers of the parent's state.
[[noreturn]] void Child(int fd, const std::string& path, const ModelOptions& options) {
  // Assimp's failed assertions abort: the default action, so that a handler the parent
  // installed (libFuzzer's) does not report them as this process's crash. Memory errors
  // keep the sanitizers' handlers.
  signal(SIGABRT, SIG_DFL);
  if (!LimitThisProcess(std::max(1, options.max_seconds), options.max_memory_bytes).ok()) {
    _exit(4);
  }
  const std::string answer =
      EncodeAnswer(ReadModelWithAssimp(path, options.max_triangles, kTextureBudget));
  size_t done = 0;
  while (done < answer.size()) {
    const ssize_t w = write(fd, answer.data() + done, answer.size() - done);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) _exit(3);
    done += static_cast<size_t>(w);
  }
  _exit(0);
}

// Runs the child and collects its answer within options.max_seconds.
absl::StatusOr<Mesh> ReadInChild(const std::string& path, const ModelOptions& options) {
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) {
    return absl::InternalError(absl::StrCat("pipe: ", std::strerror(errno)));
  }
  const pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    return absl::InternalError(absl::StrCat("fork: ", std::strerror(errno)));
  }
  if (pid == 0) {
    close(fds[0]);
    Child(fds[1], path, options);
  }
  close(fds[1]);
  const auto deadline = Clock::now() + std::chrono::seconds(options.max_seconds);
  std::string answer;
  bool timed_out = false;
  char buffer[1 << 16];
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) {
      timed_out = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int ready = poll(&p, 1, static_cast<int>(std::min<int64_t>(left, 1000)));
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) continue;
    const ssize_t r = read(fds[0], buffer, sizeof buffer);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    answer.append(buffer, static_cast<size_t>(r));
  }
  close(fds[0]);
  if (timed_out) kill(pid, SIGKILL);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (timed_out) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": the model reader took over ",
                                                   options.max_seconds, " s on this file"));
  }
  if (WIFSIGNALED(status)) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": the model reader failed on this file (signal ", WTERMSIG(status),
                     WTERMSIG(status) == SIGXCPU ? ": CPU time limit" : "", ")"));
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": the model reader failed on this file (exit status ",
                     WIFEXITED(status) ? WEXITSTATUS(status) : -1, ")"));
  }
  return DecodeAnswer(answer, path, options);
}

}  // namespace

absl::Status LimitThisProcess(int cpu_seconds, uint64_t memory_bytes) {
  const rlimit cpu{static_cast<rlim_t>(cpu_seconds), static_cast<rlim_t>(cpu_seconds)};
  if (setrlimit(RLIMIT_CPU, &cpu) != 0) return absl::InternalError("setrlimit(RLIMIT_CPU) failed");
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  constexpr bool kSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
  constexpr bool kSanitizer = true;
#else
  constexpr bool kSanitizer = false;
#endif
#else
  constexpr bool kSanitizer = false;
#endif
  if (kSanitizer) return absl::OkStatus();
  const rlimit memory{memory_bytes, memory_bytes};
  if (setrlimit(RLIMIT_AS, &memory) != 0) return absl::InternalError("setrlimit(RLIMIT_AS) failed");
  return absl::OkStatus();
}

absl::StatusOr<ModelUnits> ParseModelUnits(const std::string& text, const std::string& flag) {
  if (text == "auto") return ModelUnits::kAuto;
  if (text == "m") return ModelUnits::kMetres;
  if (text == "mm") return ModelUnits::kMillimetres;
  return absl::InvalidArgumentError(
      absl::StrCat(flag, ": '", text, "' is not auto, m (metres) or mm (millimetres)"));
}

absl::StatusOr<Mesh> LoadModel(const std::string& path, const ModelOptions& options) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    return absl::NotFoundError(absl::StrCat(path, ": no such model file"));
  }
  if (const uintmax_t bytes = fs::file_size(path, ec); ec || bytes > options.max_file_bytes) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": a model file of at most ",
                                                   options.max_file_bytes >> 20, " MiB is read"));
  }
  std::string extension = fs::path(path).extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const std::string_view bare = std::string_view(extension).substr(extension.empty() ? 0 : 1);
  if (std::find(std::begin(kModelFormats), std::end(kModelFormats), bare) ==
      std::end(kModelFormats)) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": a model is read from .obj, .ply, .gltf or .glb"));
  }
  if (absl::Status s = dataset::CheckPlyHeader(path); !s.ok()) return s;
  absl::StatusOr<Mesh> read = ReadInChild(path, options);
  if (!read.ok()) return read.status();
  Mesh mesh = *std::move(read);
  for (const Eigen::Vector3f& p : mesh.positions) {
    if (!p.allFinite()) {
      return absl::InvalidArgumentError(absl::StrCat(path, ": a vertex is not a finite number"));
    }
  }
  float scale = options.units == ModelUnits::kMillimetres ? 0.001f : 1.f;
  if (options.units == ModelUnits::kAuto && mesh.Bounds().diagonal().norm() > 10.f) scale = 0.001f;
  if (scale != 1.f) {
    for (Eigen::Vector3f& p : mesh.positions) p *= scale;
  }
  return mesh;
}

}  // namespace skimap::sim
