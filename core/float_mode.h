// Subnormal floating point flushed to zero for the span of a scope (x86 SSE: the
// FTZ and DAZ bits of MXCSR; elsewhere nothing). A body coming to rest under
// damping decays its displacements and velocities geometrically through the
// subnormal range, where each arithmetic operation costs some hundred cycles:
// in the paper's grasp, the box resting on the table made the contact space 15x
// slower for ~100 steps of every cycle (0.03 -> 0.5 ms) and the steps miss their
// 1 kHz deadlines. Values below 2.2e-308 carry no physics (a displacement of
// 1e-308 m), so the step flushes them, as real-time physics engines commonly do.
#pragma once

#if defined(__SSE2__) || defined(_M_X64)
#include <xmmintrin.h>
#define GRASPSIM_HAS_MXCSR 1
#else
#define GRASPSIM_HAS_MXCSR 0
#endif

namespace gs {

/// Sets flush-to-zero and denormals-are-zero on construction, restores the
/// caller's mode on destruction (the mode is per thread).
class FlushSubnormals {
 public:
  FlushSubnormals() {
#if GRASPSIM_HAS_MXCSR
    saved_ = _mm_getcsr();
    _mm_setcsr(saved_ | kFtz | kDaz);
#endif
  }
  ~FlushSubnormals() {
#if GRASPSIM_HAS_MXCSR
    _mm_setcsr(saved_);
#endif
  }
  FlushSubnormals(const FlushSubnormals&) = delete;
  FlushSubnormals& operator=(const FlushSubnormals&) = delete;

  /// Whether this platform flushes (false: the guard does nothing).
  static constexpr bool kSupported = GRASPSIM_HAS_MXCSR != 0;

 private:
#if GRASPSIM_HAS_MXCSR
  static constexpr unsigned kFtz = 0x8000;  // results that would be subnormal are zero
  static constexpr unsigned kDaz = 0x0040;  // subnormal operands read as zero
  unsigned saved_ = 0;
#endif
};

}  // namespace gs
