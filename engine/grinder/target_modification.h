// engine/grinder/target_modification.h: the wanted flank modifications of
// MODEL.md §7, evaluated on the measurement grid, and the combination of
// several measured teeth into one grid.
//
//   std::vector<TargetModification> target = {
//       {ModificationKind::kProfileCrowning, /*amount_um=*/3.0},
//       {ModificationKind::kTipRelief, /*amount_um=*/8.0,
//       /*length_fraction=*/0.3}};
//   Eigen::VectorXd t_um = EvaluateTargetModifications(target, grid,
//   setup.gear, setup.flank);
//
// A target is a grid of wanted deviations from the involute in micrometres,
// row-major like FlankGrid::points, NEGATIVE = material removed (the metrology
// sign of the deviations: positive = material left on). It is either a user
// grid or a sum of the parametric kinds below.
//
// Grid coordinates (MODEL.md §7): with L the roll length and x the axial
// position of a grid point, and L_s..L_e, x_s..x_e the grid's own extent,
//   xi  = (L - L_s) / (L_e - L_s)                   in [0, 1], root -> tip
//   eta = (x - (x_s + x_e)/2) / ((x_e - x_s)/2)     in [-1, 1]
//   w   = L + s x tan(beta_b), normalised to [0, 1] over the grid, constant
//   along a contact line
// where tan(beta_b) = tan(beta) cos(alpha_t) (GearData::TanBaseHelixAngle,
// signed) and s = +1 on the right flank, -1 on the left flank (MODEL.md §7 as
// corrected: the sign of the x term follows the flank). In the engine's frames
// (MODEL.md §3) w is constant along the flat wheel's instantaneous contact line
// and the nominal contact roll phi1 is w / r_b + const, on both flanks and both
// hands (tests/engine/target_modification_test.cc). SHAVING.md §2 uses the same
// w on the right flank of the shaved pinion.
#ifndef GEARLOOP_ENGINE_GRINDER_TARGET_MODIFICATION_H_
#define GEARLOOP_ENGINE_GRINDER_TARGET_MODIFICATION_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "engine/grinder/flank_grid.h"
#include "engine/grinder/grinding_setup.h"

namespace gearloop {

enum class ModificationKind {
  kProfileCrowning,  // -C_alpha (2 xi - 1)^2 amount = C_alpha
  kLeadCrowning,  // -C_beta eta^2                                     amount =
                  // C_beta
  kProfileSlope,  // f_Halpha (xi - 1/2)                               amount =
                  // f_Halpha
  kHelixSlope,    // f_Hbeta eta / 2                                   amount =
                  // f_Hbeta
  kTipRelief,  // -C_a max(0, (xi - (1 - l)) / l)^e                 amount = C_a
  kRootRelief,  // -C_f max(0, (l - xi) / l)^e                       amount =
                // C_f
  kEndRelief,  // -C_e max(0, (|eta| - (1 - l)) / l)^e, both faces  amount = C_e
  kFlankTwist,  // S (xi - 1/2) eta                                  amount = S
  kDiagonalEndRelief,  // -C_1 max(0, (l_1 - w)/l_1)^e - C_2 max(0, (w - (1 -
                       // l_2))/l_2)^e
};

// "profile_crowning", "lead_crowning", ..., "diagonal_end_relief".
const char* ModificationKindName(ModificationKind kind);
// Inverse of ModificationKindName; false for an unknown name.
bool ParseModificationKind(const std::string& name, ModificationKind* kind);

// The exponent e of a relief: linear (1) or parabolic (2).
enum class ReliefShape { kLinear, kParabolic };

struct TargetModification {
  ModificationKind kind = ModificationKind::kProfileCrowning;
  // The amount [um]: C_alpha, C_beta, f_Halpha, f_Hbeta, C_a, C_f, C_e, S or,
  // for the diagonal end relief, C_1 (the relief at the low-w end of the
  // contact band). Reliefs and crownings remove material for a positive amount.
  double amount_um = 0.0;
  // Length fraction l of a relief (tip, root, end; l_1 of the diagonal relief),
  // in (0, 1].
  double length_fraction = 0.2;
  ReliefShape shape = ReliefShape::kLinear;
  // Diagonal end relief only: C_2 [um] and l_2, the relief at the high-w end of
  // the band.
  double second_amount_um = 0.0;
  double second_length_fraction = 0.2;
  // Diagonal end relief only: the amounts vary linearly along the contact line,
  // C_k + g_k eta [um] (g_1 for C_1, g_2 for C_2; 0 = constant amount). The
  // sign of the resulting amount is kept (a negative local amount adds
  // material).
  double amount_gradient_um = 0.0;
  double second_amount_gradient_um = 0.0;
};

// Checks one modification: finite amounts, fractions in (0, 1]. Fills `issue`
// (field names relative to the modification: "amount_um", "length_fraction",
// ...) and returns false.
bool ValidateTargetModification(const TargetModification& modification,
                                ValidationIssue* issue);

// The normalised grid coordinates of MODEL.md §7 for each grid point
// (row-major).
struct TargetCoordinates {
  Eigen::VectorXd xi;   // profile, 0 at the root row, 1 at the tip row
  Eigen::VectorXd eta;  // lead, -1 at column 0, +1 at the last column
  Eigen::VectorXd w;    // contact-line coordinate, 0..1 over the grid
};
TargetCoordinates ComputeTargetCoordinates(const FlankGrid& grid,
                                           const GearData& gear,
                                           Flank flank);

// The sum of `modifications` at each grid point [um], row-major. Modifications
// must be valid.
Eigen::VectorXd EvaluateTargetModifications(
    const std::vector<TargetModification>& modifications,
    const FlankGrid& grid,
    const GearData& gear,
    Flank flank);

// One modification at normalised coordinates (xi, eta, w) [um]; for tests and
// plots.
double EvaluateTargetModification(const TargetModification& modification,
                                  double xi,
                                  double eta,
                                  double w);

}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_GRINDER_TARGET_MODIFICATION_H_
