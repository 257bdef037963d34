// engine/correction/order_choice.h (internal): which orders answer
// (correction.h, default_max_order). Where the options open an order above 3,
// the correction is computed held to the cubic terms and, where every open
// order reaches enough above the noise from that answer, with every order
// asked; orders 4-6 answer only where their exact prediction beats the cubic
// one by the margin (docs/correction-safety.md, "Orders 4-6 where they earn
// their place").
//
//   const CorrectionResult result =
//       CorrectWithOrderChoice(options, input, &CorrectAtTheseOrders);
#ifndef GEARLOOP_ENGINE_CORRECTION_ORDER_CHOICE_H_
#define GEARLOOP_ENGINE_CORRECTION_ORDER_CHOICE_H_

#include <vector>

#include "engine/correction/correction.h"

namespace gearloop {
namespace correction_internal {

// One correction at the freedom `options` gives (correction.cc: validate,
// prepare, the machine-state test, solve), the grid points `left_out` set
// aside as gross outliers before any fit (reported with the outlier test's
// own).
using CorrectionAtFreedom =
    CorrectionResult (*)(const CorrectionOptions&,
                         const CorrectionInput&,
                         const std::vector<int>& left_out);

// The correction with the order choice, each candidate computed by `correct`;
// the summary's order_choice says which orders answered and why.
CorrectionResult CorrectWithOrderChoice(const CorrectionOptions& options,
                                        const CorrectionInput& input,
                                        CorrectionAtFreedom correct);

}  // namespace correction_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_ORDER_CHOICE_H_
