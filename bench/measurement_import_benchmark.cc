// bench/measurement_import_benchmark.cc: import of a measuring-machine file at
// production size (issue 15; BENCHMARKS.md, "Measurement import"): a
// Klingelnberg .mka topography of 480 values per trace, 5 profile + 5 helix
// traces per flank, 2 flanks, through the whole pipeline (decode, parse, header
// check, Gordon interpolation, ISO 1328-1 figures and classes). Goal: < 20 ms.
//
//   build/bench/measurement_import_benchmark
//   build/bench/measurement_import_benchmark --write-mka FILE   (the file only,
//   for bench/http_import_benchmark.py)
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>

#include "engine/core/units.h"
#include "formats/gde.h"
#include "formats/measurement_import.h"
#include "tests/formats/metrology_samples.h"

namespace gearloop {
namespace {

// A smooth flank (crowning, slopes, twist) and a little waviness, in the
// printout's 3 decimals.
double Flank(double l, double x, double s) {
  return s * (-3.0 * std::pow((l - 25.7) / 9.2, 2) -
              6.0 * std::pow(x / 16.0, 2) + 0.2 * (l - 25.7) + 0.15 * x +
              0.01 * (l - 25.7) * x) +
         0.2 * std::sin(3.0 * l + x);
}

std::string MakeMkaFile(int values) {
  const GearData gear = testing::SampleGear();
  const double r_b = gear.BaseRadiusMm();
  auto roll = [&](double d) { return std::sqrt(d * d / 4 - r_b * r_b); };
  std::string out =
      "\xEF\xBB\xBFHEADER KS.MK.FILE\r\nUNDEFINED  -2147483.648\r\n";
  out +=
      "   21 :Normalmodul.........mn [mm].........: 4.5000\r\n   22 "
      ":Zaehnezahl z........................: 31\r\n";
  out +=
      "   23 :Schraegungswinkel...................: 20.0000\r\n   24 "
      ":Eingriffswinkel.....................: 20.0000\r\n";
  out +=
      "   26 :Zahnbreite [mm].....................: 40.000\r\n   45 "
      ":Auswertelaenge Profil...............: 24.961\r\n";
  out += "   41 :Start Messbereich...................:   140.500   140.500\r\n";
  out += "   44 :Ende Messbereich....................:   157.000   157.000\r\n";
  out +=
      "   61 :Start Messbereich...................:     1.000\r\n   64 :Ende "
      "Messbereich....................:    39.000\r\n\r\n";
  char buffer[160];
  for (const char* flank : {"rechts", "links"}) {
    const double s = flank[0] == 'r' ? 1.0 : 0.8;
    int k = 0;
    for (double z : {3.0, 11.5, 20.0, 28.5, 37.0}) {
      std::snprintf(
          buffer,
          sizeof(buffer),
          "TOPOGRAFIE: Zahn-Nr.: 1 /Profil:%d %s / %d Werte  / z= %.3f\r\n",
          ++k,
          flank,
          values,
          z);
      out += buffer;
      for (int i = 0; i < values; ++i) {
        const double l =
            roll(140.5) + (roll(157.0) - roll(140.5)) * i / (values - 1);
        std::snprintf(buffer, sizeof(buffer), "%9.3f", Flank(l, z - 20.0, s));
        out += buffer;
        if (i % 12 == 11 || i == values - 1) out += "\r\n";
      }
    }
    k = 0;
    for (double d : {142.0, 145.0, 148.5, 152.0, 155.5}) {
      std::snprintf(buffer,
                    sizeof(buffer),
                    "TOPOGRAFIE: Zahn-Nr.: 1 /Flankenlinie:%d %s / %d Werte  / "
                    "d= %.3f\r\n",
                    ++k,
                    flank,
                    values,
                    d);
      out += buffer;
      for (int i = 0; i < values; ++i) {
        const double z = 1.0 + 38.0 * i / (values - 1);
        std::snprintf(
            buffer, sizeof(buffer), "%9.3f", Flank(roll(d), z - 20.0, s));
        out += buffer;
        if (i % 12 == 11 || i == values - 1) out += "\r\n";
      }
    }
  }
  return out;
}

void BM_ImportMka480x5x2(benchmark::State& state) {
  const std::string file = MakeMkaFile(static_cast<int>(state.range(0)));
  const GearData gear = testing::SampleGear();
  MeasurementImportOptions options;
  for (auto _ : state) {
    const MeasurementImportResult result =
        ImportMeasurementFile(options, gear, file);
    if (!result.ok) state.SkipWithError(result.error.ToString().c_str());
    benchmark::DoNotOptimize(result.figures.fHa_mean);
  }
  state.counters["file_kB"] = static_cast<double>(file.size()) / 1024.0;
}
BENCHMARK(BM_ImportMka480x5x2)->Arg(480)->Unit(benchmark::kMillisecond);

void BM_ImportGdeExport(benchmark::State& state) {
  const GearData gear = testing::SampleGear();
  MeasurementImportOptions mka;
  const MeasurementImportResult measured =
      ImportMeasurementFile(mka, gear, MakeMkaFile(480));
  GdeExport out;
  out.gear = gear;
  out.topographies = {{"measured", 1, measured.grid.deviations_um},
                      {"target", 1, measured.grid.deviations_um * 0.5},
                      {"predicted", 1, measured.grid.deviations_um * 0.1}};
  out.figures = measured.figures;
  out.classes = measured.classes;
  const std::string xml = WriteGde(out);
  MeasurementImportOptions options;
  options.format = MeasurementFormat::kGde;
  for (auto _ : state) {
    const MeasurementImportResult result =
        ImportMeasurementFile(options, gear, xml);
    if (!result.ok) state.SkipWithError(result.error.ToString().c_str());
    benchmark::DoNotOptimize(result.figures.fHa_mean);
  }
}
BENCHMARK(BM_ImportGdeExport)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace gearloop

int main(int argc, char** argv) {
  // The benchmark's file, for timing the same import over HTTP.
  if (argc == 3 && std::strcmp(argv[1], "--write-mka") == 0) {
    std::ofstream out(argv[2], std::ios::binary);
    out << gearloop::MakeMkaFile(480);
    return out ? 0 : 1;
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
