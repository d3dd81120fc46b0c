// ROS 2 bags in rosbag2's sqlite3 storage (bag_reader.h), the default before Iron: the .db3
// files of a rosbag2 folder in name order (a split recording), or one .db3 file. Each file
// holds the tables rosbag2 documents:
//   topics(id, name, type, serialization_format, ...)
//   messages(id, topic_id, timestamp, data)   timestamp: recording time, ns
// Messages are read in timestamp order (ties by id, the order they were written), their
// CDR data decoded as the MCAP reader's are (ros2_messages.h).
//
// A .db3 a user hands us is hostile input: it is opened read-only and immutable (SQLite
// writes nothing beside it, not even a journal), in defensive mode with the schema's SQL
// functions untrusted, and SQLite's own checks of a corrupt file come back as DataLoss
// naming the file; a file without the two tables is InvalidArgument.
#include <sqlite3.h>

#include <map>
#include <memory>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "ros/bag/bag_reader.h"
#include "ros/bag/ros2_messages.h"

namespace skimap::bag {
namespace {

struct DbClose {
  void operator()(sqlite3* db) const { sqlite3_close_v2(db); }
};
struct StmtClose {
  void operator()(sqlite3_stmt* s) const { sqlite3_finalize(s); }
};
using Db = std::unique_ptr<sqlite3, DbClose>;
using Stmt = std::unique_ptr<sqlite3_stmt, StmtClose>;

absl::Status SqliteError(const std::string& file, sqlite3* db, int rc, const char* what) {
  const std::string msg =
      absl::StrCat(file, ": ", what, ": ", db != nullptr ? sqlite3_errmsg(db) : sqlite3_errstr(rc));
  if (rc == SQLITE_CORRUPT || rc == SQLITE_NOTADB || rc == SQLITE_IOERR) {
    return absl::DataLossError(msg);
  }
  if (rc == SQLITE_CANTOPEN) return absl::NotFoundError(msg);
  if (rc == SQLITE_NOMEM || rc == SQLITE_TOOBIG) return absl::ResourceExhaustedError(msg);
  return absl::InvalidArgumentError(msg);
}

absl::StatusOr<Db> OpenReadOnly(const std::string& file) {
  // A URI, so that immutable=1 applies; '%', '?' and '#' in the path are escaped.
  const std::string uri =
      absl::StrCat("file:", absl::StrReplaceAll(file, {{"%", "%25"}, {"?", "%3f"}, {"#", "%23"}}),
                   "?immutable=1");
  sqlite3* raw = nullptr;
  const int rc =
      sqlite3_open_v2(uri.c_str(), &raw, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr);
  Db db(raw);
  if (rc != SQLITE_OK) return SqliteError(file, db.get(), rc, "cannot open");
  sqlite3_db_config(db.get(), SQLITE_DBCONFIG_DEFENSIVE, 1, nullptr);
  sqlite3_db_config(db.get(), SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0, nullptr);
  sqlite3_exec(db.get(), "PRAGMA cell_size_check=ON", nullptr, nullptr, nullptr);
  return db;
}

absl::StatusOr<Stmt> Prepare(const std::string& file, sqlite3* db, const char* sql) {
  sqlite3_stmt* raw = nullptr;
  const int rc = sqlite3_prepare_v2(db, sql, -1, &raw, nullptr);
  Stmt stmt(raw);
  if (rc != SQLITE_OK) {
    if (rc == SQLITE_ERROR) {  // no such table or column: not a rosbag2 file
      return absl::InvalidArgumentError(
          absl::StrCat(file, ": not a rosbag2 sqlite3 bag (", sqlite3_errmsg(db), ")"));
    }
    return SqliteError(file, db, rc, "reading");
  }
  return stmt;
}

std::string Text(sqlite3_stmt* s, int col) {
  const unsigned char* t = sqlite3_column_text(s, col);
  return t == nullptr ? ""
                      : std::string(reinterpret_cast<const char*>(t),
                                    static_cast<size_t>(sqlite3_column_bytes(s, col)));
}

class SqliteBag final : public BagReader {
 public:
  absl::Status Open(const std::vector<std::string>& files) {
    std::map<std::string, BagTopic> by_name;
    for (const std::string& file : files) {
      absl::StatusOr<Db> db = OpenReadOnly(file);
      if (!db.ok()) return db.status();
      absl::StatusOr<Stmt> q =
          Prepare(file, db->get(), "SELECT id, name, type, serialization_format FROM topics");
      if (!q.ok()) return q.status();
      std::map<int64_t, Topic> ids;
      for (;;) {
        const int rc = sqlite3_step(q->get());
        if (rc == SQLITE_DONE) break;
        if (rc != SQLITE_ROW) return SqliteError(file, db->get(), rc, "reading topics");
        const std::string name = Text(q->get(), 1);
        const std::string type = Ros1TypeName(Text(q->get(), 2));
        if (absl::Status s = AddRos2Topic(file, name, type, &by_name); !s.ok()) return s;
        encodings_[name] = Text(q->get(), 3);
        ids[sqlite3_column_int64(q->get(), 0)] = {name, type};
      }
      files_.push_back({file, *std::move(db), std::move(ids)});
    }
    for (auto& [name, topic] : by_name) topics_.push_back(std::move(topic));
    return absl::OkStatus();
  }

