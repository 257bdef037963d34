#include "engine/core/machine_model.h"

#include <algorithm>

namespace gearloop {

int ModelEvaluation::NumReached() const {
  return static_cast<int>(
      std::count(status.begin(), status.end(), PointStatus::kOk));
}

bool ModelEvaluation::AllReached() const {
  return NumReached() == static_cast<int>(status.size());
}

}  // namespace gearloop
