// server/services/settings_service.h: GET
// /api/v1/corrections/{id}/settings?format=csv|table|nc, the machine-ready
// listing of a stored correction (codec/settings_listing.h,
// docs/settings-listing.md). The stored request gives the machine and the
// commanded parameters, the stored result the corrected ones (read through
// the family's own request reader, so both pass the same validation); the
// axis motions come from engine/core/axis_motion.h over the result's roll
// range.
//
//   GetCorrectionSettings(context, req, res);   // 200 text/csv or text/plain
#ifndef GEARLOOP_SERVER_SERVICES_SETTINGS_SERVICE_H_
#define GEARLOOP_SERVER_SERVICES_SETTINGS_SERVICE_H_

#include "server/codec/settings_listing.h"
#include "server/respond.h"
#include "server/services/service_context.h"
#include "storage/job_repository.h"

namespace gearloop {

// Most roll angles a listing samples the axes at (?samples=N, default 9).
constexpr int kMaxSettingsSamples = 1001;

// The listing of a stored job with the axes sampled at `samples` roll angles;
// false (422) for a job without corrected settings. Throws when the stored
// documents do not parse.
bool BuildSettingsListing(const JobRecord& job,
                          int samples,
                          SettingsListing* listing,
                          ApiError* error);

void GetCorrectionSettings(const ServiceContext& context,
                           const httplib::Request& req,
                           httplib::Response& res);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_SERVICES_SETTINGS_SERVICE_H_
