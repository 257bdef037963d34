// Tests of the SQLite job history on ":memory:" and on a temporary file
// (COLMAP's ParameterizedDatabaseTests): writes, listing with filters and
// paging, lineage, batches, that a file keeps everything across a reopen, and
// that a file of release 0.1.0 migrates.
#include "storage/job_repository.h"

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace gearloop {
namespace {

JobRecord MakeJob(int teeth,
                  const std::string& flank,
                  const std::string& status = "converged") {
  JobRecord job;
  job.kind = "correction";
  job.status = status;
  job.machine_kind = "flat-wheel-grinder";
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

// A unique temporary file path, removed (with its WAL side files) on
// destruction.
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
    for (const char* suffix : {"", "-wal", "-shm"})
      std::remove((path_ + suffix).c_str());
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
  EXPECT_EQ(repo_->SchemaVersion(), 3);
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
  EXPECT_EQ(read->machine_kind, "flat-wheel-grinder");
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

// A job with every traceability field, as a shop would submit it.
JobRecord MakeTracedJob(int teeth,
                        const std::string& part,
                        const std::string& serial,
                        std::vector<int> tooth_numbers) {
  JobRecord job = MakeJob(teeth, "left");
  job.part_number = part;
  job.serial = serial;
  job.tooth_numbers = std::move(tooth_numbers);
  job.measured_at = "2026-11-22T07:45:00Z";
  job.file_name = "part-" + serial + ".mka";
  job.machine_id = "RZ260-2";
  job.submitted_by = "cmm-cell";
  return job;
}

void ExpectSameTrace(const JobRecord& read, const JobRecord& expected) {
  SCOPED_TRACE("job " + std::to_string(read.id));
  EXPECT_EQ(read.part_number, expected.part_number);
  EXPECT_EQ(read.serial, expected.serial);
  EXPECT_EQ(read.tooth_numbers, expected.tooth_numbers);
  EXPECT_EQ(read.measured_at, expected.measured_at);
  EXPECT_EQ(read.file_name, expected.file_name);
  EXPECT_EQ(read.machine_id, expected.machine_id);
  EXPECT_EQ(read.batch_id, expected.batch_id);
  EXPECT_EQ(read.submitted_by, expected.submitted_by);
}

TEST_P(JobRepositoryTest, RoundTripsTraceabilityInEveryReadPath) {
  const int64_t batch = repo_->CreateBatch({"{}"}, "line-3");
  JobRecord traced = MakeTracedJob(37, "4711-A", "S0042", {1, 12, 25});
  traced.batch_id = batch;
  traced.id = repo_->CompleteBatchItem(batch, 0, traced);
  const JobRecord bare = MakeJob(37, "right");
  const int64_t bare_id = repo_->WriteJob(bare);
  ExpectSameTrace(*repo_->ReadJob(traced.id), traced);
  ExpectSameTrace(*repo_->ReadJob(bare_id), bare);
  const JobPage page = repo_->ListJobs(JobFilter{});
  ASSERT_EQ(page.jobs.size(), 2u);
  ExpectSameTrace(page.jobs[1], traced);
  ExpectSameTrace(page.jobs[0], bare);
  ExpectSameTrace(repo_->ReadLineage(traced.id).at(0), traced);
  EXPECT_EQ(repo_->ReadBatch(batch, false)->submitted_by, "line-3");
}

TEST_P(JobRepositoryTest, FiltersByTraceability) {
  const int64_t batch = repo_->CreateBatch({"{}", "{}"}, "");
  JobRecord a = MakeTracedJob(37, "4711-A", "S1", {1, 12});
  a.batch_id = batch;
  a.id = repo_->CompleteBatchItem(batch, 0, a);
  JobRecord b = MakeTracedJob(37, "4711-A", "S2", {2, 21});
  b.machine_id = "RZ260-1";
  b.submitted_by = "planner";
  b.id = repo_->WriteJob(b);
  JobRecord c = MakeTracedJob(37, "0815", "S3", {121});
  c.id = repo_->WriteJob(c);
  repo_->WriteJob(MakeJob(37, "left"));
  const auto ids = [this](const JobFilter& filter) {
    std::vector<int64_t> out;
    for (const JobRecord& job : repo_->ListJobs(filter).jobs)
      out.push_back(job.id);
    return out;
  };
  JobFilter f;
  f.part_number = "4711-A";
  EXPECT_EQ(ids(f), (std::vector<int64_t>{b.id, a.id}));
  f = JobFilter{};
  f.serial = "S3";
  EXPECT_EQ(ids(f), (std::vector<int64_t>{c.id}));
  // A tooth matches whole numbers only: 1 is not 12, 21 or 121.
  f = JobFilter{};
  f.tooth = 1;
  EXPECT_EQ(ids(f), (std::vector<int64_t>{a.id}));
  f.tooth = 21;
  EXPECT_EQ(ids(f), (std::vector<int64_t>{b.id}));
  f = JobFilter{};
  f.machine_id = "RZ260-1";
  EXPECT_EQ(ids(f), (std::vector<int64_t>{b.id}));
  f = JobFilter{};
  f.batch_id = batch;
  EXPECT_EQ(ids(f), (std::vector<int64_t>{a.id}));
  f = JobFilter{};
  f.submitted_by = "planner";
  EXPECT_EQ(ids(f), (std::vector<int64_t>{b.id}));
  f = JobFilter{};
  f.file_name = "part-S1.mka";
  EXPECT_EQ(ids(f), (std::vector<int64_t>{a.id}));
  f.part_number = "0815";
  EXPECT_TRUE(ids(f).empty());
  EXPECT_EQ(repo_->ListJobs(f).total, 0);
}

TEST_P(JobRepositoryTest, RoundTripsMachineKindInEveryReadPath) {
  const int64_t grinder = repo_->WriteJob(MakeJob(37, "right"));
  JobRecord bevel_job = MakeJob(0, "concave");
  bevel_job.machine_kind = "free-form-bevel-generator";
  bevel_job.settings_source_job_id = grinder;
  const int64_t bevel = repo_->WriteJob(bevel_job);

  EXPECT_EQ(repo_->ReadJob(grinder)->machine_kind, "flat-wheel-grinder");
  EXPECT_EQ(repo_->ReadJob(bevel)->machine_kind, "free-form-bevel-generator");
  const JobPage page = repo_->ListJobs(JobFilter{});
  ASSERT_EQ(page.jobs.size(), 2u);
  EXPECT_EQ(page.jobs[0].machine_kind, "free-form-bevel-generator");
  EXPECT_EQ(page.jobs[1].machine_kind, "flat-wheel-grinder");
  const std::vector<JobRecord> lineage = repo_->ReadLineage(grinder);
  ASSERT_EQ(lineage.size(), 2u);
  EXPECT_EQ(lineage[0].machine_kind, "flat-wheel-grinder");
  EXPECT_EQ(lineage[1].machine_kind, "free-form-bevel-generator");

  JobFilter family;
  family.machine_kind = "free-form-bevel-generator";
  const JobPage bevels = repo_->ListJobs(family);
  EXPECT_EQ(bevels.total, 1);
  ASSERT_EQ(bevels.jobs.size(), 1u);
  EXPECT_EQ(bevels.jobs[0].id, bevel);
  family.machine_kind = "flat-wheel-grinder";
  EXPECT_EQ(repo_->ListJobs(family).total, 1);
}

TEST_P(JobRepositoryTest, RefusesJobWithoutMachineKindAndStoresNothing) {
  JobRecord job = MakeJob(37, "right");
  job.machine_kind.clear();
  EXPECT_THROW(repo_->WriteJob(job), StorageError);
  const int64_t batch = repo_->CreateBatch({"{}"});
  EXPECT_THROW(repo_->CompleteBatchItem(batch, 0, job), StorageError);
  EXPECT_EQ(repo_->CountJobs(), 0);
  EXPECT_EQ(repo_->ReadPendingBatchItems().size(), 1u);
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
    JobRecord job = MakeJob(i % 2 == 0 ? 37 : 41,
                            i < 5 ? "right" : "left",
                            i == 3 ? "not_converged" : "converged");
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
  EXPECT_TRUE(
      page.jobs[0].request_json.empty());  // listings carry no documents

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
  // first -> second -> third (each ground with the previous one's settings), a
  // replay of second (same part), and an unrelated job.
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
  for (const JobRecord& job : repo_->ReadLineage(second))
    lineage_ids.push_back(job.id);
  EXPECT_EQ(lineage_ids, (std::vector<int64_t>{first, second, third}));

  lineage_ids.clear();
  for (const JobRecord& job : repo_->ReadLineage(first))
    lineage_ids.push_back(job.id);
  EXPECT_EQ(lineage_ids, (std::vector<int64_t>{first, second, replay, third}));

  EXPECT_EQ(repo_->ReadLineage(unrelated).size(), 1u);
  EXPECT_TRUE(repo_->ReadLineage(9999).empty());
  EXPECT_EQ(repo_->ReadJob(replay)->parent_job_id, second);
}

TEST_P(JobRepositoryTest, RunsBatchBookkeeping) {
  const int64_t batch =
      repo_->CreateBatch({"{\"a\":1}", "{\"a\":2}", "{\"a\":3}"});
  std::optional<BatchRecord> record =
      repo_->ReadBatch(batch, /*with_items=*/true);
  ASSERT_TRUE(record.has_value());
  EXPECT_EQ(record->status, "running");
  EXPECT_EQ(record->total, 3);
  ASSERT_EQ(record->items.size(), 3u);
  EXPECT_EQ(repo_->ReadPendingBatchItems().size(), 3u);

  const int64_t job_id =
      repo_->CompleteBatchItem(batch, 0, MakeJob(37, "right"));
  BatchItemRecord error;
  error.error_status = 422;
  error.error_code = "invalid_value";
  error.error_message = "teeth must be at least 5";
  error.error_field = "gear.teeth";
  repo_->FailBatchItem(batch, 1, error);
  // An item is finished once only.
  EXPECT_THROW(repo_->FailBatchItem(batch, 1, error), StorageError);
  EXPECT_THROW(repo_->CompleteBatchItem(batch, 0, MakeJob(37, "right")),
               StorageError);
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
                         [](const ::testing::TestParamInfo<bool>& info) {
                           return info.param ? "File" : "Memory";
                         });

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
  EXPECT_EQ(repo->SchemaVersion(), 3);
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
    ASSERT_EQ(sqlite3_exec(
                  db, "PRAGMA user_version = 99;", nullptr, nullptr, nullptr),
              SQLITE_OK);
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
  ASSERT_EQ(
      sqlite3_prepare_v2(db, "PRAGMA journal_mode;", -1, &statement, nullptr),
      SQLITE_OK);
  ASSERT_EQ(sqlite3_step(statement), SQLITE_ROW);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(statement, 0)),
               "wal");
  sqlite3_finalize(statement);
  ASSERT_EQ(
      sqlite3_prepare_v2(db, "PRAGMA user_version;", -1, &statement, nullptr),
      SQLITE_OK);
  ASSERT_EQ(sqlite3_step(statement), SQLITE_ROW);
  EXPECT_EQ(sqlite3_column_int(statement, 0), 3);
  sqlite3_finalize(statement);
  sqlite3_close(db);
}

