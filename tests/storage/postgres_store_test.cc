// The PostgreSQL store's fleet side (storage/lease_store.h) on a real server started by the
// test: leases, fencing of every write by the lease in the same transaction, membership,
// and the schema version guard. Two store objects with different node ids stand for two
// skimapd nodes on one database.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "absl/strings/str_cat.h"
#include "storage/postgres_map_store.h"
#include "tests/common/postgres_server.h"
#include "tests/storage/lossy_proxy.h"

namespace skimap::storage {
namespace {

using ::skimap::testing::LossyProxy;
using ::skimap::testing::PostgresServer;

class PostgresStoreTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    server_ = new PostgresServer();
    started_ = server_->Start();
  }
  static void TearDownTestSuite() { delete server_; }
  void SetUp() override {
    ASSERT_TRUE(started_.ok()) << started_;
    dsn_ = server_->Dsn(absl::StrCat("fleet_", ++count_));
  }
  std::unique_ptr<PostgresMapStore> Node(const std::string& id,
                                         absl::Duration ttl = absl::Seconds(30)) {
    auto s = PostgresMapStore::Open(dsn_, {.connections = 2, .node_id = id, .lease_ttl = ttl});
    EXPECT_TRUE(s.ok()) << s.status();
    return s.ok() ? *std::move(s) : nullptr;
  }
  std::vector<uint64_t> Positions(MapStore& store, const std::string& id) {
    std::vector<uint64_t> out;
    EXPECT_TRUE(store
                    .ReadJournal(id, 0, SIZE_MAX,
                                 [&](const JournalRecord& r) {
                                   out.push_back(r.position);
                                   return absl::OkStatus();
                                 })
                    .ok());
    return out;
  }

  static inline PostgresServer* server_ = nullptr;
  static inline absl::Status started_;
  static inline int count_ = 0;
  std::string dsn_;
};

