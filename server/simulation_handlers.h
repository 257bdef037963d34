// server/simulation_handlers.h: the simulated measuring machine and the simulated closed loop
// behind POST /api/v1/simulations/measurement and /closed-loop (engine/simulation/measurement_simulator.h).
//
//   nlohmann::json answer;
//   ApiError error;
//   if (!SimulateMeasurement(body, &answer, &error)) return RespondError(res, error);
//
// Common request fields, besides the setup (gear, wheel, machine, grid, flank):
//   settings               the settings the machine is commanded with (default nominal)
//   hidden_errors          the machine's hidden errors, added to what it is commanded:
//                          {"axes": {"X": [coefficients...], ...}, "wheel": {"cone_angle_deg",
//                          "parabola_coefficient_per_mm", "parabola_vertex_mm"}}, every part
//                          optional (missing = 0); or
//   random_hidden_errors   {"block_size", "max_order", "wheel_size", "seed", "fixed_blocks"}
//                          (RandomHiddenErrors: block_size in correction-size units, i.e. about
//                          block_size um of flank motion per axis)
//   noise_um, seed         probe noise sigma [um] and the random seed
//   outlier_probability, outlier_size_um, missing_probability, teeth
//   outlier_points, missing_points   [[row, column], ...]
// Closed loop only:
//   target                 as in a correction request (default none)
//   corrections            number of corrections (1..20, default 3)
//   options                correction options (probe_noise_um defaults to noise_um)
//   store                  true = keep each correction as a job, linked settings revision
//                          after revision (handled by the server)
#ifndef GEARLOOP_SERVER_SIMULATION_HANDLERS_H_
#define GEARLOOP_SERVER_SIMULATION_HANDLERS_H_

#include <vector>

#include <nlohmann/json.hpp>

#include "engine/simulation/measurement_simulator.h"
#include "server/codec/grinder_codec.h"
#include "storage/job_repository.h"

namespace gearloop {

// The simulated CMM grid: "measurement" {"deviations_um"} (null = missing), "teeth" (when more
// than one), "true_deviations_um", "outliers", "missing", "not_reached", "hidden_errors".
bool SimulateMeasurement(const nlohmann::json& body, nlohmann::json* answer, ApiError* error);

// The machine-independent part of a simulated measurement's answer on a rows x columns grid:
// "measurement" {"deviations_um", "teeth" (when more than one)}, "true_deviations_um",
// "outliers", "missing" and "not_reached" (with each point's status). The caller adds the
// machine's hidden errors and commanded settings or motion.
nlohmann::json SimulatedMeasurementToJson(const SimulatedMeasurement& cmm, int rows, int columns);

// The simulated probe of a measurement request, shared by the flat-wheel and the bevel
// simulations: noise_um, seed, outlier_probability, outlier_size_um, missing_probability and
// teeth into *measurement (absent fields keep its values, but seed and teeth default to 1),
// and with `with_point_lists` also outlier_points and missing_points on the rows x columns
// grid. Checks the values as MeasurementSimulationOptions::IsValid does, naming the API field.
bool ParseMeasurementSimulation(const nlohmann::json& body,
                                bool with_point_lists,
                                int rows,
                                int columns,
                                MeasurementSimulationOptions* measurement,
                                ApiError* error);

struct ClosedLoopRun {
  // "completed", "message", "hidden_errors", "iterations": [{part, settings, true_rms_um,
  // true_max_um, measured_rms_um, true_error_um, correction (summary or null)}].
  nlohmann::json answer;
  // One job per correction computed, in order: request (setup, the commanded settings, the
  // simulated measurement, target, options) and result; links left for the caller.
  std::vector<JobRecord> jobs;
};

bool SimulateClosedLoop(const nlohmann::json& body, ClosedLoopRun* run, ApiError* error);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SIMULATION_HANDLERS_H_
