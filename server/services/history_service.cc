#include "server/services/history_service.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <regex>
#include <string>
#include <vector>

#include "server/codec/job_codec.h"
#include "server/codec/request_keys.h"
#include "server/codec/trace_codec.h"
#include "server/services/correction_service.h"
#include "server/services/split_bevel_service.h"
#include "server/services/stored_job.h"

// Last: see server/respond.h.
#include <httplib.h>

namespace gearloop {
namespace {}  // namespace

namespace {

// Reads the integer query parameter key into *out when present; it must lie in
// [min, max].
bool ReadIntegerParam(const httplib::Request& req,
                      const char* key,
                      long long min,
                      long long max,
                      long long* out,
                      ApiError* error) {
  if (!req.has_param(key)) return true;
  const std::string text = req.get_param_value(key);
  const std::string field = std::string("query.") + key;
  if (text.empty() || text.size() > 12 ||
      text.find_first_not_of("-0123456789") != std::string::npos ||
      text.find('-', 1) != std::string::npos || text == "-") {
    *error = InvalidRequest(field, field + " must be an integer");
    return false;
  }
  const long long value = std::stoll(text);
  if (value < min || value > max) {
    *error = InvalidValue(field,
                          field + " must lie in [" + std::to_string(min) +
                              ", " + std::to_string(max) + "]");
    return false;
  }
  *out = value;
  return true;
}

// Reads the gear filters: teeth, module_mm and flank.
bool ReadGearFilter(const httplib::Request& req,
                    JobFilter* filter,
                    ApiError* error) {
  long long teeth = 0;
  if (req.has_param("teeth")) {
    if (!ReadIntegerParam(req, "teeth", 1, 1000000, &teeth, error))
      return false;
    filter->gear_teeth = static_cast<int>(teeth);
  }
  if (req.has_param("module_mm")) {
    const std::string text = req.get_param_value("module_mm");
    char* end = nullptr;
    const double value = std::strtod(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size() ||
        !std::isfinite(value)) {
      *error =
          InvalidRequest("query.module_mm", "query.module_mm must be a number");
      return false;
    }
    filter->gear_normal_module_mm = value;
  }
  if (req.has_param("flank")) {
    const std::string flank = req.get_param_value("flank");
    if (flank != "left" && flank != "right" && flank != "convex" &&
        flank != "concave" && flank != "both") {
      *error =
          InvalidValue("query.flank",
                       "query.flank must be \"left\" or \"right\" (a gear), "
                       "\"convex\" or \"concave\" (a bevel flank) or \"both\" "
                       "(a split-bevel trajectory of both flanks)");
      return false;
    }
    filter->flank = flank;
  }
  return true;
}

// True when the date (and time) of an ISO-8601 text of the shape checked by
// ReadCreatedRange exist: month 1-12, a day of that month, 00:00:00-23:59:59.
bool IsCalendarTime(const std::string& text) {
  const int year = std::stoi(text.substr(0, 4));
  const int month = std::stoi(text.substr(5, 2));
  const int day = std::stoi(text.substr(8, 2));
  static const int kDays[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  if (month < 1 || month > 12 || day < 1) return false;
  const bool leap = (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
  if (day > kDays[month - 1] + (month == 2 && leap ? 1 : 0)) return false;
  if (text.size() < 16) return true;
  if (std::stoi(text.substr(11, 2)) > 23 || std::stoi(text.substr(14, 2)) > 59)
    return false;
  return text.size() < 19 || std::stoi(text.substr(17, 2)) <= 59;
}

// Reads a query parameter that must be one of `values` (400 otherwise).
bool ReadChoiceParam(const httplib::Request& req,
                     const char* key,
                     const std::vector<std::string>& values,
                     std::optional<std::string>* out,
                     ApiError* error) {
  if (!req.has_param(key)) return true;
  const std::string text = req.get_param_value(key);
  if (std::find(values.begin(), values.end(), text) == values.end()) {
    std::string list;
    for (const std::string& v : values) list += (list.empty() ? "" : ", ") + v;
    const std::string field = std::string("query.") + key;
    *error = InvalidRequest(
        field, field + " must be one of " + list + ", got \"" + text + "\"");
    return false;
  }
  *out = text;
  return true;
}

// Every query parameter must be one the job list knows (400 naming it).
bool CheckQueryKeys(const httplib::Request& req, ApiError* error) {
  static const std::vector<std::string> kKnown = {"limit",
                                                  "offset",
                                                  "teeth",
                                                  "module_mm",
                                                  "flank",
                                                  "kind",
                                                  "status",
                                                  "created_from",
                                                  "created_to",
                                                  "part_number",
                                                  "serial",
                                                  "tooth",
                                                  "machine_id",
                                                  "file_name",
                                                  "batch_id",
                                                  "submitted_by"};
  for (const auto& [key, value] : req.params) {
    if (std::find(kKnown.begin(), kKnown.end(), key) != kKnown.end()) continue;
    std::string message = "unknown query parameter " + key;
    const std::string nearest = NearestName(key, kKnown);
    if (!nearest.empty()) message += "; did you mean " + nearest + "?";
    *error = InvalidRequest("query." + key, message);
    return false;
  }
  return true;
}

// Reads created_from and created_to; the range must not be reversed.
bool ReadCreatedRange(const httplib::Request& req,
                      JobFilter* filter,
                      ApiError* error) {
  static const std::regex kTime(
      R"(\d{4}-\d{2}-\d{2}(T\d{2}:\d{2}(:\d{2}(\.\d{1,3})?)?Z?)?)");
  for (const char* key : {"created_from", "created_to"}) {
    if (!req.has_param(key)) continue;
    const std::string text = req.get_param_value(key);
    if (!std::regex_match(text, kTime) || !IsCalendarTime(text)) {
      *error = InvalidRequest(
          std::string("query.") + key,
          std::string("query.") + key +
              " must be an ISO-8601 UTC date or time (2026-11-22T08:00:00Z)");
      return false;
    }
    (std::string(key) == "created_from" ? filter->created_from
                                        : filter->created_to) = text;
  }
  if (filter->created_from && filter->created_to &&
      *filter->created_from > *filter->created_to) {
    *error = InvalidValue("query.created_to",
                          "query.created_to lies before query.created_from");
    return false;
  }
  return true;
}

// Reads the traceability filters: part_number, serial, tooth, machine_id,
// batch_id, submitted_by and file_name.
bool ReadTraceFilter(const httplib::Request& req,
                     JobFilter* filter,
                     ApiError* error) {
  const std::pair<const char*, std::optional<std::string> JobFilter::*>
      texts[] = {{"part_number", &JobFilter::part_number},
                 {"serial", &JobFilter::serial},
                 {"machine_id", &JobFilter::machine_id},
                 {"submitted_by", &JobFilter::submitted_by},
                 {"file_name", &JobFilter::file_name}};
  for (const auto& [key, member] : texts) {
    if (!req.has_param(key)) continue;
    const std::string text = req.get_param_value(key);
    if (text.empty() || text.size() > kMaxTraceTextLength) {
      const std::string field = std::string("query.") + key;
      *error = InvalidRequest(field,
                              field + " must hold 1 to " +
                                  std::to_string(kMaxTraceTextLength) +
                                  " characters");
      return false;
    }
    filter->*member = text;
  }
  long long tooth = 0, batch_id = 0;
  if (req.has_param("tooth")) {
    if (!ReadIntegerParam(req, "tooth", 1, 100000, &tooth, error)) return false;
    filter->tooth = static_cast<int>(tooth);
  }
  if (req.has_param("batch_id")) {
    if (!ReadIntegerParam(
            req, "batch_id", 1, 1000000000000LL, &batch_id, error))
      return false;
    filter->batch_id = batch_id;
  }
  return true;
}

}  // namespace

bool ParseJobFilter(const httplib::Request& req,
                    JobFilter* filter,
                    ApiError* error) {
  long long limit = 50, offset = 0;
  if (!CheckQueryKeys(req, error) ||
      !ReadIntegerParam(req, "limit", 1, 1000, &limit, error) ||
      !ReadIntegerParam(req, "offset", 0, 1000000000, &offset, error))
    return false;
  filter->limit = static_cast<int>(limit);
  filter->offset = static_cast<int>(offset);
  if (!ReadGearFilter(req, filter, error)) return false;
  if (!ReadChoiceParam(req,
                       "kind",
                       {"correction",
                        "replay",
                        "batch_item",
                        "closed_loop",
                        "split_trajectory"},
                       &filter->kind,
                       error) ||
      !ReadChoiceParam(req,
                       "status",
                       {"converged",
                        "not_converged",
                        "no_safe_improvement",
                        "target_partly_reachable",
                        "computed"},
                       &filter->status,
                       error))
    return false;
  return ReadTraceFilter(req, filter, error) &&
         ReadCreatedRange(req, filter, error);
}

void ListCorrections(const ServiceContext& context,
                     const httplib::Request& req,
                     httplib::Response& res) {
  JobFilter filter;
  ApiError error;
  if (!ParseJobFilter(req, &filter, &error)) return RespondError(res, error);
  const JobPage page = context.repository->ListJobs(filter);
  nlohmann::json jobs = nlohmann::json::array();
  for (const JobRecord& job : page.jobs) jobs.push_back(JobSummaryJson(job));
  RespondJson(res,
              200,
              {{"jobs", jobs},
               {"total", page.total},
               {"limit", filter.limit},
               {"offset", filter.offset}});
}

void GetCorrection(const ServiceContext& context,
                   const httplib::Request& req,
                   httplib::Response& res) {
  const std::optional<JobRecord> job = ReadPathJob(context, req);
  if (!job) return RespondError(res, NoStoredJob(req.matches[1].str()));
  if (job->kind == kSplitTrajectoryJobKind &&
      RespondStoredSplitTrajectory(context, *job, res))
    return;
  nlohmann::json answer = JobSummaryJson(*job);
  answer["request"] = nlohmann::json::parse(job->request_json, nullptr, false);
  answer["result"] = nlohmann::json::parse(job->result_json, nullptr, false);
  RespondJson(res, 200, answer);
}

void GetLineage(const ServiceContext& context,
                const httplib::Request& req,
                httplib::Response& res) {
  int64_t id = 0;
  std::vector<JobRecord> lineage;
  if (ParseId(req.matches[1], &id))
    lineage = context.repository->ReadLineage(id);
  if (lineage.empty())
    return RespondError(res, NoStoredJob(req.matches[1].str()));
  nlohmann::json jobs = nlohmann::json::array();
  for (const JobRecord& job : lineage) jobs.push_back(JobSummaryJson(job));
  RespondJson(res, 200, {{"id", id}, {"jobs", jobs}});
}

void CreateBatch(const ServiceContext& context,
                 const httplib::Request& req,
                 httplib::Response& res) {
  nlohmann::json body;
  ApiError error;
  if (!ParseJsonBody(req.body, &body, &error) ||
      !CheckRequestKeys(RequestSchema::kBatch, body, "", &error))
    return RespondError(res, error);
  if (!body.contains("items"))
    return RespondError(
        res, InvalidRequest("items", "missing required field items"));
  const nlohmann::json& items = body.at("items");
  if (!items.is_array())
    return RespondError(
        res,
        InvalidRequest("items",
                       "items must be an array of correction requests"));
  if (items.empty() ||
      items.size() > static_cast<size_t>(context.max_batch_items)) {
    return RespondError(
        res,
        InvalidValue("items",
                     "a batch holds 1 to " +
                         std::to_string(context.max_batch_items) +
                         " items, got " + std::to_string(items.size())));
  }
  std::vector<std::string> texts;
  for (size_t i = 0; i < items.size(); ++i) {
    const std::string field = "items[" + std::to_string(i) + "]";
    if (!items[i].is_object())
      return RespondError(
          res,
          InvalidRequest(field,
                         field + " must be a correction request object"));
    // Items are run later from their stored text: strict here, where they
    // enter.
    if (!CheckRequestKeys(RequestSchema::kCorrection, items[i], field, &error))
      return RespondError(res, error);
    texts.push_back(Dump(items[i]));
  }
  const size_t queued =
      context.queued_batch_items ? context.queued_batch_items() : 0;
  if (queued + texts.size() >
      static_cast<size_t>(context.max_queued_batch_items)) {
    res.set_header("Retry-After", "10");
    return RespondError(
        res,
        ApiError{503,
                 "unavailable",
                 "too many batch items are waiting; try again later",
                 ""});
  }
  const std::string submitter = SubmitterOf(context, req);
  const int64_t batch_id = context.repository->CreateBatch(texts, submitter);
  std::vector<PendingBatchItem> pending(texts.size());
  for (size_t i = 0; i < texts.size(); ++i)
    pending[i] = {
        batch_id, static_cast<int>(i), std::move(texts[i]), submitter};
  if (context.enqueue_batch_items)
    context.enqueue_batch_items(std::move(pending));
  res.set_header("Location", BatchLocation(batch_id));
  RespondJson(res, 202, BatchAcceptedJson(batch_id, items.size()));
}

void GetBatch(const ServiceContext& context,
              const httplib::Request& req,
              httplib::Response& res) {
  int64_t id = 0;
  std::optional<BatchRecord> batch;
  if (ParseId(req.matches[1], &id))
    batch = context.repository->ReadBatch(id, /*with_items=*/true);
  if (!batch)
    return RespondError(
        res,
        ApiError{404, "not_found", "no batch " + req.matches[1].str(), ""});
  RespondJson(res, 200, BatchToJson(*batch));
}

}  // namespace gearloop
