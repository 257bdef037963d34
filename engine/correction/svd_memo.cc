// The SVDs of one correction, remembered (svd_memo.h).
#include "engine/correction/svd_memo.h"

#include <cstring>

namespace gearloop {
namespace correction_internal {

SvdMemo::Entry* SvdMemo::FindEntry(const Eigen::MatrixXd& a) {
  for (Entry& entry : entries_) {
    // Bit for bit: a matrix a rounding apart (or a -0 for a 0) is another A.
    if (entry.a.rows() == a.rows() && entry.a.cols() == a.cols() &&
        std::memcmp(entry.a.data(), a.data(), sizeof(double) * a.size()) == 0)
      return &entry;
  }
  return nullptr;
}

const Svd* SvdMemo::Find(const Eigen::MatrixXd& a, Route route) {
  Entry* entry = FindEntry(a);
  if (entry == nullptr) return nullptr;
  const bool has = route == Route::kGram ? entry->has_gram : entry->has_jacobi;
  if (!has) return nullptr;
  ++answered_;
  return route == Route::kGram ? &entry->gram : &entry->jacobi;
}

void SvdMemo::Remember(const Eigen::MatrixXd& a, Route route, const Svd& svd) {
  Entry* entry = FindEntry(a);
  if (entry == nullptr) {
    if (static_cast<int>(entries_.size()) < kEntries) {
      entries_.emplace_back();
      entry = &entries_.back();
    } else {
      entry = &entries_[next_];
      next_ = (next_ + 1) % kEntries;
    }
    entry->a = a;
    entry->has_gram = false;
    entry->has_jacobi = false;
  }
  ++decompositions_;
  if (route == Route::kGram) {
    entry->gram = svd;
    entry->has_gram = true;
  } else {
    entry->jacobi = svd;
    entry->has_jacobi = true;
  }
}

}  // namespace correction_internal
}  // namespace gearloop