// The schema release 0.1.0 writes (PRAGMA user_version 1): its CreateJobTable,
// CreateBatchTable and CreateBatchItemTable statements, verbatim. History files
// in the field hold exactly this; never edit it.
constexpr const char* kRelease010Schema =
    "CREATE TABLE IF NOT EXISTS jobs ("
    "  job_id INTEGER PRIMARY KEY AUTOINCREMENT,"
    "  created_utc TEXT NOT NULL,"
    "  kind TEXT NOT NULL,"
    "  status TEXT NOT NULL,"
    "  gear_teeth INTEGER NOT NULL,"
    "  gear_normal_module_mm REAL NOT NULL,"
    "  gear_helix_angle_deg REAL NOT NULL,"
    "  gear_hand TEXT NOT NULL,"
    "  flank TEXT NOT NULL,"
    "  request_json TEXT NOT NULL,"
    "  result_json TEXT NOT NULL,"
    "  residual_rms_um REAL,"
    "  best_reachable_rms_um REAL,"
    "  rank INTEGER,"
    "  elapsed_ms REAL NOT NULL,"
    "  server_version TEXT NOT NULL,"
    "  parent_job_id INTEGER REFERENCES jobs(job_id) ON DELETE SET NULL,"
    "  settings_source_job_id INTEGER REFERENCES jobs(job_id) ON DELETE SET "
    "NULL);"
    "CREATE INDEX IF NOT EXISTS jobs_gear ON jobs(gear_teeth, "
    "gear_normal_module_mm);"
    "CREATE INDEX IF NOT EXISTS jobs_created ON jobs(created_utc);"
    "CREATE INDEX IF NOT EXISTS jobs_parent ON jobs(parent_job_id);"
    "CREATE INDEX IF NOT EXISTS jobs_settings_source ON "
    "jobs(settings_source_job_id);"
    "CREATE TABLE IF NOT EXISTS batches ("
    "  batch_id INTEGER PRIMARY KEY AUTOINCREMENT,"
    "  created_utc TEXT NOT NULL,"
    "  finished_utc TEXT,"
    "  status TEXT NOT NULL,"
    "  total_items INTEGER NOT NULL,"
    "  done_items INTEGER NOT NULL DEFAULT 0,"
    "  failed_items INTEGER NOT NULL DEFAULT 0);"
    "CREATE TABLE IF NOT EXISTS batch_items ("
    "  batch_id INTEGER NOT NULL REFERENCES batches(batch_id) ON DELETE "
    "CASCADE,"
    "  item_index INTEGER NOT NULL,"
    "  state TEXT NOT NULL DEFAULT 'pending',"
    "  request_json TEXT NOT NULL,"
    "  job_id INTEGER REFERENCES jobs(job_id) ON DELETE SET NULL,"
    "  error_status INTEGER,"
    "  error_code TEXT,"
    "  error_message TEXT,"
    "  error_field TEXT,"
    "  PRIMARY KEY (batch_id, item_index));"
    "CREATE INDEX IF NOT EXISTS batch_items_state ON batch_items(state);";
