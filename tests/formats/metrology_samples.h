// tests/formats/metrology_samples.h: the sample gear and analytic flank of
// shared/formats/README.md, and the sample files, for the metrology tests.
#ifndef GEARLOOP_TESTS_FORMATS_METROLOGY_SAMPLES_H_
#define GEARLOOP_TESTS_FORMATS_METROLOGY_SAMPLES_H_

#include <fstream>
#include <sstream>
#include <string>

#include "engine/core/units.h"
#include "engine/grinder/grinding_setup.h"
#include "engine/metrology/trace_grid.h"

namespace gearloop {
namespace testing {

// z = 31, m_n = 4.5, alpha_n = 20 deg, beta = 20 deg right hand (negative in
// MODEL.md §1), b = 40, d_a = 157.452, d_f = 137.202 (the root the wheel
// reaches).
inline GearData SampleGear() {
  GearData gear;
  gear.teeth = 31;
  gear.normal_module_mm = 4.5;
  gear.normal_pressure_angle_rad = DegToRad(20.0);
  gear.helix_angle_rad = -DegToRad(20.0);
  gear.face_width_mm = 40.0;
  gear.tip_radius_mm = 157.452 / 2.0;
  gear.root_radius_mm = 137.202 / 2.0;
  return gear;
}

// The modification forms of MODEL.md §7 with the sample's coefficients.
struct FlankForms {
  double crowning_alpha = 0.0;
  double crowning_beta = 0.0;
  double slope_alpha = 0.0;
  double slope_beta = 0.0;
  double twist = 0.0;
  double offset = 0.0;
};

inline FlankForms SampleForms(Flank flank) {
  if (flank == Flank::kRight) return FlankForms{3.0, 6.0, 4.0, 5.0, 2.0, 1.0};
  return FlankForms{2.5, 5.0, -3.0, -4.0, -1.5, 0.5};
}

// e(L, x) [um] with xi over the default grid's roll-length extent and eta over
// its face extent.
inline double FormsAt(const FlankForms& f,
                      const GearData& gear,
                      double roll_length_mm,
                      double x_mm) {
  const GridOptions grid;
  const std::vector<double> l = GridRollLengthsMm(gear, grid);
  const std::vector<double> x = GridAxialPositionsMm(gear, grid);
  const double xi = (roll_length_mm - l.front()) / (l.back() - l.front());
  const double eta =
      (x_mm - 0.5 * (x.front() + x.back())) / (0.5 * (x.back() - x.front()));
  return -f.crowning_alpha * (2 * xi - 1) * (2 * xi - 1) -
         f.crowning_beta * eta * eta + f.slope_alpha * (xi - 0.5) +
         f.slope_beta * eta / 2 + f.twist * (xi - 0.5) * eta + f.offset;
}

inline Eigen::VectorXd FormsOnGrid(const FlankForms& f, const GearData& gear) {
  const GridOptions grid;
  const std::vector<double> l = GridRollLengthsMm(gear, grid);
  const std::vector<double> x = GridAxialPositionsMm(gear, grid);
  Eigen::VectorXd out(static_cast<Eigen::Index>(l.size() * x.size()));
  for (size_t i = 0; i < l.size(); ++i) {
    for (size_t j = 0; j < x.size(); ++j)
      out[static_cast<Eigen::Index>(i * x.size() + j)] =
          FormsAt(f, gear, l[i], x[j]);
  }
  return out;
}

// A sample file: shared/formats when the checkout sits beside shared/, else the
// copy in tests/formats/data.
inline std::string ReadSample(const std::string& name) {
  for (const std::string& dir :
       {std::string(GEARLOOP_SOURCE_DIR) + "/tests/formats/data/",
        std::string(GEARLOOP_SOURCE_DIR) + "/../shared/formats/"}) {
    std::ifstream in(dir + name, std::ios::binary);
    if (!in) continue;
    std::ostringstream out;
    out << in.rdbuf();
    return out.str();
  }
  return std::string();
}

}  // namespace testing
}  // namespace gearloop

#endif  // GEARLOOP_TESTS_FORMATS_METROLOGY_SAMPLES_H_
