// engine/correction/outliers.h (internal): the gross-outlier test of the
// correction (correction.h, "Outliers"): standardised residuals of the
// regularised linear fit, compared with their median and with their grid
// neighbours; the most isolated point beyond the limit is dropped and the fit
// repeated.
//
//   RemoveGrossOutliers(options, &problem, &summary);  // problem.used loses
//   the outliers
#ifndef GEARLOOP_ENGINE_CORRECTION_OUTLIERS_H_
#define GEARLOOP_ENGINE_CORRECTION_OUTLIERS_H_

#include <vector>

#include "engine/correction/correction.h"
#include "engine/correction/problem.h"
#include "engine/correction/regularisation.h"

namespace gearloop {
namespace correction_internal {

// The regularised linear fit on `used` made robust to gross outliers: Huber
// reweighting (k = 1.345, scale 1.4826 MAD of the misfits, at least the
// probe noise), a few passes, so that outliers do not bend the fit toward
// themselves and inflate the spread the test compares with. The first fit is
// a solve of its own (one Tikhonov level over the directions above
// min_flank_effect_um); the passes refit along its directions at its level
// (TikhonovFitAlong). Returns the fit at the last weights and those weights;
// the SVD of the first fit, at problem.weights, goes to `svd_at_weights` when
// asked. `problem` is reweighted in place and given back as it came (weights
// and signal_noise_um restored).
struct RobustFit {
  Eigen::VectorXd residual;  // weighted, over `used`
  Eigen::VectorXd leverage;  // the hat matrix's diagonal, over `used`
  Eigen::VectorXd weights;   // every grid point
};
RobustFit RobustLinearFit(const CorrectionOptions& options,
                          CorrectionProblem* problem,
                          const std::vector<int>& used,
                          Svd* svd_at_weights = nullptr);

// Per row of `fit` (the grid points `used`): r_i / sqrt(w_i) / sqrt(1 - h_ii),
// so that each has the spread of the probe noise [um].
std::vector<double> StandardisedResiduals(const RobustFit& fit,
                                          const std::vector<int>& used);

// The limits of the test (CorrectionOptions outlier_threshold, outlier_min_um;
// the probe noise, < 0 unknown).
struct OutlierTest {
  double threshold = 5.0;
  double min_um = 2.0;
  double probe_noise_um = -1.0;
};

// The position in `used` of the gross outlier among `standardised` (one per
// used point of a grid_rows x grid_columns row-major grid), or -1: the point
// whose smallest distance from the median and from the mean of its neighbours
// along the row, the column and both diagonals is largest, when that distance
// exceeds max(threshold max(1.4826 MAD, sigma), min_um). Where `alone` (per
// point; empty: every point) marks some of the points beyond that limit, the
// most isolated of those: RemoveGrossOutliers marks the points that also stand
// alone in the measured machine error, so that a spike's neighbour, which the
// fit's bend toward the spike may leave the larger misfit, is not taken first.
int FindGrossOutlier(const std::vector<double>& standardised,
                     const std::vector<int>& used,
                     int grid_rows,
                     int grid_columns,
                     const OutlierTest& test,
                     const std::vector<bool>& alone = {});

// Drops gross outliers from problem->used one at a time (at most
// max_outlier_fraction of them), refitting in between; reports them sorted in
// summary->outlier_indices and the points left in summary->num_points_used.
// When asked, `svd_at_used` gets the SVD of A on the points left at
// problem->weights where a fit made it (the regularised solve on them needs no
// other), else it is left with no rows.
void RemoveGrossOutliers(const CorrectionOptions& options,
                         CorrectionProblem* problem,
                         CorrectionSummary* summary,
                         Svd* svd_at_used = nullptr);

// Several measured teeth: at each grid point the values of the teeth are
// compared with their median; with 3 or more teeth a value farther than
// limit = max(threshold max(sigma^, sigma), min_um) from it is left out of the
// mean, with 2 teeth that disagree by more than 2 limit the point is left out
// (neither can be trusted). sigma^ = 1.4826 median |v - median| over all
// values (the spread between teeth); sigma the probe noise when told. Returns
// the grid points where anything was left out (ascending).
std::vector<int> DropToothOutliers(const OutlierTest& test,
                                   std::vector<Eigen::VectorXd>* teeth_um);

// Of `outliers` (the cubic answer's; the order choice keeps these out of the
// every-order solve, order_choice.cc), the points that also stand alone in the
// measured machine error m - d(commanded) (outliers.cc, Isolation): beyond
// max(outlier_threshold x 1.4826 x the median isolation of every point,
// outlier_min_um). The machine's error is smooth over the flank, a probe's
// spike is not; a target relief the cubic terms cannot make (a diagonal end
// relief's corner) leaves a point alone in the cubic answer's residual but not
// in m - d(commanded), and orders 4-6 may make it (robustness benchmark quick
// count: carrying every cubic outlier lost reach on five diagonal end reliefs,
// 0.25 -> 2.07 um final in seed 25, scenario 140). The model at the commanded
// settings comes from input.model, the correction's memo (the cubic answer
// evaluated it there).
std::vector<int> ProbeSpikes(const CorrectionOptions& options,
                             const CorrectionInput& input,
                             const std::vector<int>& outliers);

}  // namespace correction_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_OUTLIERS_H_