constexpr int kRelease010UserVersion = 1;

// Release 0.1.0's INSERT of a job, verbatim (no machine_kind).
constexpr const char* kRelease010InsertJob =
    "INSERT INTO jobs (created_utc, kind, status, gear_teeth, "
    "gear_normal_module_mm, gear_helix_angle_deg,"
    " gear_hand, flank, request_json, result_json, residual_rms_um, "
    "best_reachable_rms_um, rank, elapsed_ms,"
    " server_version, parent_job_id, settings_source_job_id)"
    " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, "
    "?15, ?16, ?17);";

void ExecRaw(sqlite3* db, const std::string& sql) {
  char* message = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &message);
  EXPECT_EQ(rc, SQLITE_OK) << sql << ": "
                           << (message != nullptr ? message : "");
  sqlite3_free(message);
}

int ReadRawUserVersion(const std::string& path) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* statement = nullptr;
  EXPECT_EQ(
      sqlite3_prepare_v2(db, "PRAGMA user_version;", -1, &statement, nullptr),
      SQLITE_OK);
  EXPECT_EQ(sqlite3_step(statement), SQLITE_ROW);
  const int version = sqlite3_column_int(statement, 0);
  sqlite3_finalize(statement);
  sqlite3_close(db);
  return version;
}

// Stores `job` the way release 0.1.0 did and returns its id.
int64_t InsertRelease010Job(sqlite3* db, const JobRecord& job) {
  sqlite3_stmt* s = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(db, kRelease010InsertJob, -1, &s, nullptr),
            SQLITE_OK);
  const auto bind_text = [s](int index, const std::string& text) {
    EXPECT_EQ(sqlite3_bind_text(s, index, text.c_str(), -1, SQLITE_TRANSIENT),
              SQLITE_OK);
  };
  const auto bind_optional_double = [s](int index,
                                        const std::optional<double>& value) {
    EXPECT_EQ(value ? sqlite3_bind_double(s, index, *value)
                    : sqlite3_bind_null(s, index),
              SQLITE_OK);
  };
  const auto bind_optional_int64 = [s](int index,
                                       const std::optional<int64_t>& value) {
    EXPECT_EQ(value ? sqlite3_bind_int64(s, index, *value)
                    : sqlite3_bind_null(s, index),
              SQLITE_OK);
  };
  bind_text(1, job.created_utc);
  bind_text(2, job.kind);
  bind_text(3, job.status);
  EXPECT_EQ(sqlite3_bind_int(s, 4, job.gear_teeth), SQLITE_OK);
  EXPECT_EQ(sqlite3_bind_double(s, 5, job.gear_normal_module_mm), SQLITE_OK);
  EXPECT_EQ(sqlite3_bind_double(s, 6, job.gear_helix_angle_deg), SQLITE_OK);
  bind_text(7, job.gear_hand);
  bind_text(8, job.flank);
  bind_text(9, job.request_json);
  bind_text(10, job.result_json);
  bind_optional_double(11, job.residual_rms_um);
  bind_optional_double(12, job.best_reachable_rms_um);
  bind_optional_int64(
      13, job.rank ? std::optional<int64_t>(*job.rank) : std::nullopt);
  EXPECT_EQ(sqlite3_bind_double(s, 14, job.elapsed_ms), SQLITE_OK);
  bind_text(15, job.server_version);
  bind_optional_int64(16, job.parent_job_id);
  bind_optional_int64(17, job.settings_source_job_id);
  EXPECT_EQ(sqlite3_step(s), SQLITE_DONE);
  sqlite3_finalize(s);
  return sqlite3_last_insert_rowid(db);
}

