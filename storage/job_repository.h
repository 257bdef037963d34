// storage/job_repository.h: the history of correction jobs and batches, kept in
// SQLite.
//
// A job is one correction (or replay) the server computed: its request and
// result as opaque JSON text (storage never parses JSON), the gear summary
// columns the history is filtered by, the solver's figures, the server version,
// and two links:
//   - parent_job_id: the job this one replays (same measurement, changed
//   options or target);
//   - settings_source_job_id: the job whose corrected settings the measured
//   part was ground
//     with, so the closed-loop history of one gear (settings revision after
//     revision) can be walked back to its first measurement.
// A batch is a list of correction requests run in the background; each item
// ends as a stored job or as an error, and a failed item never fails the
// others.
//
//   std::unique_ptr<JobRepository> repo = OpenJobRepository("gearloop.sqlite");
//   // or ":memory:" JobRecord job; job.kind = "correction"; job.machine_kind =
//   "flat-wheel-grinder"; job.status = "converged"; ... const int64_t id =
//   repo->WriteJob(job); JobPage page = repo->ListJobs(JobFilter{});   //
//   newest first
//
// Every write of a job (with its batch bookkeeping) is one transaction: a
// reader never sees half a job, and a crash never leaves one. The repository is
// safe to call from many threads (one SQLite connection behind a mutex, as
// COLMAP's database.h asks: a connection is never used by two threads at once).
// Errors throw StorageError with the SQLite message and the source position of
// the failing call.
#ifndef GEARLOOP_STORAGE_JOB_REPOSITORY_H_
#define GEARLOOP_STORAGE_JOB_REPOSITORY_H_

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace gearloop {

class StorageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One stored correction job.
struct JobRecord {
  // Assigned by WriteJob (ignored on input).
  int64_t id = 0;
  // UTC, ISO-8601 with milliseconds ("2026-11-22T08:50:01.123Z"). WriteJob
  // fills it with the current time when empty.
  std::string created_utc;
  // What produced the job: "correction", "replay", "batch_item", "closed_loop",
  // ...
  std::string kind;
  // Outcome of the solve: "converged", "not_converged", ...
  std::string status;
  // The machine family the job corrects, as the API's machine.kind names it:
  // "flat-wheel-grinder", "free-form-bevel-generator", later more families.
  // Required: WriteJob throws StorageError when it is empty. Jobs stored before
  // the column existed (schema version 1) were given their family from their
  // flank when migrated (convex or concave: "free-form-bevel-generator",
  // otherwise "flat-wheel-grinder").
  std::string machine_kind;

  // Gear summary, for filtering the history (values as the API carries them).
  int gear_teeth = 0;
  double gear_normal_module_mm = 0.0;
  double gear_helix_angle_deg = 0.0;  // unsigned
  std::string gear_hand;              // "left", "right" or "" for a spur gear
  // The corrected flank, named as the machine family names it: "left" or
  // "right" for a grinder, "convex" or "concave" for a bevel pinion.
  // Family-specific: read it together with machine_kind, never to infer the
  // family.
  std::string flank;

  // The request and the result as JSON text (opaque here).
  std::string request_json;
  std::string result_json;

  // Solver figures (absent when the solver did not report them).
  std::optional<double> residual_rms_um;
  std::optional<double> best_reachable_rms_um;
  std::optional<int> rank;
  double elapsed_ms = 0.0;

  std::string server_version;

  // The job this one replays, if any; must name a stored job.
  std::optional<int64_t> parent_job_id;
  // The job whose corrected settings the measured part was ground with, if any;
  // must name a stored job.
  std::optional<int64_t> settings_source_job_id;

  // Traceability (schema version 3): what the shop floor knows of the part.
  // All optional; an empty text (or list) is "not given" and stored as NULL.
  // Jobs stored before version 3 have none of them.
  std::string part_number;
  std::string serial;
  // The measured tooth numbers (1-based, as the measuring machine counts).
  std::vector<int> tooth_numbers;
  // When the part was measured: ISO-8601 text as the request gave it.
  std::string measured_at;
  // The measuring machine's file the measurement came from.
  std::string file_name;
  // The machine the part was ground on (the shop's name for it).
  std::string machine_id;
  // The batch the job was run in, if any (set by CompleteBatchItem's caller).
  std::optional<int64_t> batch_id;
  // The name of the token that submitted the job ("" without tokens).
  std::string submitted_by;
};

// Filters of the history listing; an absent filter matches everything.
struct JobFilter {
  std::optional<int> gear_teeth;
  // Matches within 1e-9 mm.
  std::optional<double> gear_normal_module_mm;
  std::optional<std::string> flank;
  // Matches JobRecord::machine_kind exactly ("flat-wheel-grinder", ...).
  std::optional<std::string> machine_kind;
  std::optional<std::string> kind;
  std::optional<std::string> status;
  // created_utc >= created_from (inclusive); ISO-8601 text compared as text, so
  // a date alone
  // ("2026-11-22") works as the start of that day.
  std::optional<std::string> created_from;
  // created_utc < created_to (exclusive).
  std::optional<std::string> created_to;
  // Traceability filters, each matched exactly; `tooth` matches a job whose
  // tooth_numbers hold it.
  std::optional<std::string> part_number;
  std::optional<std::string> serial;
  std::optional<int> tooth;
  std::optional<std::string> machine_id;
  std::optional<int64_t> batch_id;
  std::optional<std::string> submitted_by;
  std::optional<std::string> file_name;
  // Paging: at most `limit` jobs (1..1000), skipping the first `offset` (>= 0)
  // matches.
  int limit = 50;
  int offset = 0;
};

struct JobPage {
  // Newest first. request_json and result_json are left empty in listings
  // (ReadJob has them).
  std::vector<JobRecord> jobs;
  // Number of jobs matching the filter, over all pages.
  int64_t total = 0;
};

enum class BatchItemState { kPending, kDone, kFailed };
const char* BatchItemStateName(
    BatchItemState state);  // "pending", "done", "failed"

struct BatchItemRecord {
  int index = 0;  // position in the submitted list, from 0
  BatchItemState state = BatchItemState::kPending;
  std::string request_json;
  // Set when done.
  std::optional<int64_t> job_id;
  // Set when failed: the HTTP status and error body fields the item would have
  // been answered with.
  int error_status = 0;
  std::string error_code;
  std::string error_message;
  std::string error_field;
};

struct BatchRecord {
  int64_t id = 0;
  std::string created_utc;
  // UTC time the last item finished; empty while running.
  std::string finished_utc;
  // "running" until every item is done or failed, then "finished".
  std::string status;
  int total = 0;
  int done = 0;
  int failed = 0;
  // The name of the token that submitted the batch ("" without tokens).
  std::string submitted_by;
  // Ordered by index; filled by ReadBatch only when asked for.
  std::vector<BatchItemRecord> items;
};

// A pending batch item, as the background workers pick it up (also after a
// restart).
struct PendingBatchItem {
  int64_t batch_id = 0;
  int index = 0;
  std::string request_json;
  // The batch's submitter (BatchRecord::submitted_by).
  std::string submitted_by;
};

class JobRepository {
 public:
  virtual ~JobRepository() = default;

  // Stores `job` in one transaction and returns its id. Throws StorageError,
  // e.g. when machine_kind is empty or parent_job_id or settings_source_job_id
  // names no stored job.
  virtual int64_t WriteJob(const JobRecord& job) = 0;
  virtual std::optional<JobRecord> ReadJob(int64_t id) = 0;
  virtual bool JobExists(int64_t id) = 0;
  virtual JobPage ListJobs(const JobFilter& filter) = 0;
  virtual int64_t CountJobs() = 0;

  // The settings lineage of job `id`: the chain of settings_source_job_id links
  // back to the first job, then every job ground with settings descending from
  // `id`; oldest first, JSON texts left empty. Empty when `id` is not stored.
  virtual std::vector<JobRecord> ReadLineage(int64_t id) = 0;

  // Stores a batch of `item_requests_json.size()` pending items (one
  // transaction), submitted by the token named `submitted_by` ("" for none),
  // and returns its id.
  virtual int64_t CreateBatch(
      const std::vector<std::string>& item_requests_json,
      const std::string& submitted_by) = 0;
  int64_t CreateBatch(const std::vector<std::string>& item_requests_json) {
    return CreateBatch(item_requests_json, std::string());
  }
  // Stores `job` and marks item `index` of `batch_id` done with it, in one
  // transaction; returns the job id. Finishes the batch when this was its last
  // open item.
  virtual int64_t CompleteBatchItem(int64_t batch_id,
                                    int index,
                                    const JobRecord& job) = 0;
  // Marks item `index` failed with the given error (error_* fields of `error`).
  virtual void FailBatchItem(int64_t batch_id,
                             int index,
                             const BatchItemRecord& error) = 0;
  virtual std::optional<BatchRecord> ReadBatch(int64_t id, bool with_items) = 0;
  // Every pending item of every batch, oldest batch first (to resume after a
  // restart).
  virtual std::vector<PendingBatchItem> ReadPendingBatchItems() = 0;

  // The schema version (PRAGMA user_version) after migration.
  virtual int SchemaVersion() = 0;
  // Result of PRAGMA integrity_check ("ok" when healthy).
  virtual std::string IntegrityCheck() = 0;
};

// Opens (creating if needed) the SQLite file at `path`, or an in-memory
// database for
// ":memory:", and migrates its schema to the current version. WAL journal,
// synchronous=NORMAL (a committed job survives a crash of the process), foreign
// keys on. Throws StorageError when the file cannot be opened or migrated.
std::unique_ptr<JobRepository> OpenJobRepository(const std::string& path);

// The current UTC time as ISO-8601 with milliseconds, e.g.
// "2026-11-22T08:50:01.123Z".
std::string CurrentUtcIso8601();

}  // namespace gearloop

#endif  // GEARLOOP_STORAGE_JOB_REPOSITORY_H_
