// server/services/reach_service.h: POST /api/v1/targets/reach, what a machine
// configuration can make of a target before anything is ground. For a
// flat-wheel grinder setup and target.modifications, each modification alone
// and all together are solved from a perfect flank (measured 0, so e = -t)
// with the request's options; the solve's best reachable residual (e projected
// off the range of the model at the allowed orders, correction.h) against the
// target's rms gives the share the machine can make. The same with every axis
// free to order 6 says whether higher orders would make the rest. Nothing is
// stored.
//
// Each component that is not made whole carries a remedy
// (server/services/reach_remedy.h): a higher order on a named axis, the
// wheel's profile, or the wheel traverse along the lead, computed.
//
//   ReachTarget(context, req, res);   // 200 {components, combined, ...}
#ifndef GEARLOOP_SERVER_SERVICES_REACH_SERVICE_H_
#define GEARLOOP_SERVER_SERVICES_REACH_SERVICE_H_

#include "server/respond.h"
#include "server/services/service_context.h"

namespace gearloop {

void ReachTarget(const ServiceContext& context,
                 const httplib::Request& req,
                 httplib::Response& res);

// The reach block of a correction request `body` (a job that is
// target_partly_reachable): the same answer as POST /api/v1/targets/reach for
// its machine configuration, settings, options and target.modifications
// (measurement, trace, tolerance and lineage left out); null when the job's
// target is a grid or its machine is not the flat-wheel grinder.
nlohmann::json CorrectionReachJson(const ServiceContext& context,
                                   const nlohmann::json& body);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SERVICES_REACH_SERVICE_H_