// Every field but machine_kind; the JSON texts only when `with_documents`.
void ExpectSameJob(const JobRecord& read,
                   const JobRecord& expected,
                   bool with_documents) {
  SCOPED_TRACE("job " + std::to_string(expected.id));
  EXPECT_EQ(read.id, expected.id);
  EXPECT_EQ(read.created_utc, expected.created_utc);
  EXPECT_EQ(read.kind, expected.kind);
  EXPECT_EQ(read.status, expected.status);
  EXPECT_EQ(read.gear_teeth, expected.gear_teeth);
  EXPECT_EQ(read.gear_normal_module_mm, expected.gear_normal_module_mm);
  EXPECT_EQ(read.gear_helix_angle_deg, expected.gear_helix_angle_deg);
  EXPECT_EQ(read.gear_hand, expected.gear_hand);
  EXPECT_EQ(read.flank, expected.flank);
  EXPECT_EQ(read.request_json, with_documents ? expected.request_json : "");
  EXPECT_EQ(read.result_json, with_documents ? expected.result_json : "");
  EXPECT_EQ(read.residual_rms_um, expected.residual_rms_um);
  EXPECT_EQ(read.best_reachable_rms_um, expected.best_reachable_rms_um);
  EXPECT_EQ(read.rank, expected.rank);
  EXPECT_EQ(read.elapsed_ms, expected.elapsed_ms);
  EXPECT_EQ(read.server_version, expected.server_version);
  EXPECT_EQ(read.parent_job_id, expected.parent_job_id);
  EXPECT_EQ(read.settings_source_job_id, expected.settings_source_job_id);
}

