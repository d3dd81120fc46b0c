// PostgresMapStore: the journal. AppendJournal numbers its records under the map's row
// lock and settles appends whose COMMIT's answer was lost (postgres_map_store.h).
#include <algorithm>
#include <optional>

#include "absl/strings/str_cat.h"
#include "storage/postgres_map_store.h"
#include "storage/status_macros.h"

namespace skimap::storage {
namespace {

constexpr size_t kRecords = 64;  // journal records per query

// `s` of an append whose COMMIT's answer was lost and could not be settled in time.
absl::Status OutcomeUnknown(const absl::Status& s) {
  return absl::Status(s.code(), absl::StrCat(s.message(),
                                             "; the answer to the last COMMIT was lost and the "
                                             "database was not reachable again to read it back"));
}

}  // namespace

absl::StatusOr<bool> PostgresMapStore::Committed(PgConnection& c, const std::string& id,
                                                 const PendingAppend& append) {
  // The positions the transaction numbered its records with hold exactly its records if it
  // committed (the row lock orders appends; positions are never reused), and nothing or
  // other records if it did not.
  const uint64_t first = append.last - append.records.size() + 1;
  PgParams p;
  p.Text(id).Int(int64_t(first)).Int(int64_t(append.last));
  SK_ASSIGN_OR_RETURN(r, c.Exec("SELECT position, kind, payload FROM journal WHERE map = $1 AND "
                                "position BETWEEN $2 AND $3 ORDER BY position",
                                p));
  if (size_t(r.rows()) != append.records.size()) return false;
  for (int i = 0; i < r.rows(); ++i) {
    const JournalRecord& mine = append.records[i];
    if (uint64_t(r.Int(i, 0)) != first + i || r.Int(i, 1) != mine.kind ||
        r.Bytes(i, 2) != mine.payload) {
      return false;
    }
  }
  return true;
}

void PostgresMapStore::ForgetPending(const std::string& id) {
  MutexLock lock(&health_mu_);
  unresolved_.erase(id);
}

absl::StatusOr<std::optional<uint64_t>> PostgresMapStore::Settle(
    PgConnection& c, const std::string& id, const std::vector<JournalRecord>& records,
    const PendingAppend* attempt) {
  auto same = [&](const PendingAppend& u) {
    return std::equal(records.begin(), records.end(), u.records.begin(), u.records.end(),
                      [](const JournalRecord& a, const JournalRecord& b) {
                        return a.kind == b.kind && a.payload == b.payload;
                      });
  };
  std::vector<PendingAppend> pending;
  {
    MutexLock lock(&health_mu_);
    if (auto it = unresolved_.find(id); it != unresolved_.end()) pending = it->second;
  }
  if (attempt != nullptr) pending.push_back(*attempt);
  std::optional<uint64_t> found;
  for (size_t i = 0; i < pending.size(); ++i) {
    const PendingAppend& u = pending[i];
    SK_ASSIGN_OR_RETURN(committed, Committed(c, id, u));
    if (attempt != nullptr && i + 1 == pending.size()) {
      Count(committed ? Outcome::kCommitted : Outcome::kNotCommitted);
    }
    if (committed && same(u)) found = u.last;
    // Dropped: what did not commit, and what these records settle. Kept: committed records
    // of another append (its re-send may still come).
    if (committed && !same(u)) continue;
    MutexLock lock(&health_mu_);
    auto it = unresolved_.find(id);
    if (it == unresolved_.end()) continue;
    std::erase_if(it->second, [&](const PendingAppend& k) {
      return k.last == u.last && k.records.size() == u.records.size();
    });
    if (it->second.empty()) unresolved_.erase(it);
  }
  return found;
}

absl::StatusOr<uint64_t> PostgresMapStore::AppendJournal(
    const std::string& id, const std::vector<JournalRecord>& records) {
  if (records.empty()) return absl::InvalidArgumentError("map store: no journal record");
  for (const JournalRecord& r : records) {
    if (r.kind != JournalRecord::kFrame && r.kind != JournalRecord::kPoseUpdate) {
      return absl::InvalidArgumentError("map store: unknown journal record kind");
    }
  }
  const bool strict = options_.require_synchronous_standby;
  PendingAppend attempt{0, records};  // `last`: set by an attempt that reached COMMIT
  bool in_doubt = false;              // attempt's COMMIT may have happened unheard
  absl::StatusOr<uint64_t> appended = InTransaction<uint64_t>(
      "",
      [&](PgConnection& c) -> absl::StatusOr<uint64_t> {
        PgParams p;
        p.Text(id);
        // Locks the map's row: appends to one map are numbered one after the other, and a
        // transaction of ours still writing it on this server (a COMMIT whose answer was
        // lost) has ended, so what Committed reads below is final.
        SK_ASSIGN_OR_RETURN(
            row, c.Exec("SELECT current_setting('synchronous_standby_names') <> '' FROM maps "
                        "WHERE id = $1 FOR UPDATE",
                        p));
        if (row.rows() == 0) return NoMap(id);
        const bool synchronous = row.Bool(0, 0);
        {
          MutexLock lock(&health_mu_);
          health_.synchronous = synchronous ? 1 : 0;
          if (!synchronous && strict) ++health_.standby_waits;
        }
        if (!synchronous && strict) return NoSynchronousStandby();
        SK_ASSIGN_OR_RETURN(found, Settle(c, id, records, in_doubt ? &attempt : nullptr));
        in_doubt = false;
        if (found.has_value()) {
          if (strict) {  // a write, so that the COMMIT waits for the standby
            SK_RETURN_IF_ERROR(
                c.Exec("UPDATE maps SET last_position = last_position WHERE id = $1", p).status());
          }
          attempt.last = *found;
          in_doubt = true;  // settled again if this COMMIT's answer is lost
          return *found;
        }
        PgParams q;
        q.Text(id).Int(int64_t(records.size()));
        SK_ASSIGN_OR_RETURN(r, c.Exec("UPDATE maps SET last_position = last_position + $2 WHERE "
                                      "id = $1 RETURNING last_position",
                                      q));
        SK_RETURN_IF_ERROR(CheckFence(c, id));
        const uint64_t last = uint64_t(r.Int(0, 0));
        uint64_t position = last - records.size();
        for (const JournalRecord& record : records) {
          PgParams w;
          w.Text(id).Int(int64_t(++position)).Int(record.kind).Bytes(record.payload);
          SK_RETURN_IF_ERROR(
              c.Exec("INSERT INTO journal (map, position, kind, payload) VALUES ($1, $2, $3, $4)",
                     w)
                  .status());
        }
        attempt.last = last;
        in_doubt = true;  // from here its COMMIT may happen without an answer reaching us
        {
          MutexLock lock(&health_mu_);
          health_.server = c.server();
        }
        return last;  // durable once the COMMIT returns (synchronous_commit = on)
      },
      // Clearing synchronous_standby_names releases the COMMITs waiting for a standby: read
      // it again; found cleared, a rerun settles the records and makes them durable.
      [&](PgConnection& c) -> absl::Status {
        if (!strict) return absl::OkStatus();
        absl::StatusOr<PgResult> r =
            c.Exec("SELECT current_setting('synchronous_standby_names') <> ''");
        if (!r.ok()) return r.status();
        if (r->Bool(0, 0)) return absl::OkStatus();
        MutexLock lock(&health_mu_);
        health_.synchronous = 0;
        ++health_.standby_waits;
        return NoSynchronousStandby();
      });
  // An error other than a lost connection (or a standby missing after COMMIT) settles it:
  // that attempt did not commit.
  if (appended.ok() || !in_doubt || !IsConnectionLost(appended.status())) return appended;
  // Not settled within the budget: the map's next append settles it.
  Count(Outcome::kUnresolved);
  MutexLock lock(&health_mu_);
  std::vector<PendingAppend>& kept = unresolved_[id];
  kept.push_back(std::move(attempt));
  constexpr size_t kKept = 16;
  if (kept.size() > kKept) kept.erase(kept.begin());
  return OutcomeUnknown(appended.status());
}

absl::Status PostgresMapStore::ReadJournal(
    const std::string& id, uint64_t after, size_t limit,
    const std::function<absl::Status(const JournalRecord&)>& fn) {
  SK_RETURN_IF_ERROR(GetMap(id).status());
  // In pages: the records of one page are held in memory, not the whole journal.
  while (limit > 0) {
    absl::StatusOr<PgResult> r = WithConnection<PgResult>([&](PgConnection& c) {
      PgParams p;
      p.Text(id).Int(Clamp(after)).Int(Clamp(std::min(limit, kRecords)));
      return c.Exec(
          "SELECT position, kind, payload FROM journal WHERE map = $1 AND position > $2 "
          "ORDER BY position LIMIT $3",
          p);
    });
    if (!r.ok()) return r.status();
    if (r->rows() == 0) return absl::OkStatus();
    for (int i = 0; i < r->rows(); ++i) {
      const int64_t kind = r->Int(i, 1);
      if (kind != JournalRecord::kFrame && kind != JournalRecord::kPoseUpdate) {
        return absl::DataLossError(
            absl::StrCat("map store: map ", id, ": journal record of unknown kind ", kind));
      }
      after = uint64_t(r->Int(i, 0));
      SK_RETURN_IF_ERROR(fn(JournalRecord{JournalRecord::Kind(kind), r->Bytes(i, 2), after}));
      --limit;
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<JournalRecord> PostgresMapStore::ReadJournalRecord(const std::string& id,
                                                                  uint64_t position) {
  std::optional<JournalRecord> found;
  SK_RETURN_IF_ERROR(
      ReadJournal(id, position == 0 ? 0 : position - 1, 1, [&](const JournalRecord& r) {
        if (r.position == position) found = r;
        return absl::OkStatus();
      }));
  if (!found) {
    return absl::NotFoundError(
        absl::StrCat("map store: map ", id, ": no journal record at position ", position));
  }
  return *std::move(found);
}

absl::Status PostgresMapStore::PruneJournal(const std::string& id, uint64_t upto) {
  return InTransaction([&](PgConnection& c) -> absl::Status {
    SK_RETURN_IF_ERROR(GetMapOn(c, id).status());
    SK_RETURN_IF_ERROR(CheckFence(c, id));
    PgParams p;
    p.Text(id).Int(Clamp(upto));
    return c.Exec("DELETE FROM journal WHERE map = $1 AND position <= $2", p).status();
  });
}

}  // namespace skimap::storage
