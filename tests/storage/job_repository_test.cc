// Tests of the SQLite job history on ":memory:" and on a temporary file (COLMAP's
// ParameterizedDatabaseTests): writes, listing with filters and paging, lineage, batches, and
// that a file keeps everything across a reopen.
#include "storage/job_repository.h"

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <cstdio>
#include <string>
#include <thread>
#include <vector>

namespace gearloop {
namespace {

JobRecord MakeJob(int teeth, const std::string& flank, const std::string& status = "converged") {
  JobRecord job;
  job.kind = "correction";
  job.status = status;
  job.gear_teeth = teeth;
  job.gear_normal_module_mm = 6.0;
  job.gear_helix_angle_deg = 15.0;
  job.gear_hand = "left";
  job.flank = flank;
  job.request_json = R"({"gear":{"teeth":)" + std::to_string(teeth) + "}}";
  job.result_json = R"({"residual_rms_um":0.5})";
  job.residual_rms_um = 0.5;
  job.best_reachable_rms_um = 0.25;
  job.rank = 16;
  job.elapsed_ms = 3.5;
  job.server_version = "test";
  return job;
}

// A unique temporary file path, removed (with its WAL side files) on destruction.
class TempDatabasePath {
 public:
  TempDatabasePath() {
    char pattern[] = "/tmp/gearloop_storage_test_XXXXXX";
    const int fd = mkstemp(pattern);
    close(fd);
    path_ = pattern;
    std::remove(path_.c_str());
  }
  ~TempDatabasePath() {
    for (const char* suffix : {"", "-wal", "-shm"}) std::remove((path_ + suffix).c_str());
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

class JobRepositoryTest : public ::testing::TestWithParam<bool> {
 protected:
  void SetUp() override {
    if (GetParam()) temp_ = std::make_unique<TempDatabasePath>();
    repo_ = OpenJobRepository(GetParam() ? temp_->path() : ":memory:");
  }
  std::unique_ptr<TempDatabasePath> temp_;
  std::unique_ptr<JobRepository> repo_;
};

TEST_P(JobRepositoryTest, MigratesToCurrentSchema) {
  EXPECT_EQ(repo_->SchemaVersion(), 1);
  EXPECT_EQ(repo_->IntegrityCheck(), "ok");
  EXPECT_EQ(repo_->CountJobs(), 0);
}

TEST_P(JobRepositoryTest, WritesAndReadsJobWithAllFields) {
  JobRecord job = MakeJob(37, "right");
  job.rank.reset();
  const int64_t id = repo_->WriteJob(job);
  EXPECT_GT(id, 0);
  const std::optional<JobRecord> read = repo_->ReadJob(id);
  ASSERT_TRUE(read.has_value());
  EXPECT_EQ(read->id, id);
  EXPECT_EQ(read->kind, "correction");
  EXPECT_EQ(read->status, "converged");
  EXPECT_EQ(read->gear_teeth, 37);
  EXPECT_DOUBLE_EQ(read->gear_normal_module_mm, 6.0);
  EXPECT_DOUBLE_EQ(read->gear_helix_angle_deg, 15.0);
  EXPECT_EQ(read->gear_hand, "left");
  EXPECT_EQ(read->flank, "right");
  EXPECT_EQ(read->request_json, job.request_json);
  EXPECT_EQ(read->result_json, job.result_json);
  EXPECT_DOUBLE_EQ(*read->residual_rms_um, 0.5);
  EXPECT_DOUBLE_EQ(*read->best_reachable_rms_um, 0.25);
  EXPECT_FALSE(read->rank.has_value());
  EXPECT_DOUBLE_EQ(read->elapsed_ms, 3.5);
  EXPECT_EQ(read->server_version, "test");
  EXPECT_FALSE(read->parent_job_id.has_value());
  // Filled with the current UTC time: "YYYY-MM-DDTHH:MM:SS.mmmZ".
  ASSERT_EQ(read->created_utc.size(), 24u);
  EXPECT_EQ(read->created_utc[10], 'T');
  EXPECT_EQ(read->created_utc.back(), 'Z');
  EXPECT_FALSE(repo_->ReadJob(id + 1000).has_value());
  EXPECT_TRUE(repo_->JobExists(id));
  EXPECT_FALSE(repo_->JobExists(id + 1000));
}

TEST_P(JobRepositoryTest, RefusesLinkToMissingJobAndStoresNothing) {
  JobRecord job = MakeJob(37, "right");
  job.parent_job_id = 42;
  EXPECT_THROW(repo_->WriteJob(job), StorageError);
  job.parent_job_id.reset();
  job.settings_source_job_id = 42;
  EXPECT_THROW(repo_->WriteJob(job), StorageError);
  EXPECT_EQ(repo_->CountJobs(), 0);
}

TEST_P(JobRepositoryTest, ListsNewestFirstWithPagingAndFilters) {
  std::vector<int64_t> ids;
  for (int i = 0; i < 7; ++i) {
    JobRecord job = MakeJob(i % 2 == 0 ? 37 : 41, i < 5 ? "right" : "left", i == 3 ? "not_converged" : "converged");
    job.created_utc = "2026-11-" + std::to_string(10 + i) + "T12:00:00.000Z";
    ids.push_back(repo_->WriteJob(job));
  }
  JobFilter filter;
  filter.limit = 3;
  JobPage page = repo_->ListJobs(filter);
  EXPECT_EQ(page.total, 7);
  ASSERT_EQ(page.jobs.size(), 3u);
  EXPECT_EQ(page.jobs[0].id, ids[6]);
  EXPECT_EQ(page.jobs[2].id, ids[4]);
  EXPECT_TRUE(page.jobs[0].request_json.empty());  // listings carry no documents

  filter.offset = 6;
  page = repo_->ListJobs(filter);
  ASSERT_EQ(page.jobs.size(), 1u);
  EXPECT_EQ(page.jobs[0].id, ids[0]);

  JobFilter teeth;
  teeth.gear_teeth = 41;
  page = repo_->ListJobs(teeth);
  EXPECT_EQ(page.total, 3);
  for (const JobRecord& job : page.jobs) EXPECT_EQ(job.gear_teeth, 41);

  JobFilter module_and_flank;
  module_and_flank.gear_normal_module_mm = 6.0;
  module_and_flank.flank = "left";
  EXPECT_EQ(repo_->ListJobs(module_and_flank).total, 2);
  module_and_flank.gear_normal_module_mm = 5.0;
  EXPECT_EQ(repo_->ListJobs(module_and_flank).total, 0);

  JobFilter dates;
  dates.created_from = "2026-11-12";
  dates.created_to = "2026-11-14";
  page = repo_->ListJobs(dates);
  ASSERT_EQ(page.total, 2);
  EXPECT_EQ(page.jobs[0].id, ids[3]);
  EXPECT_EQ(page.jobs[1].id, ids[2]);

  JobFilter status;
  status.status = "not_converged";
  EXPECT_EQ(repo_->ListJobs(status).total, 1);
}

TEST_P(JobRepositoryTest, WalksSettingsLineageBothWays) {
  // first -> second -> third (each ground with the previous one's settings), a replay of
  // second (same part), and an unrelated job.
  const int64_t first = repo_->WriteJob(MakeJob(37, "right"));
  JobRecord second_job = MakeJob(37, "right");
  second_job.settings_source_job_id = first;
  const int64_t second = repo_->WriteJob(second_job);
  const int64_t unrelated = repo_->WriteJob(MakeJob(41, "right"));
  JobRecord replay_job = MakeJob(37, "right");
  replay_job.kind = "replay";
  replay_job.parent_job_id = second;
  replay_job.settings_source_job_id = first;
  const int64_t replay = repo_->WriteJob(replay_job);
  JobRecord third_job = MakeJob(37, "right");
  third_job.settings_source_job_id = second;
  const int64_t third = repo_->WriteJob(third_job);

  std::vector<int64_t> lineage_ids;
  for (const JobRecord& job : repo_->ReadLineage(second)) lineage_ids.push_back(job.id);
  EXPECT_EQ(lineage_ids, (std::vector<int64_t>{first, second, third}));

  lineage_ids.clear();
  for (const JobRecord& job : repo_->ReadLineage(first)) lineage_ids.push_back(job.id);
  EXPECT_EQ(lineage_ids, (std::vector<int64_t>{first, second, replay, third}));

  EXPECT_EQ(repo_->ReadLineage(unrelated).size(), 1u);
  EXPECT_TRUE(repo_->ReadLineage(9999).empty());
  EXPECT_EQ(repo_->ReadJob(replay)->parent_job_id, second);
}

TEST_P(JobRepositoryTest, RunsBatchBookkeeping) {
  const int64_t batch = repo_->CreateBatch({"{\"a\":1}", "{\"a\":2}", "{\"a\":3}"});
  std::optional<BatchRecord> record = repo_->ReadBatch(batch, /*with_items=*/true);
  ASSERT_TRUE(record.has_value());
  EXPECT_EQ(record->status, "running");
  EXPECT_EQ(record->total, 3);
  ASSERT_EQ(record->items.size(), 3u);
  EXPECT_EQ(repo_->ReadPendingBatchItems().size(), 3u);

  const int64_t job_id = repo_->CompleteBatchItem(batch, 0, MakeJob(37, "right"));
  BatchItemRecord error;
  error.error_status = 422;
  error.error_code = "invalid_value";
  error.error_message = "teeth must be at least 5";
  error.error_field = "gear.teeth";
  repo_->FailBatchItem(batch, 1, error);
  // An item is finished once only.
  EXPECT_THROW(repo_->FailBatchItem(batch, 1, error), StorageError);
  EXPECT_THROW(repo_->CompleteBatchItem(batch, 0, MakeJob(37, "right")), StorageError);
  EXPECT_EQ(repo_->CountJobs(), 1);  // the refused completion stored no job

  record = repo_->ReadBatch(batch, true);
  EXPECT_EQ(record->status, "running");
  EXPECT_EQ(record->done, 1);
  EXPECT_EQ(record->failed, 1);
  EXPECT_TRUE(record->finished_utc.empty());
  EXPECT_EQ(record->items[0].state, BatchItemState::kDone);
  EXPECT_EQ(record->items[0].job_id, job_id);
  EXPECT_EQ(record->items[1].state, BatchItemState::kFailed);
  EXPECT_EQ(record->items[1].error_field, "gear.teeth");
  EXPECT_EQ(record->items[1].error_status, 422);
  const std::vector<PendingBatchItem> pending = repo_->ReadPendingBatchItems();
  ASSERT_EQ(pending.size(), 1u);
  EXPECT_EQ(pending[0].index, 2);
  EXPECT_EQ(pending[0].request_json, "{\"a\":3}");

  repo_->CompleteBatchItem(batch, 2, MakeJob(37, "right"));
  record = repo_->ReadBatch(batch, false);
  EXPECT_EQ(record->status, "finished");
  EXPECT_EQ(record->done, 2);
  EXPECT_FALSE(record->finished_utc.empty());
  EXPECT_TRUE(record->items.empty());
  EXPECT_FALSE(repo_->ReadBatch(batch + 1, true).has_value());
}

TEST_P(JobRepositoryTest, AcceptsConcurrentWriters) {
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([this] {
      for (int i = 0; i < 25; ++i) repo_->WriteJob(MakeJob(37, "right"));
    });
  }
  for (std::thread& thread : threads) thread.join();
  EXPECT_EQ(repo_->CountJobs(), 100);
}

INSTANTIATE_TEST_SUITE_P(MemoryAndFile,
                         JobRepositoryTest,
                         ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& info) { return info.param ? "File" : "Memory"; });

TEST(OpenJobRepository, KeepsJobsAndBatchesAcrossReopen) {
  TempDatabasePath temp;
  int64_t id = 0;
  int64_t batch = 0;
  {
    std::unique_ptr<JobRepository> repo = OpenJobRepository(temp.path());
    id = repo->WriteJob(MakeJob(37, "right"));
    batch = repo->CreateBatch({"{}", "{}"});
  }
  std::unique_ptr<JobRepository> repo = OpenJobRepository(temp.path());
  EXPECT_EQ(repo->SchemaVersion(), 1);
  ASSERT_TRUE(repo->ReadJob(id).has_value());
  EXPECT_EQ(repo->ReadJob(id)->request_json, MakeJob(37, "right").request_json);
  EXPECT_EQ(repo->ReadPendingBatchItems().size(), 2u);
  EXPECT_EQ(repo->ReadBatch(batch, true)->items.size(), 2u);
  EXPECT_EQ(repo->IntegrityCheck(), "ok");
}

TEST(OpenJobRepository, RefusesADatabaseFromANewerServer) {
  TempDatabasePath temp;
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(temp.path().c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "PRAGMA user_version = 99;", nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
  }
  EXPECT_THROW(OpenJobRepository(temp.path()), StorageError);
}

TEST(OpenJobRepository, UsesWriteAheadLogWithForeignKeys) {
  TempDatabasePath temp;
  { std::unique_ptr<JobRepository> repo = OpenJobRepository(temp.path()); }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(temp.path().c_str(), &db), SQLITE_OK);
  sqlite3_stmt* statement = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA journal_mode;", -1, &statement, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(statement), SQLITE_ROW);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(statement, 0)), "wal");
  sqlite3_finalize(statement);
  ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA user_version;", -1, &statement, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(statement), SQLITE_ROW);
  EXPECT_EQ(sqlite3_column_int(statement, 0), 1);
  sqlite3_finalize(statement);
  sqlite3_close(db);
}

TEST(OpenJobRepository, ThrowsStorageErrorForUnopenablePath) {
  EXPECT_THROW(OpenJobRepository("/nonexistent-dir/gearloop.sqlite"), StorageError);
}

TEST(CurrentUtcIso8601, HasMillisecondsAndZulu) {
  const std::string now = CurrentUtcIso8601();
  ASSERT_EQ(now.size(), 24u);
  EXPECT_EQ(now[4], '-');
  EXPECT_EQ(now[19], '.');
  EXPECT_EQ(now[23], 'Z');
}

}  // namespace
}  // namespace gearloop
