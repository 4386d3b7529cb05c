#include "sph/core/cancellation.hpp"

namespace sph {
namespace {
thread_local const Cancellation* t_current = nullptr;
}  // namespace

CancellationScope::CancellationScope(const Cancellation* cancellation) noexcept : previous_(t_current) {
  t_current = cancellation;
}

CancellationScope::~CancellationScope() { t_current = previous_; }

const Cancellation* CurrentCancellation() noexcept { return t_current; }

void ThrowIfCancelled() {
  if (t_current != nullptr && t_current->Requested()) throw Cancelled();
}

}  // namespace sph
