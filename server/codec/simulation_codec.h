// server/codec/simulation_codec.h: the simulated measuring machine and the
// simulated closed loop of POST /api/v1/simulations/measurement and
// /closed-loop (engine/simulation/measurement_simulator.h): their request
// pieces read from JSON and their answers written back. Pure mapping; the runs
// are in server/services/simulation_service.h.
//
//   MeasurementSimulationOptions measurement;
//   ApiError error;
//   if (!ParseMeasurementSimulation(body, true, rows, columns, &measurement,
//   &error)) {
//     return RespondError(res, error);
//   }
//
// Common request fields, besides the machine's own (gear, wheel, machine, grid,
// flank or job, motion):
//   settings               the settings the machine is commanded with (default
//   nominal) hidden_errors          the machine's hidden errors, added to what
//   it is commanded:
//                          {"axes": {"X": [coefficients...], ...}, "wheel":
//                          {"cone_angle_deg", "parabola_coefficient_per_mm",
//                          "parabola_vertex_mm"}}, every part optional (missing
//                          = 0); or
//   random_hidden_errors   {"block_size", "max_order", "wheel_size", "seed",
//   "fixed_blocks"}
//                          (RandomHiddenErrors: block_size in correction-size
//                          units, i.e. about block_size um of flank motion per
//                          axis)
//   noise_um, seed         probe noise sigma [um] and the random seed
//   outlier_probability, outlier_size_um, missing_probability, teeth
//   outlier_points, missing_points   [[row, column], ...]
// Closed loop only:
//   target                 as in a correction request (default none)
//   corrections            number of corrections (1..20, default 3)
//   options                correction options (probe_noise_um defaults to
//   noise_um) store                  true = keep each correction as a job,
//   linked settings revision
//                          after revision (handled by the service)
#ifndef GEARLOOP_SERVER_CODEC_SIMULATION_CODEC_H_
#define GEARLOOP_SERVER_CODEC_SIMULATION_CODEC_H_

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "engine/simulation/measurement_simulator.h"
#include "server/codec/json_read.h"

namespace gearloop {

// The grinder's "hidden_errors" coefficient by coefficient into a parameter
// vector (kNumGrinderParameters entries; absent parts are 0).
bool ParseGrinderHiddenErrors(const nlohmann::json& value,
                              Eigen::VectorXd* errors,
                              ApiError* error);

// "random_hidden_errors": the arguments of RandomHiddenErrors
// (engine/simulation).
struct RandomHiddenErrorsRequest {
  double block_size = 1.0;
  int max_order = 2;
  double wheel_size = 0.0;
  std::uint64_t seed = 1;
  std::vector<std::string> fixed_blocks;
};
bool ParseRandomHiddenErrors(const nlohmann::json& value,
                             RandomHiddenErrorsRequest* request,
                             ApiError* error);

// The simulated probe of a measurement request, shared by the flat-wheel and
// the bevel simulations: noise_um, seed, outlier_probability, outlier_size_um,
// missing_probability and teeth into *measurement (absent fields keep its
// values, but seed and teeth default to 1), and with `with_point_lists` also
// outlier_points and missing_points on the rows x columns grid. Checks the
// values as MeasurementSimulationOptions::IsValid does, naming the API field.
bool ParseMeasurementSimulation(const nlohmann::json& body,
                                bool with_point_lists,
                                int rows,
                                int columns,
                                MeasurementSimulationOptions* measurement,
                                ApiError* error);

// The machine-independent part of a simulated measurement's answer on a rows x
// columns grid: "measurement" {"deviations_um", "teeth" (when more than one)},
// "true_deviations_um", "outliers", "missing" and "not_reached" (with each
// point's status). The caller adds the machine's hidden errors and commanded
// settings or motion.
nlohmann::json SimulatedMeasurementToJson(const SimulatedMeasurement& cmm,
                                          int rows,
                                          int columns);

// "corrections" (1..20, default 3) and "options" of a closed loop into `loop`
// (whose measurement is already read): the options default probe_noise_um to
// the measurement's noise; `options_body` receives them as used (they are
// stored with each job).
bool ParseClosedLoop(const nlohmann::json& body,
                     int rows,
                     int columns,
                     ClosedLoopOptions* loop,
                     nlohmann::json* options_body,
                     ApiError* error);

// One part of a closed loop: {part, <parameters_key>: commanded, true_rms_um,
// true_max_um, measured_rms_um, true_error_um, correction (summary or null)}.
nlohmann::json ClosedLoopIterationToJson(const ClosedLoopIteration& iteration,
                                         const std::string& parameters_key,
                                         const nlohmann::json& commanded,
                                         int rows,
                                         int columns);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_SIMULATION_CODEC_H_
