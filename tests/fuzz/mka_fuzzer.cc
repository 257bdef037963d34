// tests/fuzz/mka_fuzzer.cc: libFuzzer target for the Klingelnberg .mka reader
// and the import pipeline behind it (formats/mka_reader.h,
// formats/measurement_import.h; issue 15).
//
// Besides the sanitizers' own findings it checks the contract of METROLOGY.md
// §5: a refusal says why and where (a file line, or the file as a whole for the
// size limit and a missing trace), never an exception; an accepted file gives a
// 5 x 9 grid whose defined values are finite and figures that are finite. The
// whole input is the file's text; the sample gear is the request.
//
//   build-fuzz/tests/fuzz/mka_fuzzer -max_total_time=60 corpus/mka
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

#include "engine/core/units.h"
#include "formats/measurement_import.h"
#include "formats/mka_reader.h"
#include "tests/formats/metrology_samples.h"
#include "tests/fuzz/fuzz_check.h"

namespace {

using gearloop::fuzz::Check;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const gearloop::GearData gear = gearloop::testing::SampleGear();
  const std::string_view content(reinterpret_cast<const char*>(data), size);

  gearloop::MeasurementFile file;
  gearloop::FileError error;
  if (!gearloop::ReadMkaFile(content, &file, &error)) {
    Check(!error.message.empty(), "a refusal says why");
    Check(error.place.line >= 0, "a line number or 0");
    Check(error.place.element_path.empty(),
          "an mka refusal names a line, not an element");
  } else {
    Check(!file.traces.empty(), "an accepted file has traces");
    Check(file.trace_places.size() == file.traces.size(),
          "every trace has its place");
  }

  for (gearloop::Flank flank :
       {gearloop::Flank::kRight, gearloop::Flank::kLeft}) {
    gearloop::MeasurementImportOptions options;
    options.format = gearloop::MeasurementFormat::kMka;
    options.flank = flank;
    const gearloop::MeasurementImportResult result =
        gearloop::ImportMeasurementFile(options, gear, content);
    if (!result.ok) {
      Check(!result.error.message.empty(), "an import refusal says why");
      Check(!result.error.ToString().empty(), "the refusal renders");
      continue;
    }
    Check(result.grid.deviations_um.size() == 45, "a 5 x 9 grid");
    for (Eigen::Index i = 0; i < result.grid.deviations_um.size(); ++i) {
      const double v = result.grid.deviations_um[i];
      Check(std::isnan(v) || std::isfinite(v), "grid values finite or missing");
    }
    Check(result.figures.ok, "an accepted import has figures");
    Check(std::isfinite(result.figures.fHa_mean) &&
              std::isfinite(result.figures.Fb_max_abs) &&
              std::isfinite(result.figures.Ca_mean) &&
              std::isfinite(result.figures.twist_beta_grid),
          "finite figures");
  }
  return 0;
}
