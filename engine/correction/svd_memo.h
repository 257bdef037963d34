// engine/correction/svd_memo.h (internal): the thin SVD of the correction's
// linear systems, and the SVDs of one correction remembered. The stages of a
// correction decompose the same A more than once: the outlier test's first
// fit, the state fit's misfit and the solve read the one system at the same
// weights, and the order choice's reachable signal the system the solve has
// just decomposed (robustness benchmark, seed 2026, 30 scenarios: 186 of 470
// decompositions repeated one already made, 155 of them the one just before).
// The memo answers a repeat from its copy. The numbers are the ones the
// decomposition would give: it is deterministic, and a repeat is the same A
// bit for bit, decomposed the same way.
//
//   problem.svd_memo = std::make_shared<SvdMemo>();  // one correction
//   ComputeSvd(a, threshold, problem.svd_memo.get());  // regularisation.h
//
// One memo per correction and per thread: it is not safe to share.
#ifndef GEARLOOP_ENGINE_CORRECTION_SVD_MEMO_H_
#define GEARLOOP_ENGINE_CORRECTION_SVD_MEMO_H_

#include <Eigen/Core>
#include <vector>

namespace gearloop {
namespace correction_internal {

struct Svd {
  Eigen::MatrixXd u;      // n x p
  Eigen::VectorXd sigma;  // p, descending
  Eigen::MatrixXd v;      // q x p
  int rank = 0;
  // The singular values (and their vectors) below this are not resolved: the
  // eigen-decomposition of A'A gives them to about sqrt(p eps) sigma_1 only.
  // 0: every one resolved (the Jacobi SVD).
  double resolved_down_to = 0.0;
};

class SvdMemo {
 public:
  // The two ways ComputeSvd decomposes A (regularisation.h): the eigen-
  // decomposition of A'A, and the Jacobi SVD.
  enum class Route { kGram, kJacobi };

  // The decomposition of exactly this A by `route` made before (its rank as
  // it was counted then), or nullptr. A gram route that failed is remembered
  // with an empty sigma.
  const Svd* Find(const Eigen::MatrixXd& a, Route route);
  // Remembers `svd` as A's decomposition by `route`.
  void Remember(const Eigen::MatrixXd& a, Route route, const Svd& svd);

  // Decompositions remembered, and those answered from the memo.
  int decompositions() const { return decompositions_; }
  int answered() const { return answered_; }

 private:
  struct Entry {
    Eigen::MatrixXd a;
    bool has_gram = false;
    bool has_jacobi = false;
    Svd gram;
    Svd jacobi;
  };
  // The last kEntries matrices, oldest overwritten first: the repeats come
  // within a few decompositions of each other (the counts above: all but one
  // within 8).
  static constexpr int kEntries = 8;

  Entry* FindEntry(const Eigen::MatrixXd& a);

  std::vector<Entry> entries_;
  int next_ = 0;
  int decompositions_ = 0;
  int answered_ = 0;
};

}  // namespace correction_internal
}  // namespace gearloop

#endif  // GEARLOOP_ENGINE_CORRECTION_SVD_MEMO_H_
