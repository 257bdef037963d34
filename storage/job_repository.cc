// SQLite implementation of JobRepository (shape after COLMAP's
// database_sqlite.cc).
#include "storage/job_repository.h"

#include <sqlite3.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <functional>
#include <mutex>
#include <string>
#include <utility>

namespace gearloop {
namespace {

// Throws StorageError for any return code other than OK / ROW / DONE, naming
// the call site.
void CheckSqlite(
    int rc, sqlite3* db, const char* file, int line, const char* expression) {
  if (rc == SQLITE_OK || rc == SQLITE_ROW || rc == SQLITE_DONE) return;
  std::string message = std::string("SQLite error at ") + file + ":" +
                        std::to_string(line) + " (" + expression +
                        "): " + sqlite3_errstr(rc);
  if (db != nullptr) message += std::string(": ") + sqlite3_errmsg(db);
  throw StorageError(message);
}

#define SQLITE3_CALL(db, expression) \
  CheckSqlite((expression), (db), __FILE__, __LINE__, #expression)

// Resets a prepared statement and clears its bindings when the scope ends,
// whatever happens in between (COLMAP's Sqlite3StmtContext).
class StatementScope {
 public:
  explicit StatementScope(sqlite3_stmt* statement) : statement_(statement) {}
  ~StatementScope() {
    sqlite3_reset(statement_);
    sqlite3_clear_bindings(statement_);
  }
  StatementScope(const StatementScope&) = delete;
  StatementScope& operator=(const StatementScope&) = delete;

 private:
  sqlite3_stmt* statement_;
};

// BEGIN IMMEDIATE on construction, ROLLBACK on destruction unless Commit() ran:
// a write either lands whole or not at all (COLMAP's DatabaseTransaction).
class Transaction {
 public:
  explicit Transaction(sqlite3* db) : db_(db) {
    SQLITE3_CALL(
        db_, sqlite3_exec(db_, "BEGIN IMMEDIATE;", nullptr, nullptr, nullptr));
  }
  ~Transaction() {
    if (!committed_) sqlite3_exec(db_, "ROLLBACK;", nullptr, nullptr, nullptr);
  }
  void Commit() {
    SQLITE3_CALL(db_, sqlite3_exec(db_, "COMMIT;", nullptr, nullptr, nullptr));
    committed_ = true;
  }
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;

 private:
  sqlite3* db_;
  bool committed_ = false;
};

// The summary columns of a job, in the order ReadJobColumns expects them.
constexpr const char* kJobSummaryColumns =
    "job_id, created_utc, kind, status, gear_teeth, gear_normal_module_mm, "
    "gear_helix_angle_deg, "
    "gear_hand, flank, residual_rms_um, best_reachable_rms_um, rank, "
    "elapsed_ms, server_version, "
    "parent_job_id, settings_source_job_id, machine_kind, part_number, "
    "serial, tooth_numbers, measured_at, file_name, machine_id, batch_id, "
    "submitted_by";
constexpr int kNumJobSummaryColumns = 25;

// Tooth numbers are kept as "1,5,9" (storage never parses JSON).
std::string ToothNumbersText(const std::vector<int>& teeth) {
  std::string text;
  for (size_t i = 0; i < teeth.size(); ++i)
    text += (i == 0 ? "" : ",") + std::to_string(teeth[i]);
  return text;
}

std::vector<int> ParseToothNumbers(const std::string& text) {
  std::vector<int> teeth;
  size_t start = 0;
  while (start < text.size()) {
    size_t end = text.find(',', start);
    if (end == std::string::npos) end = text.size();
    teeth.push_back(std::atoi(text.substr(start, end - start).c_str()));
    start = end + 1;
  }
  return teeth;
}

std::string ColumnText(sqlite3_stmt* statement, int column) {
  const unsigned char* text = sqlite3_column_text(statement, column);
  if (text == nullptr) return std::string();
  return std::string(reinterpret_cast<const char*>(text),
                     sqlite3_column_bytes(statement, column));
}

std::optional<double> ColumnOptionalDouble(sqlite3_stmt* statement,
                                           int column) {
  if (sqlite3_column_type(statement, column) == SQLITE_NULL)
    return std::nullopt;
  return sqlite3_column_double(statement, column);
}

std::optional<int64_t> ColumnOptionalInt64(sqlite3_stmt* statement,
                                           int column) {
  if (sqlite3_column_type(statement, column) == SQLITE_NULL)
    return std::nullopt;
  return sqlite3_column_int64(statement, column);
}

JobRecord ReadJobColumns(sqlite3_stmt* statement, bool with_documents) {
  JobRecord job;
  job.id = sqlite3_column_int64(statement, 0);
  job.created_utc = ColumnText(statement, 1);
  job.kind = ColumnText(statement, 2);
  job.status = ColumnText(statement, 3);
  job.gear_teeth = sqlite3_column_int(statement, 4);
  job.gear_normal_module_mm = sqlite3_column_double(statement, 5);
  job.gear_helix_angle_deg = sqlite3_column_double(statement, 6);
  job.gear_hand = ColumnText(statement, 7);
  job.flank = ColumnText(statement, 8);
  job.residual_rms_um = ColumnOptionalDouble(statement, 9);
  job.best_reachable_rms_um = ColumnOptionalDouble(statement, 10);
  if (sqlite3_column_type(statement, 11) != SQLITE_NULL)
    job.rank = sqlite3_column_int(statement, 11);
  job.elapsed_ms = sqlite3_column_double(statement, 12);
  job.server_version = ColumnText(statement, 13);
  job.parent_job_id = ColumnOptionalInt64(statement, 14);
  job.settings_source_job_id = ColumnOptionalInt64(statement, 15);
  job.machine_kind = ColumnText(statement, 16);
  job.part_number = ColumnText(statement, 17);
  job.serial = ColumnText(statement, 18);
  job.tooth_numbers = ParseToothNumbers(ColumnText(statement, 19));
  job.measured_at = ColumnText(statement, 20);
  job.file_name = ColumnText(statement, 21);
  job.machine_id = ColumnText(statement, 22);
  job.batch_id = ColumnOptionalInt64(statement, 23);
  job.submitted_by = ColumnText(statement, 24);
  if (with_documents) {
    job.request_json = ColumnText(statement, kNumJobSummaryColumns);
    job.result_json = ColumnText(statement, kNumJobSummaryColumns + 1);
  }
  return job;
}

BatchItemState ParseBatchItemState(const std::string& text) {
  if (text == "done") return BatchItemState::kDone;
  if (text == "failed") return BatchItemState::kFailed;
  return BatchItemState::kPending;
}

class SqliteJobRepository : public JobRepository {
 public:
  explicit SqliteJobRepository(const std::string& path) {
    const int flags =
        SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX;
    const int rc = sqlite3_open_v2(path.c_str(), &db_, flags, nullptr);
    if (rc != SQLITE_OK) {
      std::string message =
          "cannot open database '" + path + "': " + sqlite3_errstr(rc);
      if (db_ != nullptr) sqlite3_close_v2(db_);
      throw StorageError(message);
    }
    try {
      SQLITE3_CALL(db_, sqlite3_busy_timeout(db_, 5000));
      Exec("PRAGMA foreign_keys = ON;");
      // In-memory databases silently stay in "memory" journal mode; that is
      // fine.
      Exec("PRAGMA journal_mode = WAL;");
      // With WAL, NORMAL loses no committed transaction when the process dies;
      // only a power failure may roll back the last few (COLMAP's OFF suits a
      // batch tool, not a service).
      Exec("PRAGMA synchronous = NORMAL;");
      Migrate();
      PrepareStatements();
    } catch (...) {
      FinalizeStatements();
      sqlite3_close_v2(db_);
      throw;
    }
  }

  ~SqliteJobRepository() override {
    FinalizeStatements();
    sqlite3_close_v2(db_);
  }

  int64_t WriteJob(const JobRecord& job) override {
    std::lock_guard<std::mutex> lock(mutex_);
    Transaction transaction(db_);
    const int64_t id = InsertJob(job);
    transaction.Commit();
    return id;
  }

  std::optional<JobRecord> ReadJob(int64_t id) override {
    std::lock_guard<std::mutex> lock(mutex_);
    StatementScope scope(stmt_read_job_);
    SQLITE3_CALL(db_, sqlite3_bind_int64(stmt_read_job_, 1, id));
    if (!StepRow(stmt_read_job_)) return std::nullopt;
    return ReadJobColumns(stmt_read_job_, /*with_documents=*/true);
  }

  bool JobExists(int64_t id) override {
    std::lock_guard<std::mutex> lock(mutex_);
    StatementScope scope(stmt_job_exists_);
    SQLITE3_CALL(db_, sqlite3_bind_int64(stmt_job_exists_, 1, id));
    return StepRow(stmt_job_exists_);
  }

  JobPage ListJobs(const JobFilter& filter) override {
    std::lock_guard<std::mutex> lock(mutex_);
    JobPage page;
    {
      StatementScope scope(stmt_count_filtered_jobs_);
      BindFilter(stmt_count_filtered_jobs_, filter);
      SQLITE3_CALL(db_, sqlite3_step(stmt_count_filtered_jobs_));
      page.total = sqlite3_column_int64(stmt_count_filtered_jobs_, 0);
    }
    StatementScope scope(stmt_list_jobs_);
    BindFilter(stmt_list_jobs_, filter);
    const int limit =
        filter.limit < 1 ? 1 : (filter.limit > 1000 ? 1000 : filter.limit);
    SQLITE3_CALL(db_, sqlite3_bind_int(stmt_list_jobs_, 9, limit));
    SQLITE3_CALL(
        db_,
        sqlite3_bind_int(
            stmt_list_jobs_, 10, filter.offset < 0 ? 0 : filter.offset));
    while (StepRow(stmt_list_jobs_)) {
      page.jobs.push_back(
          ReadJobColumns(stmt_list_jobs_, /*with_documents=*/false));
    }
    return page;
  }

  int64_t CountJobs() override {
    std::lock_guard<std::mutex> lock(mutex_);
    StatementScope scope(stmt_count_jobs_);
    SQLITE3_CALL(db_, sqlite3_step(stmt_count_jobs_));
    return sqlite3_column_int64(stmt_count_jobs_, 0);
  }

  std::vector<JobRecord> ReadLineage(int64_t id) override {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<JobRecord> jobs;
    StatementScope scope(stmt_read_lineage_);
    SQLITE3_CALL(db_, sqlite3_bind_int64(stmt_read_lineage_, 1, id));
    while (StepRow(stmt_read_lineage_)) {
      jobs.push_back(
          ReadJobColumns(stmt_read_lineage_, /*with_documents=*/false));
    }
    return jobs;
  }

  int64_t CreateBatch(const std::vector<std::string>& item_requests_json,
                      const std::string& submitted_by) override {
    std::lock_guard<std::mutex> lock(mutex_);
    Transaction transaction(db_);
    int64_t batch_id = 0;
    {
      StatementScope scope(stmt_insert_batch_);
      const std::string now = CurrentUtcIso8601();
      SQLITE3_CALL(
          db_,
          sqlite3_bind_text(
              stmt_insert_batch_, 1, now.c_str(), -1, SQLITE_TRANSIENT));
      SQLITE3_CALL(
          db_,
          sqlite3_bind_int(stmt_insert_batch_,
                           2,
                           static_cast<int>(item_requests_json.size())));
      SQLITE3_CALL(
          db_,
          sqlite3_bind_text(stmt_insert_batch_,
                            3,
                            item_requests_json.empty() ? "finished" : "running",
                            -1,
                            SQLITE_STATIC));
      if (item_requests_json.empty()) {
        SQLITE3_CALL(
            db_,
            sqlite3_bind_text(
                stmt_insert_batch_, 4, now.c_str(), -1, SQLITE_TRANSIENT));
      } else {
        SQLITE3_CALL(db_, sqlite3_bind_null(stmt_insert_batch_, 4));
      }
      BindNonEmptyText(stmt_insert_batch_, 5, submitted_by);
      SQLITE3_CALL(db_, sqlite3_step(stmt_insert_batch_));
      batch_id = sqlite3_last_insert_rowid(db_);
    }
    for (size_t i = 0; i < item_requests_json.size(); ++i) {
      StatementScope scope(stmt_insert_batch_item_);
      SQLITE3_CALL(db_,
                   sqlite3_bind_int64(stmt_insert_batch_item_, 1, batch_id));
      SQLITE3_CALL(
          db_,
          sqlite3_bind_int(stmt_insert_batch_item_, 2, static_cast<int>(i)));
      SQLITE3_CALL(
          db_,
          sqlite3_bind_text(stmt_insert_batch_item_,
                            3,
                            item_requests_json[i].data(),
                            static_cast<int>(item_requests_json[i].size()),
                            SQLITE_STATIC));
      SQLITE3_CALL(db_, sqlite3_step(stmt_insert_batch_item_));
    }
    transaction.Commit();
    return batch_id;
  }

  int64_t CompleteBatchItem(int64_t batch_id,
                            int index,
                            const JobRecord& job) override {
    std::lock_guard<std::mutex> lock(mutex_);
    Transaction transaction(db_);
    const int64_t job_id = InsertJob(job);
    {
      StatementScope scope(stmt_complete_batch_item_);
      SQLITE3_CALL(db_,
                   sqlite3_bind_int64(stmt_complete_batch_item_, 1, job_id));
      SQLITE3_CALL(db_,
                   sqlite3_bind_int64(stmt_complete_batch_item_, 2, batch_id));
      SQLITE3_CALL(db_, sqlite3_bind_int(stmt_complete_batch_item_, 3, index));
      StepPendingItemUpdate(stmt_complete_batch_item_, batch_id, index);
    }
    UpdateBatchCounters(batch_id);
    transaction.Commit();
    return job_id;
  }

  void FailBatchItem(int64_t batch_id,
                     int index,
                     const BatchItemRecord& error) override {
    std::lock_guard<std::mutex> lock(mutex_);
    Transaction transaction(db_);
    {
      sqlite3_stmt* s = stmt_fail_batch_item_;
      StatementScope scope(s);
      SQLITE3_CALL(db_, sqlite3_bind_int(s, 1, error.error_status));
      SQLITE3_CALL(db_,
                   sqlite3_bind_text(
                       s, 2, error.error_code.c_str(), -1, SQLITE_TRANSIENT));
      SQLITE3_CALL(
          db_,
          sqlite3_bind_text(
              s, 3, error.error_message.c_str(), -1, SQLITE_TRANSIENT));
      SQLITE3_CALL(db_,
                   sqlite3_bind_text(
                       s, 4, error.error_field.c_str(), -1, SQLITE_TRANSIENT));
      SQLITE3_CALL(db_, sqlite3_bind_int64(s, 5, batch_id));
      SQLITE3_CALL(db_, sqlite3_bind_int(s, 6, index));
      StepPendingItemUpdate(s, batch_id, index);
    }
    UpdateBatchCounters(batch_id);
    transaction.Commit();
  }

  std::optional<BatchRecord> ReadBatch(int64_t id, bool with_items) override {
    std::lock_guard<std::mutex> lock(mutex_);
    BatchRecord batch;
    {
      StatementScope scope(stmt_read_batch_);
      SQLITE3_CALL(db_, sqlite3_bind_int64(stmt_read_batch_, 1, id));
      if (!StepRow(stmt_read_batch_)) return std::nullopt;
      batch.id = sqlite3_column_int64(stmt_read_batch_, 0);
      batch.created_utc = ColumnText(stmt_read_batch_, 1);
      batch.finished_utc = ColumnText(stmt_read_batch_, 2);
      batch.status = ColumnText(stmt_read_batch_, 3);
      batch.total = sqlite3_column_int(stmt_read_batch_, 4);
      batch.done = sqlite3_column_int(stmt_read_batch_, 5);
      batch.failed = sqlite3_column_int(stmt_read_batch_, 6);
      batch.submitted_by = ColumnText(stmt_read_batch_, 7);
    }
    if (!with_items) return batch;
    StatementScope scope(stmt_read_batch_items_);
    SQLITE3_CALL(db_, sqlite3_bind_int64(stmt_read_batch_items_, 1, id));
    while (StepRow(stmt_read_batch_items_)) {
      BatchItemRecord item;
      item.index = sqlite3_column_int(stmt_read_batch_items_, 0);
      item.state = ParseBatchItemState(ColumnText(stmt_read_batch_items_, 1));
      item.job_id = ColumnOptionalInt64(stmt_read_batch_items_, 2);
      item.error_status = sqlite3_column_int(stmt_read_batch_items_, 3);
      item.error_code = ColumnText(stmt_read_batch_items_, 4);
      item.error_message = ColumnText(stmt_read_batch_items_, 5);
      item.error_field = ColumnText(stmt_read_batch_items_, 6);
      batch.items.push_back(std::move(item));
    }
    return batch;
  }

  std::vector<PendingBatchItem> ReadPendingBatchItems() override {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<PendingBatchItem> items;
    StatementScope scope(stmt_read_pending_items_);
    while (StepRow(stmt_read_pending_items_)) {
      PendingBatchItem item;
      item.batch_id = sqlite3_column_int64(stmt_read_pending_items_, 0);
      item.index = sqlite3_column_int(stmt_read_pending_items_, 1);
      item.request_json = ColumnText(stmt_read_pending_items_, 2);
      item.submitted_by = ColumnText(stmt_read_pending_items_, 3);
      items.push_back(std::move(item));
    }
    return items;
  }

  int SchemaVersion() override {
    std::lock_guard<std::mutex> lock(mutex_);
    return ReadUserVersion();
  }

  std::string IntegrityCheck() override {
    std::lock_guard<std::mutex> lock(mutex_);
    sqlite3_stmt* statement = nullptr;
    SQLITE3_CALL(db_,
                 sqlite3_prepare_v2(
                     db_, "PRAGMA integrity_check;", -1, &statement, nullptr));
    std::string result;
    while (sqlite3_step(statement) == SQLITE_ROW) {
      if (!result.empty()) result += "\n";
      result += ColumnText(statement, 0);
    }
    sqlite3_finalize(statement);
    return result;
  }

 private:
  void Exec(const char* sql) {
    SQLITE3_CALL(db_, sqlite3_exec(db_, sql, nullptr, nullptr, nullptr));
  }

  int ReadUserVersion() {
    sqlite3_stmt* statement = nullptr;
    SQLITE3_CALL(db_,
                 sqlite3_prepare_v2(
                     db_, "PRAGMA user_version;", -1, &statement, nullptr));
    int version = 0;
    if (sqlite3_step(statement) == SQLITE_ROW)
      version = sqlite3_column_int(statement, 0);
    sqlite3_finalize(statement);
    return version;
  }

  // --- Schema
  // -----------------------------------------------------------------------------
  // The tables as schema version 1 (release 0.1.0) created them; later columns
  // are added by the migration steps below, so these statements stay as
  // released.
  void CreateJobTable() {
    Exec(
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
        "  settings_source_job_id INTEGER REFERENCES jobs(job_id) ON DELETE "
        "SET NULL);"
        "CREATE INDEX IF NOT EXISTS jobs_gear ON jobs(gear_teeth, "
        "gear_normal_module_mm);"
        "CREATE INDEX IF NOT EXISTS jobs_created ON jobs(created_utc);"
        "CREATE INDEX IF NOT EXISTS jobs_parent ON jobs(parent_job_id);"
        "CREATE INDEX IF NOT EXISTS jobs_settings_source ON "
        "jobs(settings_source_job_id);");
  }

  void CreateBatchTable() {
    Exec(
        "CREATE TABLE IF NOT EXISTS batches ("
        "  batch_id INTEGER PRIMARY KEY AUTOINCREMENT,"
        "  created_utc TEXT NOT NULL,"
        "  finished_utc TEXT,"
        "  status TEXT NOT NULL,"
        "  total_items INTEGER NOT NULL,"
        "  done_items INTEGER NOT NULL DEFAULT 0,"
        "  failed_items INTEGER NOT NULL DEFAULT 0);");
  }

  void CreateBatchItemTable() {
    Exec(
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
        "CREATE INDEX IF NOT EXISTS batch_items_state ON batch_items(state);");
  }

  // Ordered migrations: entry v brings the schema from user_version v to v + 1.
  // Append new steps at the end; never edit a released one (COLMAP's
  // PostMigrateTables).
  void Migrate() {
    const std::vector<std::function<void()>> migrations = {
        [this] {
          CreateJobTable();
          CreateBatchTable();
          CreateBatchItemTable();
        },
        // Version 2 (after release 0.1.0): the machine family in its own
        // column, so no reader infers it from the flank. Rows stored before had
        // only grinder and bevel jobs, told apart by their flank names; this is
        // the one place that inference is made.
        [this] {
          Exec(
              "ALTER TABLE jobs ADD COLUMN machine_kind TEXT NOT NULL DEFAULT "
              "'';"
              "UPDATE jobs SET machine_kind = CASE WHEN flank IN ('convex', "
              "'concave')"
              "  THEN 'free-form-bevel-generator' ELSE 'flat-wheel-grinder' "
              "END;");
        },
        // Version 3: traceability of a job (part, serial, teeth, measuring
        // time and file, machine, batch, submitter) and of a batch (its
        // submitter). Older rows have none: NULL.
        [this] {
          Exec(
              "ALTER TABLE jobs ADD COLUMN part_number TEXT;"
              "ALTER TABLE jobs ADD COLUMN serial TEXT;"
              "ALTER TABLE jobs ADD COLUMN tooth_numbers TEXT;"
              "ALTER TABLE jobs ADD COLUMN measured_at TEXT;"
              "ALTER TABLE jobs ADD COLUMN file_name TEXT;"
              "ALTER TABLE jobs ADD COLUMN machine_id TEXT;"
              "ALTER TABLE jobs ADD COLUMN batch_id INTEGER REFERENCES "
              "batches(batch_id) ON DELETE SET NULL;"
              "ALTER TABLE jobs ADD COLUMN submitted_by TEXT;"
              "ALTER TABLE batches ADD COLUMN submitted_by TEXT;"
              "CREATE INDEX IF NOT EXISTS jobs_part ON jobs(part_number, "
              "serial);"
              "CREATE INDEX IF NOT EXISTS jobs_batch ON jobs(batch_id);");
        },
    };
    int version = ReadUserVersion();
    if (version > static_cast<int>(migrations.size())) {
      throw StorageError("database schema version " + std::to_string(version) +
                         " is newer than this server knows (" +
                         std::to_string(migrations.size()) + ")");
    }
    for (; version < static_cast<int>(migrations.size()); ++version) {
      Transaction transaction(db_);
      migrations[version]();
      Exec(("PRAGMA user_version = " + std::to_string(version + 1) + ";")
               .c_str());
      transaction.Commit();
    }
  }

  // --- Statements
  // ---------------------------------------------------------------------------
  void Prepare(const std::string& sql, sqlite3_stmt** statement) {
    SQLITE3_CALL(db_,
                 sqlite3_prepare_v3(db_,
                                    sql.c_str(),
                                    -1,
                                    SQLITE_PREPARE_PERSISTENT,
                                    statement,
                                    nullptr));
    statements_.push_back(statement);
  }

  void PrepareStatements() {
    PrepareJobStatements();
    PrepareBatchStatements();
  }

  // The statements of the jobs table: insert, read, filter, list, lineage.
  void PrepareJobStatements() {
    const std::string columns = kJobSummaryColumns;
    // Every filter is optional: a NULL binding matches everything, so one
    // prepared statement serves all combinations.
    const std::string where =
        " WHERE (?1 IS NULL OR gear_teeth = ?1)"
        " AND (?2 IS NULL OR abs(gear_normal_module_mm - ?2) < 1e-9)"
        " AND (?3 IS NULL OR flank = ?3)"
        " AND (?4 IS NULL OR kind = ?4)"
        " AND (?5 IS NULL OR status = ?5)"
        " AND (?6 IS NULL OR created_utc >= ?6)"
        " AND (?7 IS NULL OR created_utc < ?7)"
        " AND (?8 IS NULL OR machine_kind = ?8)"
        " AND (?11 IS NULL OR part_number = ?11)"
        " AND (?12 IS NULL OR serial = ?12)"
        " AND (?13 IS NULL OR (',' || tooth_numbers || ',') LIKE"
        "      ('%,' || ?13 || ',%'))"
        " AND (?14 IS NULL OR machine_id = ?14)"
        " AND (?15 IS NULL OR batch_id = ?15)"
        " AND (?16 IS NULL OR submitted_by = ?16)"
        " AND (?17 IS NULL OR file_name = ?17)";
    Prepare(
        "INSERT INTO jobs (created_utc, kind, status, gear_teeth, "
        "gear_normal_module_mm, gear_helix_angle_deg,"
        " gear_hand, flank, request_json, result_json, residual_rms_um, "
        "best_reachable_rms_um, rank, elapsed_ms,"
        " server_version, parent_job_id, settings_source_job_id, machine_kind,"
        " part_number, serial, tooth_numbers, measured_at, file_name,"
        " machine_id, batch_id, submitted_by)"
        " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, "
        "?15, ?16, ?17, ?18, ?19, ?20, ?21, ?22, ?23, ?24, ?25, ?26);",
        &stmt_insert_job_);
    Prepare("SELECT " + columns +
                ", request_json, result_json FROM jobs WHERE job_id = ?1;",
            &stmt_read_job_);
    Prepare("SELECT 1 FROM jobs WHERE job_id = ?1;", &stmt_job_exists_);
    Prepare("SELECT count(*) FROM jobs" + where + ";",
            &stmt_count_filtered_jobs_);
    Prepare("SELECT " + columns + " FROM jobs" + where +
                " ORDER BY job_id DESC LIMIT ?9 OFFSET ?10;",
            &stmt_list_jobs_);
    Prepare("SELECT count(*) FROM jobs;", &stmt_count_jobs_);
    Prepare(
        "WITH RECURSIVE"
        " up(id) AS (SELECT ?1 UNION SELECT j.settings_source_job_id FROM jobs "
        "j JOIN up ON j.job_id = up.id"
        "            WHERE j.settings_source_job_id IS NOT NULL),"
        " down(id) AS (SELECT ?1 UNION SELECT j.job_id FROM jobs j JOIN down "
        "ON j.settings_source_job_id = down.id)"
        " SELECT " +
            columns +
            " FROM jobs WHERE job_id IN (SELECT id FROM up UNION SELECT id "
            "FROM down) ORDER BY job_id ASC;",
        &stmt_read_lineage_);
  }

  // The statements of the batches and batch_items tables.
  void PrepareBatchStatements() {
    Prepare(
        "INSERT INTO batches (created_utc, total_items, status, finished_utc, "
        "submitted_by) VALUES (?1, ?2, ?3, ?4, ?5);",
        &stmt_insert_batch_);
    Prepare(
        "INSERT INTO batch_items (batch_id, item_index, request_json) VALUES "
        "(?1, ?2, ?3);",
        &stmt_insert_batch_item_);
    Prepare(
        "UPDATE batch_items SET state = 'done', job_id = ?1"
        " WHERE batch_id = ?2 AND item_index = ?3 AND state = 'pending';",
        &stmt_complete_batch_item_);
    Prepare(
        "UPDATE batch_items SET state = 'failed', error_status = ?1, "
        "error_code = ?2, error_message = ?3,"
        " error_field = ?4 WHERE batch_id = ?5 AND item_index = ?6 AND state = "
        "'pending';",
        &stmt_fail_batch_item_);
    Prepare(
        "UPDATE batches SET"
        " done_items = (SELECT count(*) FROM batch_items WHERE batch_id = ?1 "
        "AND state = 'done'),"
        " failed_items = (SELECT count(*) FROM batch_items WHERE batch_id = ?1 "
        "AND state = 'failed'),"
        " status = CASE WHEN EXISTS (SELECT 1 FROM batch_items WHERE batch_id "
        "= ?1 AND state = 'pending')"
        "          THEN 'running' ELSE 'finished' END,"
        " finished_utc = CASE WHEN EXISTS (SELECT 1 FROM batch_items WHERE "
        "batch_id = ?1 AND state = 'pending')"
        "          THEN NULL ELSE ?2 END"
        " WHERE batch_id = ?1;",
        &stmt_update_batch_counters_);
    Prepare(
        "SELECT batch_id, created_utc, finished_utc, status, total_items, "
        "done_items, failed_items, submitted_by"
        " FROM batches WHERE batch_id = ?1;",
        &stmt_read_batch_);
    Prepare(
        "SELECT item_index, state, job_id, error_status, error_code, "
        "error_message, error_field"
        " FROM batch_items WHERE batch_id = ?1 ORDER BY item_index;",
        &stmt_read_batch_items_);
    Prepare(
        "SELECT i.batch_id, i.item_index, i.request_json, b.submitted_by"
        " FROM batch_items i JOIN batches b ON b.batch_id = i.batch_id"
        " WHERE i.state = 'pending' ORDER BY i.batch_id, i.item_index;",
        &stmt_read_pending_items_);
  }

  void FinalizeStatements() {
    for (sqlite3_stmt** statement : statements_) {
      if (*statement != nullptr) sqlite3_finalize(*statement);
      *statement = nullptr;
    }
    statements_.clear();
  }

  // Steps `statement` once: true when it yields a row, false when it is done;
  // any other return code throws StorageError.
  bool StepRow(sqlite3_stmt* statement) {
    const int rc = sqlite3_step(statement);
    SQLITE3_CALL(db_, rc);
    return rc == SQLITE_ROW;
  }

  // --- Writes (called with the mutex held, inside a transaction)
  // ---------------------------- Runs an UPDATE of the pending item `index` of
  // batch `batch_id` (stmt_complete_batch_item_ or stmt_fail_batch_item_,
  // bound): an item that is not pending, or does not exist, throws and so rolls
  // the transaction back.
  void StepPendingItemUpdate(sqlite3_stmt* statement,
                             int64_t batch_id,
                             int index) {
    SQLITE3_CALL(db_, sqlite3_step(statement));
    if (sqlite3_changes(db_) != 1) {
      throw StorageError("batch " + std::to_string(batch_id) +
                         " has no pending item " + std::to_string(index));
    }
  }

  int64_t InsertJob(const JobRecord& job) {
    // The column defaults to '' only so that the migration could add it to old
    // rows; a job written now without its family is a bug of the caller, not
    // bad input.
    if (job.machine_kind.empty()) throw StorageError("job has no machine_kind");
    sqlite3_stmt* s = stmt_insert_job_;
    StatementScope scope(s);
    const std::string created =
        job.created_utc.empty() ? CurrentUtcIso8601() : job.created_utc;
    SQLITE3_CALL(
        db_, sqlite3_bind_text(s, 1, created.c_str(), -1, SQLITE_TRANSIENT));
    SQLITE3_CALL(db_,
                 sqlite3_bind_text(s, 2, job.kind.c_str(), -1, SQLITE_STATIC));
    SQLITE3_CALL(
        db_, sqlite3_bind_text(s, 3, job.status.c_str(), -1, SQLITE_STATIC));
    SQLITE3_CALL(db_, sqlite3_bind_int(s, 4, job.gear_teeth));
    SQLITE3_CALL(db_, sqlite3_bind_double(s, 5, job.gear_normal_module_mm));
    SQLITE3_CALL(db_, sqlite3_bind_double(s, 6, job.gear_helix_angle_deg));
    SQLITE3_CALL(
        db_, sqlite3_bind_text(s, 7, job.gear_hand.c_str(), -1, SQLITE_STATIC));
    SQLITE3_CALL(db_,
                 sqlite3_bind_text(s, 8, job.flank.c_str(), -1, SQLITE_STATIC));
    SQLITE3_CALL(db_,
                 sqlite3_bind_text(s,
                                   9,
                                   job.request_json.data(),
                                   static_cast<int>(job.request_json.size()),
                                   SQLITE_STATIC));
    SQLITE3_CALL(db_,
                 sqlite3_bind_text(s,
                                   10,
                                   job.result_json.data(),
                                   static_cast<int>(job.result_json.size()),
                                   SQLITE_STATIC));
    BindOptionalDouble(s, 11, job.residual_rms_um);
    BindOptionalDouble(s, 12, job.best_reachable_rms_um);
    if (job.rank) {
      SQLITE3_CALL(db_, sqlite3_bind_int(s, 13, *job.rank));
    } else {
      SQLITE3_CALL(db_, sqlite3_bind_null(s, 13));
    }
    SQLITE3_CALL(db_, sqlite3_bind_double(s, 14, job.elapsed_ms));
    SQLITE3_CALL(db_,
                 sqlite3_bind_text(
                     s, 15, job.server_version.c_str(), -1, SQLITE_STATIC));
    BindOptionalInt64(s, 16, job.parent_job_id);
    BindOptionalInt64(s, 17, job.settings_source_job_id);
    SQLITE3_CALL(
        db_,
        sqlite3_bind_text(s, 18, job.machine_kind.c_str(), -1, SQLITE_STATIC));
    BindTraceColumns(s, job);
    SQLITE3_CALL(db_, sqlite3_step(s));
    return sqlite3_last_insert_rowid(db_);
  }

  // Binds ?19..?26 of the insert: the traceability of `job`.
  void BindTraceColumns(sqlite3_stmt* s, const JobRecord& job) {
    BindNonEmptyText(s, 19, job.part_number);
    BindNonEmptyText(s, 20, job.serial);
    BindNonEmptyText(s, 21, ToothNumbersText(job.tooth_numbers));
    BindNonEmptyText(s, 22, job.measured_at);
    BindNonEmptyText(s, 23, job.file_name);
    BindNonEmptyText(s, 24, job.machine_id);
    BindOptionalInt64(s, 25, job.batch_id);
    BindNonEmptyText(s, 26, job.submitted_by);
  }

  // NULL for an empty text.
  void BindNonEmptyText(sqlite3_stmt* s, int index, const std::string& text) {
    if (text.empty()) {
      SQLITE3_CALL(db_, sqlite3_bind_null(s, index));
    } else {
      SQLITE3_CALL(
          db_, sqlite3_bind_text(s, index, text.c_str(), -1, SQLITE_TRANSIENT));
    }
  }

  void UpdateBatchCounters(int64_t batch_id) {
    StatementScope scope(stmt_update_batch_counters_);
    const std::string now = CurrentUtcIso8601();
    SQLITE3_CALL(db_,
                 sqlite3_bind_int64(stmt_update_batch_counters_, 1, batch_id));
    SQLITE3_CALL(
        db_,
        sqlite3_bind_text(
            stmt_update_batch_counters_, 2, now.c_str(), -1, SQLITE_TRANSIENT));
    SQLITE3_CALL(db_, sqlite3_step(stmt_update_batch_counters_));
  }

  void BindOptionalDouble(sqlite3_stmt* s,
                          int index,
                          const std::optional<double>& value) {
    if (value) {
      SQLITE3_CALL(db_, sqlite3_bind_double(s, index, *value));
    } else {
      SQLITE3_CALL(db_, sqlite3_bind_null(s, index));
    }
  }

  void BindOptionalInt64(sqlite3_stmt* s,
                         int index,
                         const std::optional<int64_t>& value) {
    if (value) {
      SQLITE3_CALL(db_, sqlite3_bind_int64(s, index, *value));
    } else {
      SQLITE3_CALL(db_, sqlite3_bind_null(s, index));
    }
  }

  void BindOptionalText(sqlite3_stmt* s,
                        int index,
                        const std::optional<std::string>& value) {
    if (value) {
      SQLITE3_CALL(
          db_,
          sqlite3_bind_text(s, index, value->c_str(), -1, SQLITE_TRANSIENT));
    } else {
      SQLITE3_CALL(db_, sqlite3_bind_null(s, index));
    }
  }

  void BindFilter(sqlite3_stmt* s, const JobFilter& filter) {
    if (filter.gear_teeth) {
      SQLITE3_CALL(db_, sqlite3_bind_int(s, 1, *filter.gear_teeth));
    } else {
      SQLITE3_CALL(db_, sqlite3_bind_null(s, 1));
    }
    BindOptionalDouble(s, 2, filter.gear_normal_module_mm);
    BindOptionalText(s, 3, filter.flank);
    BindOptionalText(s, 4, filter.kind);
    BindOptionalText(s, 5, filter.status);
    BindOptionalText(s, 6, filter.created_from);
    BindOptionalText(s, 7, filter.created_to);
    BindOptionalText(s, 8, filter.machine_kind);
    BindOptionalText(s, 11, filter.part_number);
    BindOptionalText(s, 12, filter.serial);
    if (filter.tooth) {
      SQLITE3_CALL(db_, sqlite3_bind_int(s, 13, *filter.tooth));
    } else {
      SQLITE3_CALL(db_, sqlite3_bind_null(s, 13));
    }
    BindOptionalText(s, 14, filter.machine_id);
    BindOptionalInt64(s, 15, filter.batch_id);
    BindOptionalText(s, 16, filter.submitted_by);
    BindOptionalText(s, 17, filter.file_name);
  }

  sqlite3* db_ = nullptr;
  std::mutex mutex_;
  std::vector<sqlite3_stmt**> statements_;
  sqlite3_stmt* stmt_insert_job_ = nullptr;
  sqlite3_stmt* stmt_read_job_ = nullptr;
  sqlite3_stmt* stmt_job_exists_ = nullptr;
  sqlite3_stmt* stmt_count_filtered_jobs_ = nullptr;
  sqlite3_stmt* stmt_list_jobs_ = nullptr;
  sqlite3_stmt* stmt_count_jobs_ = nullptr;
  sqlite3_stmt* stmt_read_lineage_ = nullptr;
  sqlite3_stmt* stmt_insert_batch_ = nullptr;
  sqlite3_stmt* stmt_insert_batch_item_ = nullptr;
  sqlite3_stmt* stmt_complete_batch_item_ = nullptr;
  sqlite3_stmt* stmt_fail_batch_item_ = nullptr;
  sqlite3_stmt* stmt_update_batch_counters_ = nullptr;
  sqlite3_stmt* stmt_read_batch_ = nullptr;
  sqlite3_stmt* stmt_read_batch_items_ = nullptr;
  sqlite3_stmt* stmt_read_pending_items_ = nullptr;
};

}  // namespace

const char* BatchItemStateName(BatchItemState state) {
  switch (state) {
    case BatchItemState::kPending:
      return "pending";
    case BatchItemState::kDone:
      return "done";
    case BatchItemState::kFailed:
      return "failed";
  }
  return "pending";
}

std::unique_ptr<JobRepository> OpenJobRepository(const std::string& path) {
  return std::make_unique<SqliteJobRepository>(path);
}

std::string CurrentUtcIso8601() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  const auto millis = std::chrono::duration_cast<std::chrono::milliseconds>(
                          now.time_since_epoch())
                          .count() %
                      1000;
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char buffer[64];
  std::snprintf(buffer,
                sizeof(buffer),
                "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ",
                utc.tm_year + 1900,
                utc.tm_mon + 1,
                utc.tm_mday,
                utc.tm_hour,
                utc.tm_min,
                utc.tm_sec,
                static_cast<int>(millis));
  return buffer;
}

}  // namespace gearloop
