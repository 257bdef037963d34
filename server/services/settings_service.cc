#include "server/services/settings_service.h"

#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

#include "engine/core/axis_motion.h"
#include "engine/core/units.h"
#include "server/services/machine_family.h"
#include "server/services/stored_job.h"

// Last: see server/respond.h.
#include <httplib.h>

namespace gearloop {
namespace {

std::string CoefficientUnit(const ParameterBlock& block, int power) {
  if (!block.is_polynomial || power == 0) return block.unit;
  return block.unit + "/rad" + (power == 1 ? "" : "^" + std::to_string(power));
}

// The coefficients of every block, absolute and changed.
void ListCoefficients(const std::vector<ParameterBlock>& blocks,
                      const Eigen::VectorXd& corrected,
                      const Eigen::VectorXd& delta,
                      SettingsListing* listing) {
  for (const ParameterBlock& block : blocks) {
    for (int k = 0; k < block.num_coefficients; ++k) {
      const int i = block.first_index + k;
      listing->coefficients.push_back({block.name,
                                       block.is_polynomial,
                                       block.is_polynomial ? k : 0,
                                       CoefficientUnit(block, k),
                                       corrected(i),
                                       delta(i)});
    }
  }
}

// The polynomial axes over [roll_min, roll_max]: position and change.
void ListMotions(const std::vector<ParameterBlock>& blocks,
                 const Eigen::VectorXd& corrected,
                 const Eigen::VectorXd& delta,
                 double roll_min_rad,
                 double roll_max_rad,
                 int samples,
                 SettingsListing* listing) {
  const AxisMotion change =
      ComputeAxisMotion(blocks, delta, roll_min_rad, roll_max_rad, samples);
  const AxisMotion position =
      ComputeAxisMotion(blocks, corrected, roll_min_rad, roll_max_rad, samples);
  listing->roll_rad = change.roll_rad;
  for (size_t b = 0; b < blocks.size(); ++b) {
    if (!blocks[b].is_polynomial) continue;
    std::string change_unit;
    const double factor = AxisMotionUnitFactor(blocks[b].unit, &change_unit);
    SettingsListing::Motion motion;
    motion.block = blocks[b].name;
    motion.unit = blocks[b].unit;
    motion.change_unit = change_unit;
    motion.change = change.blocks[b].change;
    for (double v : position.blocks[b].change)
      motion.absolute.push_back(v / factor);
    listing->motions.push_back(std::move(motion));
  }
}

}  // namespace

bool BuildSettingsListing(const JobRecord& job,
                          int samples,
                          SettingsListing* listing,
                          ApiError* error) {
  nlohmann::json request, result;
  ParseStoredJob(job, &request, &result);
  CorrectionProblem commanded;
  if (!CorrectionProblemFor(request, &commanded, error))
    throw std::runtime_error("stored request of job " + std::to_string(job.id) +
                             " does not parse: " + error->message);
  const std::string& key = commanded.parameters_key;
  const nlohmann::json range = result.value("roll_range_deg", nlohmann::json());
  if (!result.contains(key) || !range.is_array() || range.size() != 2 ||
      !range[0].is_number() || !range[1].is_number()) {
    *error =
        InvalidValue("",
                     "job " + std::to_string(job.id) + " holds no corrected " +
                         key + " (a closed-loop step stores only its summary)");
    return false;
  }
  // The corrected parameters, read as a request would give them.
  nlohmann::json corrected_request = request;
  corrected_request[key] = result[key];
  // The answer of a solver without bounds (lsq-plain) may be beyond what a
  // request may carry: refused, named, not an internal error.
  CorrectionProblem corrected;
  if (!CorrectionProblemFor(corrected_request, &corrected, error)) {
    *error = InvalidValue(error->field,
                          "the corrected " + key + " of job " +
                              std::to_string(job.id) +
                              " cannot be listed: " + error->message);
    return false;
  }
  const Eigen::VectorXd delta =
      corrected.current_parameters - commanded.current_parameters;
  const std::vector<ParameterBlock> blocks = commanded.model->ParameterBlocks();
  listing->job_id = job.id;
  listing->machine_kind = job.machine_kind;
  listing->part_number = job.part_number;
  listing->serial = job.serial;
  ListCoefficients(blocks, corrected.current_parameters, delta, listing);
  ListMotions(blocks,
              corrected.current_parameters,
              delta,
              range[0].get<double>() / kDegPerRad,
              range[1].get<double>() / kDegPerRad,
              samples,
              listing);
  return true;
}

void GetCorrectionSettings(const ServiceContext& context,
                           const httplib::Request& req,
                           httplib::Response& res) {
  const std::optional<JobRecord> job = ReadPathJob(context, req);
  if (!job) return RespondError(res, NoStoredJob(req.matches[1].str()));
  std::string format = "table";
  if (req.has_param("format")) {
    format = req.get_param_value("format");
    if (req.get_param_value_count("format") > 1 ||
        !IsSettingsListingFormat(format)) {
      return RespondError(
          res,
          InvalidRequest("query.format",
                         "query.format must be csv, table or nc (given once)"));
    }
  }
  int samples = kAxisMotionSamples;
  if (req.has_param("samples")) {
    const std::string text = req.get_param_value("samples");
    if (text.empty() || text.size() > 6 ||
        text.find_first_not_of("0123456789") != std::string::npos) {
      return RespondError(
          res,
          InvalidRequest("query.samples", "query.samples must be an integer"));
    }
    samples = std::stoi(text);
    if (samples < 2 || samples > kMaxSettingsSamples) {
      return RespondError(
          res,
          InvalidValue("query.samples",
                       "query.samples must lie in [2, " +
                           std::to_string(kMaxSettingsSamples) + "]"));
    }
  }
  SettingsListing listing;
  ApiError error;
  if (!BuildSettingsListing(*job, samples, &listing, &error))
    return RespondError(res, error);
  res.status = 200;
  if (format == "csv") {
    res.set_header("Content-Disposition",
                   "attachment; filename=\"settings-" +
                       std::to_string(job->id) + ".csv\"");
    res.set_content(SettingsListingCsv(listing), "text/csv; charset=utf-8");
  } else if (format == "nc") {
    res.set_content(SettingsListingNc(listing), "text/plain; charset=utf-8");
  } else {
    res.set_content(SettingsListingTable(listing), "text/plain; charset=utf-8");
  }
}

}  // namespace gearloop
