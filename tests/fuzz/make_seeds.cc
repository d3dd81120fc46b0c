// skimap_fuzz_seeds OUT_DIR: writes the seed corpora of the fuzz targets
// (OUT_DIR/<target>/<name>), made with the real encoders so that each seed is a valid
// input the fuzzer then mutates. The committed corpora (tests/fuzz/corpus/) came from this
// program; rerun it after a format change:
//
//   build/asan/tests/fuzz/skimap_fuzz_seeds tests/fuzz/corpus
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "codec/image_codec.h"
#include "codec/image_files.h"
#include "perception/objects/features.h"
#include "perception/objects/random_forest.h"
#include "server/core/maps/frame_index.h"
#include "server/core/objects/object_database_io.h"
#include "server/core/transfer/chunk_codec.h"
#include "server/core/transfer/map_export.h"
#include "server/http/rest_messages.h"
#include "skimap/free_columns_voxel.h"
#include "skimap/hypotheses_voxel.h"
#include "skimap/label_voxel.h"
#include "skimap/serialization.h"
#include "skimap/v1/map_service.pb.h"
#include "tests/fuzz/fuzz_input.h"

namespace skimap::fuzz {
namespace {

namespace fs = std::filesystem;
fs::path out_dir;

void Write(const std::string& target, const std::string& name, const std::string& bytes) {
  fs::create_directories(out_dir / target);
  std::ofstream(out_dir / target / name, std::ios::binary) << bytes;
}

std::string Byte(int v) { return std::string(1, static_cast<char>(v)); }
std::string U16(int v) { return Byte(v & 0xff) + Byte(v >> 8); }

constexpr int kW = 16, kH = 12;

perception::DepthImage Depth() {
  perception::DepthImage d{kW, kH, std::vector<uint16_t>(kW * kH)};
  for (int i = 0; i < kW * kH; ++i) d.pixels[i] = static_cast<uint16_t>(900 + 7 * i);
  return d;
}

perception::ColorImage Color() {
  perception::ColorImage c{kW, kH, std::vector<uint8_t>(kW * kH * 3)};
  for (size_t i = 0; i < c.rgb.size(); ++i) c.rgb[i] = static_cast<uint8_t>(i * 13);
  return c;
}

void ImageSeeds() {
  const perception::DepthCodec depth[] = {perception::DepthCodec::kRawU16,
                                          perception::DepthCodec::kPng16,
                                          perception::DepthCodec::kZstd};
  const perception::ColorCodec color[] = {perception::ColorCodec::kRawRgb8,
                                          perception::ColorCodec::kPng,
                                          perception::ColorCodec::kJpeg};
  const std::string size = U16(kW - 1) + U16(kH - 1);
  for (int i = 0; i < 3; ++i) {
    Write("image_codec", "depth" + std::to_string(i),
          Byte(i) + size + *perception::EncodeDepth(depth[i], Depth()));
    Write("image_codec", "color" + std::to_string(i),
          Byte(3 + i) + size + *perception::EncodeColor(color[i], Color()));
  }
  // RVL with runs of zeros (holes) between the values.
  perception::DepthImage holes = Depth();
  for (size_t i = 0; i < holes.pixels.size(); ++i) {
    if (i % 7 < 2) holes.pixels[i] = 0;
  }
  Write("image_codec", "depth_rvl",
        Byte(8) + size + *perception::EncodeDepth(perception::DepthCodec::kRvl, holes));
  Write("image_codec", "png_header",
        Byte(6) + size + *perception::EncodeColor(perception::ColorCodec::kPng, Color()));
  Write("image_codec", "jpeg_header",
        Byte(7) + size + *perception::EncodeColor(perception::ColorCodec::kJpeg, Color()));
  // image_files.h's DecodeImage (codec 9 + ImageMode): a 16-bit PNG at any depth, a colour
  // JPEG as colour, a PGM unchanged.
  Write("image_codec", "file_png16",
        Byte(9 + 4) + size + *perception::EncodeDepth(perception::DepthCodec::kPng16, Depth()));
  Write("image_codec", "file_jpeg",
        Byte(9 + 1) + size + *perception::EncodeColor(perception::ColorCodec::kJpeg, Color()));
  // PNGs the libdeflate fast path decodes (codec/png_fast_path.cc): 8-bit RGB as RGB,
  // BGRA unchanged, grey as grey.
  cv::Mat bgra(kH, kW, CV_8UC4), grey(kH, kW, CV_8UC1);
  cv::randu(bgra, 0, 256);
  cv::randu(grey, 0, 256);
  Write("image_codec", "file_png_rgb",
        Byte(9 + 2) + size + *perception::EncodeColor(perception::ColorCodec::kPng, Color()));
  Write("image_codec", "file_png_bgra", Byte(9) + size + *perception::EncodeImage(".png", bgra));
  Write("image_codec", "file_png_grey",
        Byte(9 + 3) + size + *perception::EncodeImage(".png", grey));
  Write("image_codec", "file_pgm",
        Byte(9) + size + *perception::EncodeImage(".pgm", cv::Mat(kH, kW, CV_8UC1, cv::Scalar(9))));
}

v1::Frame Frame(const std::string& map, uint64_t sequence, v1::DepthEncoding de,
                v1::ColorEncoding ce) {
  v1::Frame f;
  f.set_map(map);
  f.set_sequence(sequence);
  f.mutable_pose()->mutable_rotation()->set_w(1);
  f.mutable_pose()->mutable_translation()->set_z(0.5);
  v1::CameraIntrinsics& k = *f.mutable_intrinsics();
  k.set_width(kW);
  k.set_height(kH);
  k.set_fx(15);
  k.set_fy(15);
  k.set_cx(8);
  k.set_cy(6);
  f.set_depth_scale(0.001);
  f.set_depth_encoding(de);
  const perception::DepthCodec dc = de == v1::DEPTH_ENCODING_PNG16  ? perception::DepthCodec::kPng16
                                    : de == v1::DEPTH_ENCODING_ZSTD ? perception::DepthCodec::kZstd
                                    : de == v1::DEPTH_ENCODING_RVL
                                        ? perception::DepthCodec::kRvl
                                        : perception::DepthCodec::kRawU16;
  f.set_depth(*perception::EncodeDepth(dc, Depth()));
  f.set_color_encoding(ce);
  if (ce != v1::COLOR_ENCODING_NONE) {
    const perception::ColorCodec cc = ce == v1::COLOR_ENCODING_PNG ? perception::ColorCodec::kPng
                                      : ce == v1::COLOR_ENCODING_JPEG
                                          ? perception::ColorCodec::kJpeg
                                          : perception::ColorCodec::kRawRgb8;
    f.set_color(*perception::EncodeColor(cc, Color()));
  }
  return f;
}

void FrameSeeds() {
  const v1::DepthEncoding depth[] = {v1::DEPTH_ENCODING_RAW_U16, v1::DEPTH_ENCODING_PNG16,
                                     v1::DEPTH_ENCODING_ZSTD, v1::DEPTH_ENCODING_RVL};
  const v1::ColorEncoding color[] = {v1::COLOR_ENCODING_NONE, v1::COLOR_ENCODING_RAW_RGB8,
                                     v1::COLOR_ENCODING_PNG, v1::COLOR_ENCODING_JPEG};
  for (int d = 0; d < 4; ++d) {
    for (int c = 0; c < 4; ++c) {
      Write("frame_decode", "frame_d" + std::to_string(d) + "_c" + std::to_string(c),
            Frame("maps/m", 1, depth[d], color[c]).SerializeAsString());
    }
  }
}

void RequestSeeds() {
  auto put = [](int rpc, const std::string& name, const google::protobuf::Message& m) {
    Write("map_requests", name, Byte(rpc) + m.SerializeAsString());
  };
  v1::CreateMapRequest create;
  create.set_map_id("kitchen");
  create.mutable_options()->set_resolution(0.02);
  create.mutable_options()->set_carve_free_space(true);
  put(0, "create", create);
  v1::GetMapRequest get;
  get.set_name("maps/m");
  put(1, "get", get);
  v1::ListMapsRequest list;
  list.set_page_size(1);
  put(2, "list", list);
  v1::DeleteMapRequest del;
  del.set_name("maps/kitchen");
  put(3, "delete", del);
  put(4, "frame", Frame("maps/m", 10, v1::DEPTH_ENCODING_ZSTD, v1::COLOR_ENCODING_PNG));
  put(4, "frame_carve", Frame("maps/c", 10, v1::DEPTH_ENCODING_RAW_U16, v1::COLOR_ENCODING_NONE));
  v1::UpdatePosesRequest poses;
  poses.set_map("maps/m");
  v1::PoseUpdate* u = poses.add_updates();
  u->set_sequence(1);
  u->mutable_pose()->mutable_rotation()->set_w(1);
  u->mutable_pose()->mutable_translation()->set_y(0.1);
  put(5, "poses", poses);
  v1::GetOccupancyGridRequest grid;
  grid.set_map("maps/c");
  grid.mutable_region()->set_min_x(-1);
  grid.mutable_region()->set_max_x(1);
  grid.mutable_region()->set_min_y(-1);
  grid.mutable_region()->set_max_y(1);
  grid.set_band_min_z(0.1);
  put(6, "grid", grid);
  v1::GetHeightMapRequest height;
  height.set_map("maps/m");
  put(7, "height", height);
  v1::GetVoxelsRequest voxels;
  voxels.set_map("maps/m");
  voxels.set_page_size(5);
  voxels.mutable_box()->mutable_min()->set_x(-1);
  voxels.mutable_box()->mutable_max()->set_x(1);
  put(8, "voxels", voxels);
  v1::RadiusSearchRequest radius;
  radius.set_map("maps/m");
  radius.mutable_center()->set_z(1);
  radius.set_radius(0.3);
  put(9, "radius", radius);
}

std::vector<VoxelBatch<RGBWeightedVoxel>::Item> ChunkVoxels() {
  std::vector<VoxelBatch<RGBWeightedVoxel>::Item> items;
  for (int i = 0; i < 5; ++i) {
    items.push_back({{-64 + i, 96 + 2 * i, 3 * i}, RGBWeightedVoxel(10.f * i, 20, 30, 1.f + i)});
  }
  return items;
}

void ChunkSeeds() {
  const server::ChunkCoord c{-2, 3, 0};
  Write("chunk_codec", "rgb",
        Byte(1) + server::EncodeVoxelChunk<RGBWeightedVoxel>(c, ChunkVoxels()));
  std::vector<VoxelBatch<WeightVoxel>::Item> weights;
  for (int i = 0; i < 40; ++i) weights.push_back({{-64 + i % 32, 96 + i / 32, 0}, {2.f}});
  Write("chunk_codec", "weight", Byte(0) + server::EncodeVoxelChunk<WeightVoxel>(c, weights));
  server::FrameIndex index;
  for (uint64_t s = 4096; s < 4100; ++s) {
    perception::CameraPose pose;
    pose.translation = {0.1 * double(s - 4096), 0, 0};
    index.Add(s, {.position = s, .record_bytes = 1000, .pose = pose});
  }
  Write("chunk_codec", "frame_index", Byte(7) + index.EncodeBucket(1));
  // The free volume's blocks, and a chunk of the per-column volume they replaced.
  std::vector<VoxelBatch<FreeColumnsVoxel>::Item> blocks;
  for (int i = 0; i < 6; ++i) {
    FreeColumnsVoxel block;
    block.counts[size_t(i)] = uint32_t(1 + i);
    block.counts[15] = 3;
    blocks.push_back({{-64 + 4 * i, 96 + 4 * (i % 2), 0}, block});
  }
  Write("chunk_codec", "free_columns",
        Byte(5) + server::EncodeVoxelChunk<FreeColumnsVoxel>(c, blocks));
  Write("chunk_codec", "free_legacy", Byte(5) + server::EncodeVoxelChunk<WeightVoxel>(c, weights));
}

void SkimapFileSeeds() {
  SkiMap<RGBWeightedVoxel> rgb({.resolution = 0.05});
  VoxelBatch<RGBWeightedVoxel> batch;
  for (const auto& item : ChunkVoxels()) batch.AddKey(item.key, item.data);
  batch.Finalize();
  rgb.Integrate(batch);
  Write("skimap_file", "rgb", Byte(1) + SerializeMap(rgb));
  SkiMap<WeightVoxel> weight({.resolution = 0.1});
  VoxelBatch<WeightVoxel> wb;
  wb.AddKey({1, 2, 3}, {4.f});
  wb.AddKey({-5, 0, 7}, {1.f});
  wb.Finalize();
  weight.Integrate(wb);
  Write("skimap_file", "weight", Byte(0) + SerializeMap(weight));
  Write("skimap_file", "labels_empty", Byte(2) + SerializeMap(SkiMap<MultiLabelVoxel>({})));
  Write("skimap_file", "hypotheses_empty", Byte(3) + SerializeMap(SkiMap<HypothesesVoxel>({})));
}

storage::Chunk StoredChunk() {
  return {{"rgb", -2, 3, 0}, server::EncodeVoxelChunk<RGBWeightedVoxel>({-2, 3, 0}, ChunkVoxels())};
}

void ExportSeeds() {
  v1::MapOptions options;
  options.set_resolution(0.05);
  std::string file;
  server::ExportWriter w({.map_id = "kitchen",
                          .options = options.SerializeAsString(),
                          .snapshot_position = 2,
                          .journal_base = 0},
                         &file);
  w.AddChunk(StoredChunk(), &file);
  for (uint64_t p = 1; p <= 2; ++p) {
    w.AddJournal(
        {.kind = storage::JournalRecord::kFrame,
         .payload = Frame("maps/kitchen", p, v1::DEPTH_ENCODING_ZSTD, v1::COLOR_ENCODING_NONE)
                        .SerializeAsString(),
         .position = p},
        &file);
  }
  w.Finish(&file);
  Write("export_reader", "with_journal", Byte(1) + Byte(7) + file);
  Write("export_reader", "with_journal_raw_crc", Byte(0) + Byte(200) + file);
  std::string small;
  server::ExportWriter s({.map_id = "a", .options = "", .snapshot_position = 0, .journal_base = 0},
                         &small);
  s.Finish(&small);
  Write("export_reader", "empty_map", Byte(1) + Byte(0) + small);
}

void ForestSeeds() {
  objects::TrainingSet set{.dims = 4};
  for (int i = 0; i < 60; ++i) {
    const float x[4] = {float(i % 3), float(i % 5) * 0.1f, float(i) * 0.01f, 1.f};
    set.Add(x, static_cast<uint32_t>(i % 3));
  }
  absl::StatusOr<objects::RandomForest> f =
      objects::RandomForest::Train(set, 3, {.trees = 3, .max_depth = 4, .threads = 1});
  Write("random_forest", "small", Byte(1) + f->Serialize());
}

void ObjectDatabaseSeeds() {
  const objects::DescriptorLayout layout = *objects::DetectorLayout("ORB");
  std::string s = Byte(1) + Byte(1) + Byte(0);  // flags, format version, no overrides
  PutBytes(&s, "ORB");
  s += Byte(static_cast<int>(layout.kind)) + U16(layout.dims);
  s += Byte(1);          // one object
  s += U16(7) + U16(0);  // obj_id 7
  PutBytes(&s, "cube");
  PutBytes(&s, "");                         // no RGB volume
  s += Byte(1) + U16(1) + U16(2) + U16(3);  // one voxel (1, 2, 3)
  s += U16(5) + U16(0) + Byte(1);           // evidence 5, one centroid
  s += U16(5) + U16(0);                     // cardinality 5
  PutBytes(&s, std::string(layout.RowBytes(), '\x3c'));
  s += Byte(0) + U16(0) + U16(0);  // no forest
  PutBytes(&s, "");
  Write("object_database", "one_object", s);
}

// REST JSON bodies (rest_json_fuzz.cc): route byte, then a body as clients send it.
void RestJsonSeeds() {
  Write(
      "rest_json", "create",
      Byte(0) + R"({"mapId": "kitchen", "options": {"resolution": 0.05, "carveFreeSpace": true}})");
  Write("rest_json", "radius",
        Byte(1) + R"({"center": {"x": 0.5, "y": -1, "z": 0.25}, "radius": 0.3, "maxResults": 10})");
  v1::Frame frame = Frame("maps/fuzz", 7, v1::DEPTH_ENCODING_RAW_U16, v1::COLOR_ENCODING_NONE);
  frame.clear_map();
  Write("rest_json", "frame", Byte(2) + server::ToJson(frame));
  Write("rest_json", "poses",
        Byte(3) + R"({"updates": [{"sequence": "7", "pose": {"translation": {"x": 1},)"
                  R"( "rotation": {"w": 1}}}]})");
}

}  // namespace
}  // namespace skimap::fuzz

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: skimap_fuzz_seeds OUT_DIR\n");
    return 2;
  }
  using namespace skimap::fuzz;
  out_dir = argv[1];
  ImageSeeds();
  FrameSeeds();
  RequestSeeds();
  ChunkSeeds();
  SkimapFileSeeds();
  ExportSeeds();
  ForestSeeds();
  ObjectDatabaseSeeds();
  RestJsonSeeds();
  return 0;
}
