// The object catalogue: database objects (SK17-like: boxes, cans, cups, bottles, composite
// shapes, 5-30 cm) and distractor objects that are not in the database, all textured with
// real photographs.
//
// Thread safety: pure functions returning values.
#ifndef SKIMAP_SIM_OBJECTS_H_
#define SKIMAP_SIM_OBJECTS_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "sim/mesh.h"

namespace skimap::sim {

// Debian's opencv-doc photographs, the default texture source.
inline constexpr char kDefaultTextureDir[] = "/usr/share/doc/opencv-doc/examples/data";

// Loads every .jpg/.jpeg/.png/.webp in `dir` (sorted by name; not recursive) that is a colour-
// able image of at least 64x64 px, scaled so the longer side is at most max_side px.
// When that gives fewer than `min_count` textures, each picture is instead cut into k x k
// tiles (the smallest k, at most 4, that gives min_count; tiles under 64 px dropped), each
// scaled the same way: a folder of a few large pictures (wallpapers) still gives every
// object a print of its own. kNotFound if the folder is missing or holds no usable image.
absl::StatusOr<std::vector<Texture>> LoadTextures(const std::string& dir, int max_side = 256,
                                                  int min_count = 0);

// A database object: BOP obj_id, a short name, and its mesh with the origin at the centre
// of its bounding box (BOP convention), z up when standing.
struct ObjectModel {
  int obj_id = 0;
  std::string name;
  Mesh mesh;
};

// The number of distinct database object designs (ids 1..kNumObjectDesigns).
inline constexpr int kNumObjectDesigns = 12;

// Textures a scene draws on: a print and a secondary part per object design, four
// distractors and the floor (MakeDatabaseObjects, MakeDistractors, BuildStructureMesh).
inline constexpr int kSceneTextures = 2 * kNumObjectDesigns + 4 + 1;

// Texture indices by detail, most detailed first (distinct ORB keypoints per pixel); near
// twins of a picture ranked before them (thumbnails correlating above 0.6), dull pictures
// (colourfulness under 40) and blurred or plain ones (under 300 ORB keypoints) moved last.
std::vector<size_t> RankByDetail(const std::vector<Texture>& textures);

// Makes database objects 1..count (count <= kNumObjectDesigns). Like printed packaging,
// they get the most detailed photographs (`rank`: RankByDetail(textures), cycling if there
// are fewer textures than objects): a logo on a plain ground gives a recogniser nothing to
// work with, on any object. REQUIRES: textures non-empty.
std::vector<ObjectModel> MakeDatabaseObjects(const std::vector<Texture>& textures,
                                             const std::vector<size_t>& rank, int count);

// Makes `count` distractor meshes (origin at bbox centre), textured from the end of
// `rank` (RankByDetail(textures)), so they look unlike the database objects (which take
// its start). REQUIRES: textures non-empty.
std::vector<Mesh> MakeDistractors(const std::vector<Texture>& textures,
                                  const std::vector<size_t>& rank, int count);

// Moves the mesh so the centre of its bounding box is at the origin.
void CentreMesh(Mesh& mesh);

}  // namespace skimap::sim

#endif  // SKIMAP_SIM_OBJECTS_H_