TEST_F(PostgresStoreTest, TheCreatorHoldsTheLeaseAndOthersSeeItsAddress) {
  auto a = Node("node-a"), b = Node("node-b");
  ASSERT_TRUE(a->Heartbeat("10.0.0.1:50051", absl::Seconds(30)).ok());
  ASSERT_TRUE(a->CreateMap("m", "o").ok());
  EXPECT_TRUE(a->HeldLease("m").has_value());
  EXPECT_FALSE(b->HeldLease("m").has_value());
  absl::StatusOr<Lease> seen = b->AcquireLease("m", absl::Seconds(30));
  ASSERT_TRUE(seen.ok()) << seen.status();
  EXPECT_EQ(seen->node, "node-a");
  EXPECT_EQ(seen->address, "10.0.0.1:50051");
  EXPECT_TRUE(seen->live);
  EXPECT_EQ(seen->token, 1);
  // b may not write a map it does not hold; a may.
  absl::Status refused = b->AppendJournal("m", {{JournalRecord::kFrame, "b"}}).status();
  EXPECT_EQ(refused.code(), absl::StatusCode::kFailedPrecondition) << refused;
  EXPECT_EQ(b->WriteSnapshot("m", 0, {}, {}).code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(b->DeleteMap("m").code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(*a->AppendJournal("m", {{JournalRecord::kFrame, "a"}}), 1u);
  EXPECT_EQ(b->AcquireLease("nope", absl::Seconds(1)).status().code(), absl::StatusCode::kNotFound);
}

TEST_F(PostgresStoreTest, AnExpiredLeaseIsTakenOverAndTheOldHoldersWritesAreFenced) {
  auto a = Node("node-a", absl::Milliseconds(300)), b = Node("node-b");
  ASSERT_TRUE(a->CreateMap("m", "").ok());
  ASSERT_TRUE(a->AppendJournal("m", {{JournalRecord::kFrame, "1"}}).ok());
  absl::SleepFor(absl::Milliseconds(400));  // a is paused past its lease
  absl::StatusOr<Lease> taken = b->AcquireLease("m", absl::Seconds(30));
  ASSERT_TRUE(taken.ok()) << taken.status();
  EXPECT_EQ(taken->node, "node-b");
  EXPECT_EQ(taken->token, 2);
  ASSERT_TRUE(b->HeldLease("m").has_value());
  // a resumes: every write is refused and changes nothing.
  absl::Status s = a->AppendJournal("m", {{JournalRecord::kFrame, "stale"}}).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition) << s;
  EXPECT_NE(s.message().find("lost the lease"), std::string::npos) << s;
  EXPECT_EQ(a->WriteSnapshot("m", 1, {{{"rgb", 0, 0, 0}, "X"}}, {}).code(),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(a->PruneJournal("m", 1).code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(Positions(*b, "m"), std::vector<uint64_t>{1});
  EXPECT_EQ(b->GetMap("m")->snapshot_position, 0u);
  EXPECT_EQ(*b->AppendJournal("m", {{JournalRecord::kFrame, "2"}}), 2u);
  // a's heartbeat does not renew what it lost.
  auto lost = a->Heartbeat("a:1", absl::Seconds(30));
  ASSERT_TRUE(lost.ok()) << lost.status();
  EXPECT_TRUE(lost->empty());  // the failed write dropped the fence already
  EXPECT_EQ(b->AcquireLease("m", absl::Seconds(30))->node, "node-b");
}

TEST_F(PostgresStoreTest, HeartbeatRenewsHeldLeasesAndReportsLostOnes) {
  auto a = Node("node-a", absl::Milliseconds(300)), b = Node("node-b");
  ASSERT_TRUE(a->CreateMap("kept", "").ok());
  ASSERT_TRUE(a->CreateMap("lost", "").ok());
  for (int i = 0; i < 4; ++i) {  // renewed past several ttls
    absl::SleepFor(absl::Milliseconds(150));
    auto lost = a->Heartbeat("a:1", absl::Milliseconds(300));
    ASSERT_TRUE(lost.ok()) << lost.status();
    EXPECT_TRUE(lost->empty());
  }
  EXPECT_EQ(b->AcquireLease("kept", absl::Seconds(1))->node, "node-a");
  absl::SleepFor(absl::Milliseconds(400));
  ASSERT_EQ(b->AcquireLease("lost", absl::Seconds(30))->node, "node-b");
  auto lost = a->Heartbeat("a:1", absl::Milliseconds(300));
  ASSERT_TRUE(lost.ok());
  EXPECT_EQ(*lost, std::vector<std::string>{"lost"});
  EXPECT_FALSE(a->HeldLease("lost").has_value());
  EXPECT_TRUE(a->HeldLease("kept").has_value());  // expired but nobody took it: renewed
  EXPECT_TRUE(a->AppendJournal("kept", {{JournalRecord::kFrame, "k"}}).ok());
}

TEST_F(PostgresStoreTest, NoAppendCommitsAfterATakeover) {
  // a appends as fast as it can while b takes the lease over: every append a was told
  // succeeded is in the journal, before b's first record, and none after the takeover.
  auto a = Node("node-a", absl::Milliseconds(200)), b = Node("node-b");
  ASSERT_TRUE(a->CreateMap("m", "").ok());
  std::atomic<bool> stop{false};
  std::vector<uint64_t> acked;
  std::thread writer([&] {
    while (!stop.load()) {
      absl::StatusOr<uint64_t> p = a->AppendJournal("m", {{JournalRecord::kFrame, "a"}});
      if (p.ok()) acked.push_back(*p);
    }
  });
  absl::StatusOr<Lease> taken;
  do {  // a's lease runs out (a writes but never renews)
    absl::SleepFor(absl::Milliseconds(20));
    taken = b->AcquireLease("m", absl::Seconds(30));
  } while (taken.ok() && taken->node != "node-b");
  ASSERT_TRUE(taken.ok()) << taken.status();
  absl::StatusOr<uint64_t> first_b = b->AppendJournal("m", {{JournalRecord::kFrame, "b"}});
  absl::SleepFor(absl::Milliseconds(100));
  stop = true;
  writer.join();
  ASSERT_TRUE(first_b.ok()) << first_b.status();
  ASSERT_FALSE(acked.empty());
  EXPECT_LT(acked.back(), *first_b);
  std::vector<uint64_t> expected = acked;
  expected.push_back(*first_b);
  EXPECT_EQ(Positions(*b, "m"), expected);
}

TEST_F(PostgresStoreTest, NodesRegisterAndLeaveReleasingTheirLeases) {
  auto a = Node("node-a"), b = Node("node-b");
  ASSERT_TRUE(a->Heartbeat("127.0.0.1:1", absl::Seconds(30)).ok());
  ASSERT_TRUE(b->Heartbeat("127.0.0.1:2", absl::Seconds(30)).ok());
  ASSERT_TRUE(a->CreateMap("m", "").ok());
  auto nodes = b->ListNodes(absl::Minutes(10));
  ASSERT_TRUE(nodes.ok()) << nodes.status();
  ASSERT_EQ(nodes->size(), 2u);
  EXPECT_EQ((*nodes)[0].id, "node-a");
  EXPECT_EQ((*nodes)[0].address, "127.0.0.1:1");
  EXPECT_TRUE((*nodes)[0].live);
  auto leases = b->ListLeases();
  ASSERT_TRUE(leases.ok());
  ASSERT_EQ(leases->size(), 1u);
  EXPECT_EQ((*leases)[0].node, "node-a");
  ASSERT_TRUE(a->Leave().ok());
  EXPECT_EQ(b->ListNodes(absl::Minutes(10))->size(), 1u);
  EXPECT_EQ(b->AcquireLease("m", absl::Seconds(30))->node, "node-b");  // at once
  EXPECT_EQ(a->AppendJournal("m", {{JournalRecord::kFrame, "x"}}).status().code(),
            absl::StatusCode::kFailedPrecondition);
}

TEST_F(PostgresStoreTest, ADatabaseOfANewerSchemaIsRefused) {
  ASSERT_NE(Node("node-a"), nullptr);
  auto c = PgConnection::Connect(dsn_);
  ASSERT_TRUE(c.ok());
  ASSERT_TRUE((*c)->ExecScript("INSERT INTO schema_version VALUES (99, 'future', 0)").ok());
  auto s = PostgresMapStore::Open(dsn_, {});
  EXPECT_EQ(s.status().code(), absl::StatusCode::kFailedPrecondition) << s.status();
}

// libpq quotes the part of a connection string it cannot parse, which may be the password.
TEST_F(PostgresStoreTest, AConnectionStringThatDoesNotParseIsRefusedWithoutQuotingIt) {
  for (const char* dsn :
       {"postgresql://skimap:s3cret%zz@127.0.0.1/x", "host=127.0.0.1 password=s3cret junk"}) {
    auto s = PostgresMapStore::Open(dsn, {});
    EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument) << dsn << ": " << s.status();
    EXPECT_EQ(s.status().message().find("s3cret"), std::string::npos) << s.status();
  }
}

TEST_F(PostgresStoreTest, AnUnreachableServerIsUnavailable) {
  auto s = PostgresMapStore::Open("postgresql://skimap@127.0.0.1:1/x?connect_timeout=2", {});
  EXPECT_EQ(s.status().code(), absl::StatusCode::kUnavailable) << s.status();
}

// Failover (docs/operations.md, "A replicated store"): calls that lose their connection
// reconnect and run again; a COMMIT whose answer was lost is read back, never written twice.
class PostgresFailoverTest : public PostgresStoreTest {
 protected:
  void SetUp() override {
    PostgresStoreTest::SetUp();
    proxy_ = std::make_unique<LossyProxy>(server_->port());
    proxied_dsn_ = dsn_;
    const std::string port = absl::StrCat(":", server_->port(), "/");
    proxied_dsn_.replace(proxied_dsn_.find(port), port.size(),
                         absl::StrCat(":", proxy_->port(), "/"));
  }
  std::unique_ptr<PostgresMapStore> Through(absl::Duration failover = absl::Seconds(20),
                                            absl::Duration statement = absl::Seconds(2)) {
    auto s = PostgresMapStore::Open(proxied_dsn_ + "?connect_timeout=2",
                                    {.connections = 1,
                                     .node_id = "node-a",
                                     .failover_timeout = failover,
                                     .statement_timeout = statement});
    EXPECT_TRUE(s.ok()) << s.status();
    return s.ok() ? *std::move(s) : nullptr;
  }
  // The journal of `id`: position and payload of every record.
  std::vector<std::pair<uint64_t, std::string>> Journal(MapStore& store, const std::string& id) {
    std::vector<std::pair<uint64_t, std::string>> out;
    EXPECT_TRUE(store
                    .ReadJournal(id, 0, SIZE_MAX,
                                 [&](const JournalRecord& r) {
                                   out.emplace_back(r.position, r.payload);
                                   return absl::OkStatus();
                                 })
                    .ok());
    return out;
  }
  using Records = std::vector<std::pair<uint64_t, std::string>>;

  std::unique_ptr<LossyProxy> proxy_;
  std::string proxied_dsn_;
};

TEST_F(PostgresFailoverTest, ALostCommitAnswerIsReadBackNotWrittenTwice) {
  auto store = Through();
  ASSERT_TRUE(store->CreateMap("m", "o").ok());
  ASSERT_EQ(*store->AppendJournal("m", {{JournalRecord::kFrame, "r1"}}), 1u);
  proxy_->Arm(LossyProxy::kAnswerLost);
  absl::StatusOr<uint64_t> appended = store->AppendJournal("m", {{JournalRecord::kFrame, "r2"}});
  ASSERT_TRUE(appended.ok()) << appended.status();
  EXPECT_EQ(*appended, 2u);
  EXPECT_EQ(proxy_->losses(), 1);
  EXPECT_EQ(Journal(*store, "m"), (Records{{1, "r1"}, {2, "r2"}}));
  const PostgresMapStore::Health h = store->health();
  EXPECT_EQ(h.unknown_commits, 1u);
  EXPECT_EQ(h.unknown_committed, 1u);
  EXPECT_GE(h.reconnects, 1u);
  EXPECT_EQ(*store->AppendJournal("m", {{JournalRecord::kFrame, "r3"}}), 3u);
}

TEST_F(PostgresFailoverTest, ACommitThatNeverArrivedIsRunAgain) {
  auto store = Through();
  ASSERT_TRUE(store->CreateMap("m", "o").ok());
  ASSERT_EQ(*store->AppendJournal("m", {{JournalRecord::kFrame, "r1"}}), 1u);
  proxy_->Arm(LossyProxy::kCommitLost);
  absl::StatusOr<uint64_t> appended = store->AppendJournal(
      "m", {{JournalRecord::kFrame, "r2"}, {JournalRecord::kPoseUpdate, "p2"}});
  ASSERT_TRUE(appended.ok()) << appended.status();
  EXPECT_EQ(*appended, 3u);
  EXPECT_EQ(Journal(*store, "m"), (Records{{1, "r1"}, {2, "r2"}, {3, "p2"}}));
  EXPECT_EQ(store->health().unknown_commits, 1u);
  EXPECT_EQ(store->health().unknown_committed, 0u);
}

// The database stays away past failover_timeout after a lost answer: the append fails
// (Unavailable, outcome unknown); the client re-sends the same record once it is back, and
// gets the position it took, not a second copy.
TEST_F(PostgresFailoverTest, AnUnresolvedAppendIsResolvedByTheMapsNextAppend) {
  auto store = Through(absl::Seconds(1));
  ASSERT_TRUE(store->CreateMap("m", "o").ok());
  ASSERT_EQ(*store->AppendJournal("m", {{JournalRecord::kFrame, "r1"}}), 1u);
  proxy_->SetDown(true);
  proxy_->Arm(LossyProxy::kAnswerLost);
  // The armed loss needs a live connection: the pool's one was opened before SetDown.
  absl::StatusOr<uint64_t> lost = store->AppendJournal("m", {{JournalRecord::kFrame, "r2"}});
  ASSERT_EQ(lost.status().code(), absl::StatusCode::kUnavailable) << lost.status();
  EXPECT_NE(lost.status().message().find("answer to the last COMMIT was lost"), std::string::npos)
      << lost.status();
  EXPECT_EQ(store->health().unknown_unresolved, 1u);
  proxy_->SetDown(false);
  EXPECT_EQ(*store->AppendJournal("m", {{JournalRecord::kFrame, "r2"}}), 2u);
  EXPECT_EQ(*store->AppendJournal("m", {{JournalRecord::kFrame, "r3"}}), 3u);
  EXPECT_EQ(Journal(*store, "m"), (Records{{1, "r1"}, {2, "r2"}, {3, "r3"}}));
}

// A server that stops answering costs a call its statement deadline and its connection,
// not a hung thread; once it answers again, so does the store.
TEST_F(PostgresFailoverTest, AServerThatStopsAnsweringCostsTheStatementDeadline) {
  auto store = Through(absl::Seconds(1), absl::Milliseconds(500));
  ASSERT_TRUE(store->CreateMap("m", "o").ok());
  proxy_->SetStalled(true);
  const absl::Time start = absl::Now();
  absl::StatusOr<uint64_t> stalled = store->AppendJournal("m", {{JournalRecord::kFrame, "r1"}});
  const absl::Duration took = absl::Now() - start;
  EXPECT_EQ(stalled.status().code(), absl::StatusCode::kUnavailable) << stalled.status();
  // The deadline, then reconnects (each up to connect_timeout) within the failover budget.
  EXPECT_LT(took, absl::Seconds(6));
  proxy_->SetStalled(false);
  EXPECT_EQ(*store->AppendJournal("m", {{JournalRecord::kFrame, "r1"}}), 1u);
  EXPECT_EQ(Journal(*store, "m"), (Records{{1, "r1"}}));
}

TEST_F(PostgresFailoverTest, CreateAndDeleteWhoseAnswersWereLostSucceedOnce) {
  auto store = Through();
  proxy_->Arm(LossyProxy::kAnswerLost);
  ASSERT_TRUE(store->CreateMap("m", "o").ok());
  EXPECT_TRUE(store->HeldLease("m").has_value());
  proxy_->Arm(LossyProxy::kAnswerLost);
  ASSERT_TRUE(store->DeleteMap("m").ok());
  EXPECT_EQ(proxy_->losses(), 2);
  EXPECT_EQ(store->GetMap("m").status().code(), absl::StatusCode::kNotFound);
}

TEST_F(PostgresFailoverTest, ARestartedServerCostsNoCall) {
  auto store = Through();
  ASSERT_TRUE(store->CreateMap("m", "o").ok());
  ASSERT_EQ(*store->AppendJournal("m", {{JournalRecord::kFrame, "r1"}}), 1u);
  ASSERT_EQ(server_->Ctl("-w -m immediate restart"), 0);
  EXPECT_EQ(*store->AppendJournal("m", {{JournalRecord::kFrame, "r2"}}), 2u);
  EXPECT_TRUE(store->GetMap("m").ok());
  EXPECT_GE(store->health().reconnects, 1u);
}

// pg_auto_failover clears synchronous_standby_names when the standby fails, which releases
// the COMMITs waiting for it: such a commit is on the primary alone and must not be
// acknowledged by a store that requires a standby. (A standby named here that never
// connects stands for one that failed.)
TEST_F(PostgresFailoverTest, ACommitReleasedWithoutItsStandbyIsNotAcknowledged) {
  ASSERT_TRUE(Through()->CreateMap("m", "o").ok());
  auto admin = PgConnection::Connect(dsn_);
  ASSERT_TRUE(admin.ok()) << admin.status();
  auto set_standby = [&](const std::string& names) {
    ASSERT_TRUE(
        (*admin)->ExecScript("ALTER SYSTEM SET synchronous_standby_names = '" + names + "'").ok());
    ASSERT_TRUE((*admin)->ExecScript("SELECT pg_reload_conf()").ok());
    for (int i = 0; i < 100; ++i) {  // the reload is asynchronous
      auto c = PgConnection::Connect(dsn_);
      auto r = (*c)->Exec("SELECT current_setting('synchronous_standby_names')");
      if (r.ok() && r->Bytes(0, 0) == names) return;
      absl::SleepFor(absl::Milliseconds(50));
    }
    FAIL() << "the setting did not reach new sessions";
  };
  ASSERT_NO_FATAL_FAILURE(set_standby("standby_that_failed"));
  auto strict = PostgresMapStore::Open(dsn_, {.connections = 1,
                                              .node_id = "",
                                              .failover_timeout = absl::Seconds(2),
                                              .require_synchronous_standby = true});
  ASSERT_TRUE(strict.ok()) << strict.status();
  absl::StatusOr<uint64_t> appended;
  std::thread append([&] {
    appended = (*strict)->AppendJournal("m", {{JournalRecord::kFrame, "r1"}});
  });
  absl::SleepFor(absl::Milliseconds(500));   // its COMMIT waits for the standby
  ASSERT_NO_FATAL_FAILURE(set_standby(""));  // ... and is released without it
  append.join();
  (void)(*admin)->ExecScript("ALTER SYSTEM RESET synchronous_standby_names");
  (void)(*admin)->ExecScript("SELECT pg_reload_conf()");
  EXPECT_EQ(appended.status().code(), absl::StatusCode::kUnavailable) << appended.status();
  EXPECT_GE((*strict)->health().standby_waits, 1u);
  EXPECT_EQ((*strict)->health().synchronous, 0);
  // The record is on the primary (a re-send, once a standby is back, is answered its
  // position), but it was not acknowledged.
  EXPECT_EQ(Journal(*strict.value(), "m"), (Records{{1, "r1"}}));
}

// Several hosts: the first that is a primary able to commit serves (here the first host
// cannot be reached at all).
TEST_F(PostgresFailoverTest, AMultiHostDsnFindsTheServerThatAnswers) {
  std::string dsn = dsn_;
  dsn.replace(dsn.find("@127.0.0.1:"), 11, "@127.0.0.1:1,127.0.0.1:");
  auto store = PostgresMapStore::Open(dsn, {.node_id = "node-a"});
  ASSERT_TRUE(store.ok()) << store.status();
  ASSERT_TRUE((*store)->CreateMap("m", "o").ok());
  ASSERT_TRUE((*store)->AppendJournal("m", {{JournalRecord::kFrame, "r1"}}).ok());
  EXPECT_EQ((*store)->health().server, absl::StrCat("127.0.0.1:", server_->port()));
  EXPECT_EQ((*store)->health().synchronous, 0);
  EXPECT_EQ(PgHostCount(dsn), 2);
  // Required synchronous replication on a lone server: refused, saying what to configure.
  auto strict = PostgresMapStore::Open(dsn, {.require_synchronous_standby = true});
  EXPECT_EQ(strict.status().code(), absl::StatusCode::kFailedPrecondition) << strict.status();
}

}  // namespace
}  // namespace skimap::storage
