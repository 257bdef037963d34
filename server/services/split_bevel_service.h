// server/services/split_bevel_service.h: 5-axis flank-milling trajectories of
// split equal-base-circle bevel wheels (issue 14, SPLIT_BEVEL.md §8):
//   POST /api/v1/bevel/split-trajectory        parse -> IsValid -> engine ->
//                                              store the job -> 200
//   GET  /api/v1/bevel/split-trajectory/{id}/nc  the stored job's NC program
//                                              (text/plain)
// A computed trajectory is a job of the history (kind "split_trajectory",
// machine_kind "head-head-5-axis-mill", status "computed"): listed by GET
// /api/v1/corrections, shown whole by GET /api/v1/corrections/{id}. Its stored
// result always holds nc_program; the POST answer carries it only when
// output.nc is true.
//
//   CreateSplitTrajectory(context, req, res);  // 200 {derived, setup, passes,
//                                              //  job_id, location,
//                                              nc_location}
#ifndef GEARLOOP_SERVER_SERVICES_SPLIT_BEVEL_SERVICE_H_
#define GEARLOOP_SERVER_SERVICES_SPLIT_BEVEL_SERVICE_H_

#include <cstdint>
#include <string>

#include "server/codec/machine_kind.h"
#include "server/respond.h"
#include "server/services/service_context.h"
#include "storage/job_repository.h"

namespace gearloop {

// The job's kind in the history (its machine_kind is kHeadHead5AxisMillKind,
// server/codec/machine_kind.h).
constexpr const char* kSplitTrajectoryJobKind = "split_trajectory";

// "/api/v1/bevel/split-trajectory/<id>/nc".
std::string SplitTrajectoryNcLocation(int64_t job_id);

void CreateSplitTrajectory(const ServiceContext& context,
                           const httplib::Request& req,
                           httplib::Response& res);
// GET /api/v1/corrections/{id} of a split-trajectory job stored without its
// points: the job's summary, "points_recomputed" {server_version,
// nc_program_matches | error}, the request, and the result with the points
// computed again (the same bytes the POST answered, then the stored
// nc_program). When the request no longer computes or its listing differs
// from the stored one, "error" says so and the result is the stored one
// (without points). False, nothing answered, for a job stored with its points
// (before this change), which the generic path shows.
bool RespondStoredSplitTrajectory(const ServiceContext& context,
                                  const JobRecord& job,
                                  httplib::Response& res);
// 404 when no split-trajectory job has this id.
void GetSplitTrajectoryNc(const ServiceContext& context,
                          const httplib::Request& req,
                          httplib::Response& res);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SERVICES_SPLIT_BEVEL_SERVICE_H_