  const std::vector<BagTopic>& topics() const override { return topics_; }

  absl::Status ForEach(const std::vector<std::string>& topics,
                       const std::function<absl::Status(const BagMessage&)>& fn) override {
    if (absl::Status s = CheckRos2Topics(Name(), topics_, encodings_, topics); !s.ok()) return s;
    for (File& f : files_) {
      absl::StatusOr<Stmt> q =
          Prepare(f.path, f.db.get(),
                  "SELECT topic_id, timestamp, data, id FROM messages ORDER BY timestamp, id");
      if (!q.ok()) return q.status();
      for (;;) {
        const int rc = sqlite3_step(q->get());
        if (rc == SQLITE_DONE) break;
        if (rc != SQLITE_ROW) return SqliteError(f.path, f.db.get(), rc, "reading messages");
        const auto topic = f.topics.find(sqlite3_column_int64(q->get(), 0));
        if (topic == f.topics.end()) continue;  // a topic this file does not list
        bool wanted = false;
        for (const std::string& t : topics) wanted = wanted || t == topic->second.name;
        if (!wanted) continue;
        const int64_t ns = sqlite3_column_int64(q->get(), 1);
        if (ns < 0) {
          return absl::InvalidArgumentError(absl::StrCat(
              f.path, ": message ", sqlite3_column_int64(q->get(), 3), " has timestamp ", ns));
        }
        const void* data = sqlite3_column_blob(q->get(), 2);
        const std::string_view bytes(static_cast<const char*>(data),
                                     static_cast<size_t>(sqlite3_column_bytes(q->get(), 2)));
        BagMessage out;
        out.topic = &topic->second.name;
        out.time.fromNSec(static_cast<uint64_t>(ns));
        absl::Status d =
            DecodeRos2Message(topic->second.type, bytes,
                              absl::StrCat(f.path, ": message ", sqlite3_column_int64(q->get(), 3),
                                           " on ", topic->second.name),
                              &out);
        if (!d.ok()) return d;
        if (absl::Status s = fn(out); !s.ok()) return s;
      }
    }
    return absl::OkStatus();
  }

 private:
  struct Topic {
    std::string name, type;  // type the ROS 1 way
  };
  struct File {
    std::string path;
    Db db;
    std::map<int64_t, Topic> topics;  // by topics.id
  };
  std::string Name() const { return files_.size() == 1 ? files_[0].path : files_[0].path + " ..."; }

  std::vector<File> files_;
  std::vector<BagTopic> topics_;
  std::map<std::string, std::string> encodings_;  // topic -> serialization_format
};

}  // namespace

absl::StatusOr<std::unique_ptr<BagReader>> OpenSqliteBag(const std::vector<std::string>& files) {
  auto bag = std::make_unique<SqliteBag>();
  if (absl::Status s = bag->Open(files); !s.ok()) return s;
  return bag;
}

}  // namespace skimap::bag