TEST(OpenJobRepository, MigratesAFileOfRelease010) {
  TempDatabasePath temp;
  // A history file as release 0.1.0 leaves it: a grinder job, a bevel job
  // (flank convex), a bevel job ground with its settings (flank concave, no
  // rank, no reachable figure), a grinder replay, and a batch with one done and
  // one pending item.
  JobRecord grinder = MakeJob(37, "right");
  grinder.created_utc = "2026-11-20T08:00:00.000Z";
  grinder.server_version = "0.1.0";
  JobRecord bevel;
  bevel.created_utc = "2026-11-20T09:30:00.125Z";
  bevel.kind = "closed_loop";
  bevel.status = "not_converged";
  bevel.gear_hand = "left";
  bevel.flank = "convex";
  bevel.request_json = R"({"machine":{"kind":"free-form-bevel-generator"}})";
  bevel.result_json =
      R"({"machine_kind":"free-form-bevel-generator","side":"convex"})";
  bevel.residual_rms_um = 1.25;
  bevel.best_reachable_rms_um = 0.75;
  bevel.rank = 9;
  bevel.elapsed_ms = 12.0;
  bevel.server_version = "0.1.0";
  JobRecord next_bevel = bevel;
  next_bevel.created_utc = "2026-11-20T09:30:01.500Z";
  next_bevel.flank = "concave";
  next_bevel.best_reachable_rms_um.reset();
  next_bevel.rank.reset();
  JobRecord replay = MakeJob(37, "left");
  replay.created_utc = "2026-11-21T10:00:00.000Z";
  replay.kind = "replay";
  replay.gear_hand = "";
  replay.server_version = "0.1.0";
  int64_t batch = 0;
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(temp.path().c_str(), &db), SQLITE_OK);
    ExecRaw(db,
            "PRAGMA foreign_keys = ON; PRAGMA journal_mode = WAL; PRAGMA "
            "synchronous = NORMAL;");
    ExecRaw(db, "BEGIN IMMEDIATE;");
    ExecRaw(db, kRelease010Schema);
    ExecRaw(db,
            "PRAGMA user_version = " + std::to_string(kRelease010UserVersion) +
                ";");
    ExecRaw(db, "COMMIT;");
    grinder.id = InsertRelease010Job(db, grinder);
    bevel.id = InsertRelease010Job(db, bevel);
    next_bevel.settings_source_job_id = bevel.id;
    next_bevel.id = InsertRelease010Job(db, next_bevel);
    replay.parent_job_id = grinder.id;
    replay.id = InsertRelease010Job(db, replay);
    ExecRaw(
        db,
        "INSERT INTO batches (created_utc, total_items, status, finished_utc)"
        " VALUES ('2026-11-21T11:00:00.000Z', 2, 'running', NULL);");
    batch = sqlite3_last_insert_rowid(db);
    ExecRaw(db,
            "INSERT INTO batch_items (batch_id, item_index, request_json) "
            "VALUES (" +
                std::to_string(batch) + ", 0, '{}'), (" +
                std::to_string(batch) + ", 1, '{}');");
    ExecRaw(db,
            "UPDATE batch_items SET state = 'done', job_id = " +
                std::to_string(grinder.id) + " WHERE batch_id = " +
                std::to_string(batch) + " AND item_index = 0;");
    ExecRaw(db,
            "UPDATE batches SET done_items = 1 WHERE batch_id = " +
                std::to_string(batch) + ";");
    sqlite3_close(db);
  }
  ASSERT_EQ(ReadRawUserVersion(temp.path()), kRelease010UserVersion);
  const std::vector<std::pair<JobRecord, std::string>> expected = {
      {grinder, "flat-wheel-grinder"},
      {bevel, "free-form-bevel-generator"},
      {next_bevel, "free-form-bevel-generator"},
      {replay, "flat-wheel-grinder"},
  };

  // Opened twice: the first open migrates, the second finds nothing left to do.
  for (int open = 0; open < 2; ++open) {
    SCOPED_TRACE(open == 0 ? "first open" : "reopen");
    std::unique_ptr<JobRepository> repo = OpenJobRepository(temp.path());
    EXPECT_EQ(repo->SchemaVersion(), 3);
    EXPECT_EQ(repo->IntegrityCheck(), "ok");
    EXPECT_EQ(repo->CountJobs(), 4);
    for (const auto& [job, machine_kind] : expected) {
      const std::optional<JobRecord> read = repo->ReadJob(job.id);
      ASSERT_TRUE(read.has_value());
      ExpectSameJob(*read, job, /*with_documents=*/true);
      EXPECT_EQ(read->machine_kind, machine_kind);
    }
    const JobPage page = repo->ListJobs(JobFilter{});
    ASSERT_EQ(page.jobs.size(), expected.size());
    for (size_t i = 0; i < expected.size(); ++i) {
      // Newest first.
      const auto& [job, machine_kind] = expected[expected.size() - 1 - i];
      ExpectSameJob(page.jobs[i], job, /*with_documents=*/false);
      EXPECT_EQ(page.jobs[i].machine_kind, machine_kind);
    }
    const std::vector<JobRecord> lineage = repo->ReadLineage(bevel.id);
    ASSERT_EQ(lineage.size(), 2u);
    EXPECT_EQ(lineage[1].id, next_bevel.id);
    EXPECT_EQ(lineage[1].machine_kind, "free-form-bevel-generator");
    const std::optional<BatchRecord> record =
        repo->ReadBatch(batch, /*with_items=*/true);
    ASSERT_TRUE(record.has_value());
    EXPECT_EQ(record->done, 1);
    ASSERT_EQ(record->items.size(), 2u);
    EXPECT_EQ(record->items[0].job_id, grinder.id);
    ASSERT_EQ(repo->ReadPendingBatchItems().size(), 1u);
  }
  EXPECT_EQ(ReadRawUserVersion(temp.path()), 3);

  // The migrated file takes new jobs of either family.
  std::unique_ptr<JobRepository> repo = OpenJobRepository(temp.path());
  JobRecord new_bevel = bevel;
  new_bevel.created_utc.clear();
  new_bevel.machine_kind = "free-form-bevel-generator";
  const int64_t id = repo->WriteJob(new_bevel);
  EXPECT_EQ(repo->ReadJob(id)->machine_kind, "free-form-bevel-generator");
  EXPECT_EQ(repo->CountJobs(), 5);
}

