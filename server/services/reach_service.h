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
//   ReachTarget(context, req, res);   // 200 {components, combined, ...}
#ifndef GEARLOOP_SERVER_SERVICES_REACH_SERVICE_H_
#define GEARLOOP_SERVER_SERVICES_REACH_SERVICE_H_

#include "server/respond.h"
#include "server/services/service_context.h"

namespace gearloop {

void ReachTarget(const ServiceContext& context,
                 const httplib::Request& req,
                 httplib::Response& res);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SERVICES_REACH_SERVICE_H_
