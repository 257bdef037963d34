#include "server/codec/trace_codec.h"

#include <regex>
#include <set>
#include <vector>

namespace gearloop {
namespace {

// The text fields of a trace and where they go in a job.
struct TraceText {
  const char* key;
  std::string JobRecord::*member;
};

constexpr TraceText kTraceTexts[] = {
    {"part_number", &JobRecord::part_number},
    {"serial", &JobRecord::serial},
    {"measured_at", &JobRecord::measured_at},
    {"file_name", &JobRecord::file_name},
    {"machine_id", &JobRecord::machine_id},
};

bool ReadTraceText(const nlohmann::json& trace,
                   const TraceText& field,
                   JobRecord* job,
                   ApiError* error) {
  std::string text;
  bool found = false;
  if (!ReadString(trace, "trace", field.key, false, &text, error, &found))
    return false;
  if (!found) return true;
  const std::string path = std::string("trace.") + field.key;
  bool printable = !text.empty() && text.size() <= kMaxTraceTextLength;
  for (const char c : text)
    printable = printable && static_cast<unsigned char>(c) >= 0x20 && c != 0x7f;
  if (!printable) {
    *error = InvalidValue(path,
                          path + " must hold 1 to " +
                              std::to_string(kMaxTraceTextLength) +
                              " printable characters");
    return false;
  }
  if (std::string(field.key) == "measured_at" && !IsIso8601DateTime(text)) {
    *error = InvalidValue(
        path, path + " must be an ISO-8601 date-time (2026-11-22T08:15:00Z)");
    return false;
  }
  job->*field.member = text;
  return true;
}

bool ReadTraceTeeth(const nlohmann::json& trace,
                    JobRecord* job,
                    ApiError* error) {
  if (!trace.contains("teeth")) return true;
  const nlohmann::json& teeth = trace.at("teeth");
  if (!teeth.is_array() || teeth.empty() || teeth.size() > kMaxTraceTeeth) {
    *error =
        InvalidRequest("trace.teeth",
                       "trace.teeth must be an array of 1 to " +
                           std::to_string(kMaxTraceTeeth) + " tooth numbers");
    return false;
  }
  std::set<long long> seen;
  std::vector<int> numbers;
  for (size_t i = 0; i < teeth.size(); ++i) {
    const std::string path = "trace.teeth[" + std::to_string(i) + "]";
    if (!teeth[i].is_number_integer()) {
      *error = InvalidRequest(path, path + " must be an integer");
      return false;
    }
    const long long tooth = teeth[i].get<long long>();
    if (tooth < 1 || tooth > 100000 || !seen.insert(tooth).second) {
      *error = InvalidValue(
          path, path + " must be a tooth number >= 1, each named once");
      return false;
    }
    numbers.push_back(static_cast<int>(tooth));
  }
  job->tooth_numbers = std::move(numbers);
  return true;
}

// The tooth a measuring file's "tooth" names (0: the mean of all; none).
void ToothOfMeasurementFile(const nlohmann::json& body, JobRecord* job) {
  const nlohmann::json* measurement = nullptr;
  if (body.contains("measurement")) measurement = &body.at("measurement");
  if (measurement == nullptr || !measurement->is_object() ||
      !measurement->contains("file") || !measurement->at("file").is_object())
    return;
  const nlohmann::json& file = measurement->at("file");
  if (file.contains("tooth") && file.at("tooth").is_number_integer() &&
      file.at("tooth").get<long long>() > 0 &&
      file.at("tooth").get<long long>() <= 100000)
    job->tooth_numbers = {static_cast<int>(file.at("tooth").get<long long>())};
}

}  // namespace

bool IsIso8601DateTime(const std::string& text) {
  static const std::regex kDateTime(
      R"(\d{4}-(0[1-9]|1[0-2])-(0[1-9]|[12]\d|3[01])T([01]\d|2[0-3]):[0-5]\d)"
      R"((:[0-5]\d(\.\d{1,9})?)?(Z|[+-]([01]\d|2[0-3]):?[0-5]\d)?)");
  return std::regex_match(text, kDateTime);
}

bool ParseJobTrace(const nlohmann::json& body,
                   JobRecord* job,
                   ApiError* error) {
  const nlohmann::json* trace = nullptr;
  if (!RequireObject(body, "", "trace", false, &trace, error)) return false;
  if (trace == nullptr) {
    ToothOfMeasurementFile(body, job);
    return true;
  }
  for (const auto& item : trace->items()) {
    bool known = item.key() == "teeth";
    for (const TraceText& field : kTraceTexts)
      known = known || item.key() == field.key;
    if (!known) {
      *error = InvalidRequest(
          "trace." + item.key(),
          "trace." + item.key() +
              " is not a trace field (part_number, serial, teeth, "
              "measured_at, file_name, machine_id)");
      return false;
    }
  }
  for (const TraceText& field : kTraceTexts) {
    if (!ReadTraceText(*trace, field, job, error)) return false;
  }
  if (!ReadTraceTeeth(*trace, job, error)) return false;
  if (job->tooth_numbers.empty()) ToothOfMeasurementFile(body, job);
  return true;
}

nlohmann::json JobTraceJson(const JobRecord& job) {
  nlohmann::json trace = nlohmann::json::object();
  for (const TraceText& field : kTraceTexts) {
    if (!(job.*field.member).empty()) trace[field.key] = job.*field.member;
  }
  if (!job.tooth_numbers.empty()) trace["teeth"] = job.tooth_numbers;
  if (job.batch_id) trace["batch_id"] = *job.batch_id;
  if (!job.submitted_by.empty()) trace["submitted_by"] = job.submitted_by;
  return trace;
}

}  // namespace gearloop
