// server/services/simulation_service.h: POST /api/v1/simulations/measurement
// and /simulations/closed-loop for every machine family (machine_family.h):
// parse -> simulate (engine/simulation/measurement_simulator.h) -> optionally
// store each correction of the loop as a job, linked settings revision after
// revision -> respond.
//
//   SimulateMeasurement(context, req, res);   // 200 {measurement,
//   true_deviations_um, ...}
#ifndef GEARLOOP_SERVER_SERVICES_SIMULATION_SERVICE_H_
#define GEARLOOP_SERVER_SERVICES_SIMULATION_SERVICE_H_

#include "server/respond.h"
#include "server/services/service_context.h"

namespace gearloop {

// The simulated CMM grid: "measurement" {"deviations_um"} (null = missing),
// "teeth" (when more than one), "true_deviations_um", "outliers", "missing",
// "not_reached", "hidden_errors" and the commanded settings (or motion).
void SimulateMeasurement(const ServiceContext& context,
                         const httplib::Request& req,
                         httplib::Response& res);

// "completed", "message", "hidden_errors", "iterations": [{part, settings (or
// motion), true_rms_um, true_max_um, measured_rms_um, true_error_um, correction
// (summary or null), job_id (with "store": true)}].
void SimulateClosedLoop(const ServiceContext& context,
                        const httplib::Request& req,
                        httplib::Response& res);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SERVICES_SIMULATION_SERVICE_H_
