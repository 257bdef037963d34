// engine/correction/evaluation_memo.h (internal): the exact model's
// evaluations of one correction, remembered. The stages of a correction (the
// outlier test, the state fit, the refinement, the search, the safe step, the
// order choice) evaluate the model at some parameter vectors more than once,
// and often ask for the Jacobian where they have just evaluated without it
// (the refinement's accepted trial point becomes the next pass's start). The
// memo answers a repeat from its copy, and a Jacobian asked after a plain
// evaluation through MachineModel::AddJacobian, so the model does not solve
// for its contacts again. The numbers are the ones the model would give:
// Evaluate is deterministic, and AddJacobian gives what Evaluate with the
// Jacobian gives.
//
//   EvaluationMemo memo(input.model);   // lives for one correction
//   CorrectionInput memoised = input;
//   memoised.model = &memo;
//
// One memo per correction and per thread: it is not safe to share.
#ifndef GEARLOOP_ENGINE_CORRECTION_EVALUATION_MEMO_H_
#define GEARLOOP_ENGINE_CORRECTION_EVALUATION_MEMO_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "engine/core/machine_model.h"

namespace gearloop {
namespace correction_internal {

class EvaluationMemo : public MachineModel {
 public:
  explicit EvaluationMemo(const MachineModel* model) : model_(model) {}

  int NumParameters() const override { return model_->NumParameters(); }
  int GridRows() const override { return model_->GridRows(); }
  int GridColumns() const override { return model_->GridColumns(); }
  std::string ParameterName(int j) const override {
    return model_->ParameterName(j);
  }
  std::vector<ParameterBlock> ParameterBlocks() const override {
    return model_->ParameterBlocks();
  }
  bool NominalRollRange(double* roll_min_rad,
                        double* roll_max_rad) const override {
    return model_->NominalRollRange(roll_min_rad, roll_max_rad);
  }
  void Evaluate(const Eigen::VectorXd& parameters,
                bool with_jacobian,
                ModelEvaluation* evaluation) const override;
  void AddJacobian(const Eigen::VectorXd& parameters,
                   ModelEvaluation* evaluation) const override;

  // Evaluations the model made, and those answered from the memo (a
  // Jacobian added to a remembered evaluation counts as answered).
  int model_evaluations() const { return model_evaluations_; }
  int answered() const { return answered_; }

 private:
  struct Entry {
    Eigen::VectorXd parameters;
    ModelEvaluation evaluation;
    bool has_jacobian = false;
  };
  // The last kEntries evaluations, oldest overwritten first: the repeats
  // come within a few evaluations of each other (robustness benchmark, seed
  // 2026: 36 evaluations a correction, 12.5 of them repeats).
  static constexpr int kEntries = 16;

  Entry* Find(const Eigen::VectorXd& parameters) const;
  Entry* Remember(const Eigen::VectorXd& parameters) const;

  const MachineModel* model_;
  mutable std::vector<Entry> entries_;
  mutable int next_ = 0;
  mutable int model_evaluations_ = 0;
  mutable int answered_ = 0;
};

}  // namespace correction_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_EVALUATION_MEMO_H_
