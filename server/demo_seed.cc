#include "server/demo_seed.h"

#include <httplib.h>

#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

namespace gearloop {
namespace {

std::string Fixed(double value, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", digits, value);
  return buffer;
}

double Number(const nlohmann::json& value) {
  return value.is_number() ? value.get<double>() : 0.0;
}

nlohmann::json DemoSetup() {
  return nlohmann::json::parse(R"({
    "gear": {"teeth": 37, "normal_module_mm": 6, "normal_pressure_angle_deg": 20,
             "helix_angle_deg": 15, "hand": "left", "face_width_mm": 78,
             "tip_radius_mm": 120.9157, "root_radius_mm": 107.1569},
    "wheel": {"radius_mm": 350},
    "machine": {"kind": "flat-wheel-grinder", "k1_mm": 0, "k2_mm": 0, "traverse_mm_per_rad": 0},
    "grid": {"profile_points": 5, "lead_points": 9, "profile_range": [0.2, 0.9], "lead_range": [-0.4, 0.4]},
    "flank": "right"})");
}

class DemoClient {
 public:
  DemoClient(const std::string& host,
             int port,
             const std::string& token,
             std::ostream& out)
      : client_(host, port), out_(out) {
    client_.set_read_timeout(120, 0);
    client_.set_tcp_nodelay(true);
    if (!token.empty()) headers_.emplace("Authorization", "Bearer " + token);
  }

  // The answer's body when the status is `expected`; prints why not and returns
  // null otherwise.
  nlohmann::json Call(const std::string& method,
                      const std::string& path,
                      const nlohmann::json& body,
                      int expected) {
    httplib::Result result =
        method == "GET"
            ? client_.Get(path.c_str(), headers_)
            : client_.Post(
                  path.c_str(), headers_, body.dump(), "application/json");
    if (!result) {
      out_ << "demo: " << method << " " << path << " failed: no answer\n";
      return nullptr;
    }
    if (result->status != expected) {
      out_ << "demo: " << method << " " << path << " answered "
           << result->status << ": " << result->body << "\n";
      return nullptr;
    }
    return nlohmann::json::parse(result->body, nullptr, false);
  }

