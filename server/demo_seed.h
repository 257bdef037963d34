// server/demo_seed.h: the short closed-loop demo `scripts/run` seeds an empty
// job history with, spoken over HTTP to the running server like any client (so
// it also proves the server works):
//   1. a part of the API.md example gear ground with hidden machine errors is
//   measured
//      (POST /api/v1/simulations/measurement, probe noise 0.3 um);
//   2. the correction is computed and stored (POST /api/v1/corrections);
//   3. the stored job is replayed with the published particle-swarm solver for
//   comparison
//      (POST /api/v1/corrections/{id}/replay);
//   4. three rounds of grind -> measure -> correct are simulated and stored as
//   a settings
//      lineage (POST /api/v1/simulations/closed-loop with store = true).
// It prints what a user wants to see: the flank error before, the predicted
// residual, the job ids and where to look at them.
//
//   if (!SeedDemo("127.0.0.1", port, "", std::cout)) { ... }
#ifndef GEARLOOP_SERVER_DEMO_SEED_H_
#define GEARLOOP_SERVER_DEMO_SEED_H_

#include <ostream>
#include <string>

namespace gearloop {

// Runs the demo against the server at host:port (with `token` as a bearer token
// when not empty), printing to `out`. Does nothing (and returns true) when the
// history already holds jobs. Returns false, with the reason printed, when a
// step fails.
bool SeedDemo(const std::string& host,
              int port,
              const std::string& token,
              std::ostream& out);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_DEMO_SEED_H_
