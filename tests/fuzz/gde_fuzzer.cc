// tests/fuzz/gde_fuzzer.cc: libFuzzer target for the GDE (VDI/VDE 2610) XML
// reader, the import pipeline and the writer (formats/gde.h,
// formats/measurement_import.h; issue 15).
//
// Checks, besides the sanitizers: a refusal says why and names an element path
// or a line (the XML parser's), never an exception; an accepted file gives a 5
// x 9 grid with finite figures, and its grid written back as GDE (WriteGde)
// re-imports to the same grid within 0.001 um.
//
//   build-fuzz/tests/fuzz/gde_fuzzer -max_total_time=60 corpus/gde
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "engine/core/units.h"
#include "formats/gde.h"
#include "formats/measurement_import.h"
#include "tests/formats/metrology_samples.h"
#include "tests/fuzz/fuzz_check.h"

namespace {

using gearloop::fuzz::Check;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const gearloop::GearData gear = gearloop::testing::SampleGear();
  const std::string_view content(reinterpret_cast<const char*>(data), size);

  gearloop::MeasurementImportOptions options;
  options.format = gearloop::MeasurementFormat::kGde;
  const gearloop::MeasurementImportResult result =
      gearloop::ImportMeasurementFile(options, gear, content);
  if (!result.ok) {
    Check(!result.error.message.empty(), "a refusal says why");
    Check(!result.error.ToString().empty(), "the refusal renders");
    return 0;
  }
  Check(result.grid.deviations_um.size() == 45, "a 5 x 9 grid");
  Check(result.figures.ok && std::isfinite(result.figures.fHb_mean) &&
            std::isfinite(result.figures.Fa_max_abs),
        "finite figures");
  if (!result.grid.not_measured.empty())
    return 0;  // a net with holes is not re-importable

  gearloop::GdeExport out;
  out.gear = gear;
  out.grid = options.grid;
  out.flank = options.flank;
  out.topographies.push_back({"measured", 1, result.grid.deviations_um});
  out.figures = result.figures;
  out.classes = result.classes;
  const std::string xml = gearloop::WriteGde(out);
  const gearloop::MeasurementImportResult again =
      gearloop::ImportMeasurementFile(options, gear, xml);
  Check(again.ok, "the written GDE re-imports");
  for (Eigen::Index i = 0; i < result.grid.deviations_um.size(); ++i) {
    Check(std::abs(again.grid.deviations_um[i] -
                   result.grid.deviations_um[i]) <= 1e-3,
          "the round trip keeps the grid");
  }
  return 0;
}
