// server/codec/trace_codec.h: the traceability of a correction job: the
// request's optional "trace" object (part number, serial, tooth numbers,
// measuring time, file name, machine id) read into the job record, and the
// "trace" of a stored job (with its batch and submitter) written back.
//
//   JobRecord job;
//   ApiError error;
//   if (!ParseJobTrace(body, &job, &error)) return RespondError(res, error);
//   summary["trace"] = JobTraceJson(job);
#ifndef GEARLOOP_SERVER_CODEC_TRACE_CODEC_H_
#define GEARLOOP_SERVER_CODEC_TRACE_CODEC_H_

#include <nlohmann/json.hpp>
#include <string>

#include "server/codec/json_read.h"
#include "storage/job_repository.h"

namespace gearloop {

// Longest text of a trace field, and most tooth numbers.
constexpr size_t kMaxTraceTextLength = 200;
constexpr size_t kMaxTraceTeeth = 1000;

// Reads body.trace (optional) into the trace fields of `job`: texts of 1 to
// kMaxTraceTextLength printable characters, teeth an array of distinct tooth
// numbers >= 1, measured_at an ISO-8601 date-time. A field the trace does not
// know, a wrong type or a bad value is an error naming "trace.<field>". Without
// trace.teeth, a measuring file's single tooth (measurement.file.tooth > 0) is
// the job's tooth.
bool ParseJobTrace(const nlohmann::json& body, JobRecord* job, ApiError* error);

// True when `text` is an ISO-8601 date-time: 2026-11-22T08:15:00Z,
// 2026-11-22T08:15:00.250+01:00, 2026-11-22T08:15 (local).
bool IsIso8601DateTime(const std::string& text);

// The trace of a stored job: its given fields only (an empty object when none).
nlohmann::json JobTraceJson(const JobRecord& job);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_TRACE_CODEC_H_
