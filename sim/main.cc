// skimap-sim: makes the synthetic SK17-style RGB-D benchmark (BOP + TUM layout).
// Usage: skimap-sim --preset sk --out DIR [options]   (see --help and docs/sim.md)
#include <cstdlib>
#include <iostream>
#include <string>

#include "absl/strings/numbers.h"
#include "sim/generator.h"

namespace {

constexpr char kUsage[] = R"(usage: skimap-sim --out DIR [options]

Makes a synthetic RGB-D dataset with ground truth in BOP layout (plus TUM text files).

  --preset NAME       mini (3 objects, 1 scene, ~100 frames), sk (12 objects, 5 scenes,
                      hand-held) or robot (12 objects, 4 rooms, a robot's head camera
                      patrolling) [mini]
  --out DIR           output folder (created; existing files are overwritten)
  --seed N            random seed; the same seed gives byte-identical output [1]
  --textures DIR      folder of .jpg/.png photographs
                      [/usr/share/doc/opencv-doc/examples/data]
  --frames N          frames per test scene [preset: mini 100, sk 400, robot 900]
  --train-frames N    frames per training orbit variant [preset: mini 12, sk 36]
  --scenes N          only the first N test scenes
  --speed X           trajectory speed multiplier [1]
  --no-train          skip the object training sequences
  --models-only       write camera.json, objects.json and models/ (PLY, and textured OBJ
                      under models/textured/) only
  --no-depth-noise    ideal depth (range limits only)
  --noise MODEL       test scenes' sensor: kinect, harsh (held out: more depth noise,
                      4 m range, more dropouts, colour noise, auto-exposure drift) or tof
                      (time of flight: flying pixels at depth edges) [kinect]
  --motion-blur N     average N sub-frames per frame (N >= 2 enables) [0]
  --threads N         frames rendered in parallel [2]
  --quiet             no progress output
  --help              this text
)";

int Fail(const std::string& msg) {
  std::cerr << "skimap-sim: " << msg << "\n(run skimap-sim --help for usage)\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  skimap::sim::GeneratorOptions o;
  o.progress = &std::cout;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](std::string* out) {
      if (i + 1 >= argc) return false;
      *out = argv[++i];
      return true;
    };
    auto int_value = [&](int* out) {
      std::string v;
      return value(&v) && absl::SimpleAtoi(v, out);
    };
    std::string v;
    bool ok = true;
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      return 0;
    } else if (a == "--preset") {
      ok = value(&o.preset);
    } else if (a == "--noise") {
      ok = value(&o.noise);
    } else if (a == "--out") {
      ok = value(&o.out_dir);
    } else if (a == "--textures") {
      ok = value(&o.texture_dir);
    } else if (a == "--seed") {
      ok = value(&v) && absl::SimpleAtoi(v, &o.seed);
    } else if (a == "--speed") {
      ok = value(&v) && absl::SimpleAtod(v, &o.speed_scale);
    } else if (a == "--frames") {
      ok = int_value(&o.scene_frames) && o.scene_frames > 0;
    } else if (a == "--train-frames") {
      ok = int_value(&o.train_frames) && o.train_frames > 0;
    } else if (a == "--scenes") {
      ok = int_value(&o.scenes) && o.scenes >= 0;
    } else if (a == "--motion-blur") {
      ok = int_value(&o.motion_blur);
    } else if (a == "--threads") {
      ok = int_value(&o.threads) && o.threads > 0;
    } else if (a == "--models-only") {
      o.models_only = true;
    } else if (a == "--no-train") {
      o.train = false;
    } else if (a == "--no-depth-noise") {
      o.depth_noise = false;
    } else if (a == "--quiet") {
      o.progress = nullptr;
    } else {
      return Fail("unknown option " + a);
    }
    if (!ok) return Fail("bad or missing value for " + a);
  }
  if (o.out_dir.empty()) return Fail("--out DIR is required");
  if (o.progress) *o.progress << "skimap-sim: preset " << o.preset << " -> " << o.out_dir << "\n";
  absl::StatusOr<skimap::sim::GeneratorStats> st = skimap::sim::Generate(o);
  if (!st.ok()) {
    std::cerr << "skimap-sim: " << st.status().message() << "\n";
    return 1;
  }
  if (o.models_only) {
    std::cout << "skimap-sim: models written to " << o.out_dir << "/models\n";
    return 0;
  }
  std::cout << "skimap-sim: " << st->frames << " frames in " << st->seconds << " s ("
            << st->frames / st->seconds << " frames/s written; " << st->render_fps
            << " frames/s rendering only, all threads)\n";
  return 0;
}
