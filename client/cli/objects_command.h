// `skimap objects ...`: the object service from the command line.
//
//   skimap objects ls                         objects with their sizes
//   skimap objects info ID                    one object (and the classifier state)
//   skimap objects rm ID
//   skimap objects train DATASET [--object=ID] [--detector=ORB|SIFT|AKAZE|BRISK]
//                 [--name=NAME] [--frame_stride=N] [--object_resolution=M] [--on_server]
//       DATASET is a BOP root (every train/<id>/ object, or only --object) or, with
//       --object, one BOP scene folder. Frames are streamed from this machine; with
//       --on_server the server reads DATASET from its own disk (a long-running operation).
//   skimap objects add MODEL --object=ID [--name=NAME] [--model_units=auto|m|mm]
//                 [--camera=camera.json] [--view_distances=M,...] [--view_azimuths=36]
//                 [--detector=...]
//       trains an object from a 3D model file (PLY with vertex colours, OBJ + MTL +
//       texture, glTF / GLB, ...): training views rendered here (client/cli/model_views.h)
//       and streamed as `objects train` streams a sequence's
//   skimap objects build [--classes_per_object=K] [--trees=T] [--tree_depth=D]
//       builds the classifier and waits, printing progress
//   skimap objects classifier                  the classifier's state
//
// Thread safety: one call at a time.
#ifndef CLIENT_CLI_OBJECTS_COMMAND_H_
#define CLIENT_CLI_OBJECTS_COMMAND_H_

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "client/channel.h"

namespace skimap::client {

// args: the positional arguments (args[0] the program, args[1] "objects", args[2] the verb).
// Returns the process exit code (0 OK, 1 error, 2 usage), printing errors to stderr.
int RunObjectsCommand(const std::string& server, const std::vector<std::string>& args,
                      const Connection& connection = {});

// `objects train DATASET` then `objects build`, with the same flags (what `skimap eval
// --train` runs first), except that an object the server already has is kept, not
// retrained (delete it to retrain): the database is trained or loaded. The build always
// runs (its flags are the forest-size and classes-per-object ablations). Progress goes to
// stderr; the first error is returned.
absl::Status TrainAndBuild(const std::string& server, const std::string& dataset,
                           const Connection& connection = {});

}  // namespace skimap::client

#endif  // CLIENT_CLI_OBJECTS_COMMAND_H_