// Schema version 2 as the server after release 0.1.0 left it: release 0.1.0's
// tables and the machine_kind column.
constexpr const char* kVersion2Step =
    "ALTER TABLE jobs ADD COLUMN machine_kind TEXT NOT NULL DEFAULT '';"
    "PRAGMA user_version = 2;";

TEST(OpenJobRepository, MigratesAFileOfSchemaVersion2) {
  TempDatabasePath temp;
  JobRecord grinder = MakeJob(37, "right");
  grinder.created_utc = "2026-11-22T08:00:00.000Z";
  int64_t batch = 0;
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(temp.path().c_str(), &db), SQLITE_OK);
    ExecRaw(db, "PRAGMA foreign_keys = ON; PRAGMA journal_mode = WAL;");
    ExecRaw(db, kRelease010Schema);
    ExecRaw(db, kVersion2Step);
    grinder.id = InsertRelease010Job(db, grinder);
    ExecRaw(db,
            "UPDATE jobs SET machine_kind = 'flat-wheel-grinder' WHERE "
            "job_id = " +
                std::to_string(grinder.id) + ";");
    ExecRaw(db,
            "INSERT INTO batches (created_utc, total_items, status)"
            " VALUES ('2026-11-22T09:00:00.000Z', 1, 'running');");
    batch = sqlite3_last_insert_rowid(db);
    ExecRaw(db,
            "INSERT INTO batch_items (batch_id, item_index, request_json) "
            "VALUES (" +
                std::to_string(batch) + ", 0, '{}');");
    sqlite3_close(db);
  }
  ASSERT_EQ(ReadRawUserVersion(temp.path()), 2);
  for (int open = 0; open < 2; ++open) {
    SCOPED_TRACE(open == 0 ? "first open" : "reopen");
    std::unique_ptr<JobRepository> repo = OpenJobRepository(temp.path());
    EXPECT_EQ(repo->SchemaVersion(), 3);
    EXPECT_EQ(repo->IntegrityCheck(), "ok");
    const std::optional<JobRecord> read = repo->ReadJob(grinder.id);
    ASSERT_TRUE(read.has_value());
    ExpectSameJob(*read, grinder, /*with_documents=*/true);
    EXPECT_EQ(read->machine_kind, "flat-wheel-grinder");
    // Stored before traceability: none of it.
    ExpectSameTrace(*read, JobRecord{});
    const std::vector<PendingBatchItem> pending = repo->ReadPendingBatchItems();
    ASSERT_EQ(pending.size(), 1u);
    EXPECT_EQ(pending[0].submitted_by, "");
  }
  EXPECT_EQ(ReadRawUserVersion(temp.path()), 3);
  // The migrated file takes traced jobs into its old batch.
  std::unique_ptr<JobRepository> repo = OpenJobRepository(temp.path());
  JobRecord traced = MakeTracedJob(37, "4711-A", "S7", {3});
  traced.batch_id = batch;
  traced.id = repo->CompleteBatchItem(batch, 0, traced);
  ExpectSameTrace(*repo->ReadJob(traced.id), traced);
  JobFilter filter;
  filter.batch_id = batch;
  EXPECT_EQ(repo->ListJobs(filter).total, 1);
}

TEST(OpenJobRepository, ThrowsStorageErrorForUnopenablePath) {
  EXPECT_THROW(OpenJobRepository("/nonexistent-dir/gearloop.sqlite"),
               StorageError);
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
