#include "server/services/bevel_service.h"

#include "engine/bevel/conversion.h"
#include "engine/bevel/freeform_generator.h"
#include "server/codec/bevel_codec.h"
#include "server/codec/request_keys.h"
#include "server/services/machine_family.h"

// Last: see server/respond.h.
#include <httplib.h>

namespace gearloop {

void BevelConversion(const httplib::Request& req, httplib::Response& res) {
  nlohmann::json body;
  ApiError error;
  BevelPinionJob job;
  ConversionOptions options;
  if (!ParseJsonBody(req.body, &body, &error) ||
      !CheckRequestKeys(RequestSchema::kBevelConversion, body, "", &error) ||
      !ParseBevelJob(body, &job, &error) ||
      !ParseConversionOptions(body, &options, &error)) {
    return RespondError(res, error);
  }
  const ConversionResult conversion = ConvertCradleToFreeForm(options, job);
  if (!conversion.ok) {
    return RespondError(
        res,
        InvalidValue(
            "job",
            "the cradle summary cannot be converted: " + conversion.message));
  }
  RespondJson(res, 200, ConversionToJson(job, conversion));
}

void BevelEvaluate(const httplib::Request& req, httplib::Response& res) {
  nlohmann::json body;
  ApiError error;
  BevelSetup setup;
  if (!ParseJsonBody(req.body, &body, &error) ||
      !CheckRequestKeys(RequestSchema::kBevelMotion, body, "", &error) ||
      !PrepareBevel(body, &setup, &error))
    return RespondError(res, error);
  const BevelFreeFormGenerator generator(setup.job, setup.grid, setup.nominal);
  ModelEvaluation evaluation;
  generator.Evaluate(
      setup.motion.ToVector(), /*with_jacobian=*/false, &evaluation);
  RespondJson(
      res,
      200,
      BevelEvaluationToJson(setup.job, setup.motion, setup.grid, evaluation));
}

void BevelAxisSensitivity(const httplib::Request& req, httplib::Response& res) {
  nlohmann::json body;
  ApiError error;
  BevelSetup setup;
  AxisSensitivityOptions options;
  if (!ParseJsonBody(req.body, &body, &error) ||
      !CheckRequestKeys(
          RequestSchema::kBevelAxisSensitivity, body, "", &error) ||
      !PrepareBevel(body, &setup, &error) ||
      !ParseAxisSensitivityOptions(body, &options, &error)) {
    return RespondError(res, error);
  }
  const BevelFreeFormGenerator generator(setup.job, setup.grid, setup.nominal);
  const AxisSensitivityTable table =
      ComputeAxisSensitivity(generator, setup.motion.ToVector(), options);
  RespondJson(res,
              200,
              AxisSensitivityToJson(setup.job,
                                    setup.motion,
                                    options,
                                    table,
                                    generator.GridRows(),
                                    generator.GridColumns()));
}

}  // namespace gearloop
