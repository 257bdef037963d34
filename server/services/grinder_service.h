// server/services/grinder_service.h: the flat-wheel grinder's model endpoints:
// POST /api/v1/nominal, /evaluate and /sensitivity. Each parses the setup and
// settings (codec/grinder_codec.h), runs the grinder
// (engine/grinder/flat_wheel_grinder.h) and answers.
//
//   GrinderNominal(req, res);   // 200 {settings, gear, flank, radii,
//   roll_range_deg}
#ifndef GEARLOOP_SERVER_SERVICES_GRINDER_SERVICE_H_
#define GEARLOOP_SERVER_SERVICES_GRINDER_SERVICE_H_

#include "server/respond.h"

namespace gearloop {

// The nominal settings of the setup and the gear's figures.
void GrinderNominal(const httplib::Request& req, httplib::Response& res);
// The flank ground with "settings" (default nominal) on the grid
// (EvaluationToJson) and its ISO 1328-1 figures and classes ("iso1328").
void GrinderEvaluate(const httplib::Request& req, httplib::Response& res);
// The Jacobian of the flank in the settings and its singular values
// (SensitivityToJson).
void GrinderSensitivity(const httplib::Request& req, httplib::Response& res);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SERVICES_GRINDER_SERVICE_H_
