// The exact model's evaluations of one correction, remembered
// (evaluation_memo.h).
#include "engine/correction/evaluation_memo.h"

namespace gearloop {
namespace correction_internal {

namespace {

// Everything but the Jacobian (which a plain evaluation leaves empty).
void CopyWithoutJacobian(const ModelEvaluation& from, ModelEvaluation* to) {
  to->deviations_um = from.deviations_um;
  to->status = from.status;
  to->jacobian_um.resize(0, 0);
  to->contact_roll_rad = from.contact_roll_rad;
  to->contact_margin_mm = from.contact_margin_mm;
  to->contact_unknowns = from.contact_unknowns;
}

}  // namespace

EvaluationMemo::Entry* EvaluationMemo::Find(
    const Eigen::VectorXd& parameters) const {
  for (Entry& entry : entries_) {
    // Exactly the same numbers: a vector a rounding apart is another point.
    if (entry.parameters.size() == parameters.size() &&
        entry.parameters == parameters)
      return &entry;
  }
  return nullptr;
}

EvaluationMemo::Entry* EvaluationMemo::Remember(
    const Eigen::VectorXd& parameters) const {
  if (static_cast<int>(entries_.size()) < kEntries) {
    entries_.emplace_back();
    entries_.back().parameters = parameters;
    return &entries_.back();
  }
  Entry* entry = &entries_[next_];
  next_ = (next_ + 1) % kEntries;
  entry->parameters = parameters;
  return entry;
}

void EvaluationMemo::Evaluate(const Eigen::VectorXd& parameters,
                              bool with_jacobian,
                              ModelEvaluation* evaluation) const {
  if (Entry* found = Find(parameters)) {
    ++answered_;
    if (!with_jacobian) {
      CopyWithoutJacobian(found->evaluation, evaluation);
      return;
    }
    if (!found->has_jacobian) {
      // Remembered without its Jacobian: add it at the remembered contacts.
      model_->AddJacobian(parameters, &found->evaluation);
      found->has_jacobian = true;
    }
    *evaluation = found->evaluation;
    return;
  }
  model_->Evaluate(parameters, with_jacobian, evaluation);
  ++model_evaluations_;
  Entry* entry = Remember(parameters);
  entry->evaluation = *evaluation;
  entry->has_jacobian = with_jacobian;
}

void EvaluationMemo::AddJacobian(const Eigen::VectorXd& parameters,
                                 ModelEvaluation* evaluation) const {
  Evaluate(parameters, true, evaluation);
}

}  // namespace correction_internal
}  // namespace gearloop
