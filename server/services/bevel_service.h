// server/services/bevel_service.h: the spiral-bevel pinion endpoints (issue 6,
// docs/bevel-machines.md): POST /api/v1/bevel/conversions, /bevel/evaluate and
// /bevel/axis-sensitivity. Each parses (codec/bevel_codec.h), runs the engine
// (engine/bevel/) and answers. Bevel corrections and simulations go through
// correction_service.h and simulation_service.h like every machine family's.
//
//   BevelEvaluate(req, res);   // 200 {job, motion, deviations_um, not_reached,
//   reached, points}
#ifndef GEARLOOP_SERVER_SERVICES_BEVEL_SERVICE_H_
#define GEARLOOP_SERVER_SERVICES_BEVEL_SERVICE_H_

#include "server/respond.h"

namespace gearloop {

// job, options -> the free-form motions converted from the cradle summary, with
// fit residuals, transform differences and the flank distance on the grid.
void BevelConversion(const httplib::Request& req, httplib::Response& res);
// job, motion -> deviations_um (null where not reached) and the grid points.
void BevelEvaluate(const httplib::Request& req, httplib::Response& res);
// job, motion, errors -> offsets and coefficients tables, rankings.
void BevelAxisSensitivity(const httplib::Request& req, httplib::Response& res);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SERVICES_BEVEL_SERVICE_H_
