// server/codec/zero_correction.h: why a correction came back zero, in words a
// machine operator reads, from the engine summary's own fields (issue 16: a
// job with options.default_max_order 6 came back "converged" with a zero
// correction and no word why). Pure mapping of the summary: nothing is solved
// again.
//
//   nlohmann::json explain = ZeroCorrectionExplainJson(summary);
//   if (!explain.is_null()) answer["explain"] = explain;  // {reason, message}
//
// Reasons, first that applies:
//   already_on_target       the error to correct is (numerically) zero
//   below_min_flank_effect  rank or truncation rank 0: no direction of the
//                           machine moves the flank by min_flank_effect_um
//   no_safe_improvement     the exact model found no fraction of the change
//                           that makes a better part (step_fraction 0)
//   motion_bound            the motion bound scaled the change to nothing
//   nothing_above_noise     the regularisation rule kept (almost) no
//                           effective direction: what the machine could make
//                           of the error is no larger than the noise the rule
//                           sees in it
//   negligible_change       none of these: the kept change is too small to
//                           move the flank measurably
#ifndef GEARLOOP_SERVER_CODEC_ZERO_CORRECTION_H_
#define GEARLOOP_SERVER_CODEC_ZERO_CORRECTION_H_

#include <nlohmann/json.hpp>

#include "engine/correction/correction.h"

namespace gearloop {

// A correction this small (CorrectionSummary::correction_size: axis motion in
// units of 1 um of flank, MODEL.md §6) is no correction: a thousandth of a
// micrometre is below any machine's resolution.
constexpr double kNegligibleCorrectionSize = 1e-3;

// {"reason", "message"} when `s` is a usable solve whose correction is
// negligible (correction_size <= kNegligibleCorrectionSize), else null.
nlohmann::json ZeroCorrectionExplainJson(const CorrectionSummary& s);

}  // namespace gearloop

#endif  // GEARLOOP_SERVER_CODEC_ZERO_CORRECTION_H_