 private:
  httplib::Client client_;
  httplib::Headers headers_;
  std::ostream& out_;
};

// The simulation of the demo's first part: hidden machine errors and 0.3 um
// probe noise.
nlohmann::json DemoSimulation() {
  nlohmann::json simulation = DemoSetup();
  simulation["random_hidden_errors"] = {
      {"block_size", 3.0}, {"max_order", 2}, {"seed", 4}};
  simulation["noise_um"] = 0.3;
  simulation["seed"] = 9;
  return simulation;
}

// Steps 1 and 2: measures the simulated part and stores its correction as a
// job; *request is the correction request, *job the stored job.
bool SeedCorrection(DemoClient& client,
                    std::ostream& out,
                    const nlohmann::json& simulation,
                    nlohmann::json* request,
                    nlohmann::json* job) {
  // 1. A part ground with hidden machine errors, measured with 0.3 um probe
  // noise.
  const nlohmann::json measured =
      client.Call("POST", "/api/v1/simulations/measurement", simulation, 200);
  if (measured.is_null()) return false;

  // 2. The correction, stored as a job.
  *request = DemoSetup();
  (*request)["measurement"] = measured["measurement"];
  (*request)["target"] = {
      {"modifications", {{{"kind", "profile_crowning"}, {"amount_um", 3.0}}}}};
  (*request)["options"] = {{"probe_noise_um", 0.3}};
  *job = client.Call("POST", "/api/v1/corrections", *request, 201);
  if (job->is_null()) return false;
  const nlohmann::json& stored = *job;
  const nlohmann::json& result = stored["result"];
  out << "  1. measured part (hidden machine errors, 0.3 um probe noise), "
         "target 3 um profile crowning:\n"
      << "     flank error rms " << Fixed(Number(result["initial_rms_um"]), 2)
      << " um, max " << Fixed(Number(result["initial_max_um"]), 2) << " um\n"
      << "  2. correction job #" << stored["id"] << " ("
      << result["status"].get<std::string>() << ", "
      << result["solver"].get<std::string>() << ", "
      << result["regularisation"]["rule"].get<std::string>()
      << "): predicted residual rms "
      << Fixed(Number(result["residual_rms_um"]), 2) << " um; best reachable "
      << Fixed(Number(result["best_reachable_rms_um"]), 2) << " um; rank "
      << result["rank"] << "\n";
  return true;
}

// Step 3: replays the job with a changed target.
bool SeedReplay(DemoClient& client,
                std::ostream& out,
                const nlohmann::json& job) {
  // 3. A replay of the same measurement with a changed target, linked to its
  // parent.
  const std::string replay_path = "/api/v1/corrections/" +
                                  std::to_string(job["id"].get<long long>()) +
                                  "/replay";
  const nlohmann::json changed_target = {
      {"modifications",
       {{{"kind", "profile_crowning"}, {"amount_um", 3.0}},
        {{"kind", "lead_crowning"}, {"amount_um", 2.0}}}}};
  const nlohmann::json replay =
      client.Call("POST", replay_path, {{"target", changed_target}}, 201);
  if (replay.is_null()) return false;
  out << "  3. replay job #" << replay["id"] << " of job #" << job["id"]
      << ": same measurement, target plus 2 um lead crowning: predicted "
         "residual rms "
      << Fixed(Number(replay["result"]["residual_rms_um"]), 2) << " um\n";
  return true;
}

// Step 4: closed-loop rounds stored as a settings lineage.
bool SeedClosedLoop(DemoClient& client,
                    std::ostream& out,
                    const nlohmann::json& simulation,
                    const nlohmann::json& request) {
  // 4. Three rounds of grind -> measure -> correct, stored as a settings
  // lineage.
  nlohmann::json loop = simulation;
  loop["target"] = request["target"];
  loop["corrections"] = 3;
  loop["seed"] = 21;
  loop["store"] = true;
  const nlohmann::json run =
      client.Call("POST", "/api/v1/simulations/closed-loop", loop, 200);
  if (run.is_null()) return false;
  out << "  4. closed loop, true flank error rms of each part ground:";
  std::string last_job;
  for (const nlohmann::json& iteration : run["iterations"]) {
    out << (iteration["part"] == 0 ? " " : " -> ")
        << Fixed(Number(iteration["true_rms_um"]), 2);
    if (iteration.contains("job_id"))
      last_job = std::to_string(iteration["job_id"].get<long long>());
  }
  out << " um\n";
  if (!last_job.empty()) {
    out << "     stored as a settings lineage: GET /api/v1/corrections/"
        << last_job << "/lineage\n";
  }
  return true;
}

// Step 5: what the machine can make of the replay's target before anything
// is ground (POST /api/v1/targets/reach; nothing is stored).
bool PrintReach(DemoClient& client, std::ostream& out) {
  nlohmann::json request = DemoSetup();
  request["target"] = {{"modifications",
                        {{{"kind", "profile_crowning"}, {"amount_um", 3.0}},
                         {{"kind", "lead_crowning"}, {"amount_um", 2.0}}}}};
  const nlohmann::json reach =
      client.Call("POST", "/api/v1/targets/reach", request, 200);
  if (reach.is_null()) return false;
  out << "  5. reach of that target on this machine (POST /api/v1/targets/"
         "reach):\n";
  for (const nlohmann::json& part : reach["components"]) {
    out << "     " << part["modification"].value("kind", std::string()) << ": "
        << Fixed(100.0 * Number(part["reachable_share"]), 1)
        << " % can be made (target rms "
        << Fixed(Number(part["target_rms_um"]), 2) << " um, not made "
        << Fixed(Number(part["unreachable_rms_um"]), 2) << " um)\n";
    // What would make the rest, as the server computed it.
    if (part["remedy"].is_object())
      out << "       -> " << part["remedy"].value("message", std::string())
          << "\n";
  }
  const nlohmann::json& both = reach["combined"];
  out << "     together: " << Fixed(100.0 * Number(both["reachable_share"]), 1)
      << " %";
  if (reach["with_highest_orders"].is_object() &&
      !reach["with_highest_orders"].value("same_as_combined", false)) {
    out << "; with every axis free to order 6: "
        << Fixed(
               100.0 * Number(reach["with_highest_orders"]["reachable_share"]),
               1)
        << " %";
  }
  out << "\n";
  return true;
}

}  // namespace

bool SeedDemo(const std::string& host,
              int port,
              const std::string& token,
              std::ostream& out) {
  DemoClient client(host, port, token, out);
  const nlohmann::json history =
      client.Call("GET", "/api/v1/corrections?limit=1", nullptr, 200);
  if (history.is_null()) return false;
  if (history.value("total", 0) > 0) {
    out << "Job history: " << history["total"]
        << " stored jobs (demo already seeded).\n";
    return true;
  }
  out << "Seeding the job history with a short closed-loop demo (API.md "
         "example gear: z = 37, m_n = 6 mm,\n"
         "20 deg, helix 15 deg left hand, b = 78 mm, wheel R_w = 350 mm, right "
         "flank, 5 x 9 grid).\n";

  const nlohmann::json simulation = DemoSimulation();
  nlohmann::json request;
  nlohmann::json job;
  return SeedCorrection(client, out, simulation, &request, &job) &&
         SeedReplay(client, out, job) &&
         SeedClosedLoop(client, out, simulation, request) &&
         PrintReach(client, out);
}

}  // namespace gearloop
