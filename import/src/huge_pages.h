// Asks the kernel to back a large, freshly allocated (still untouched) buffer with transparent
// huge pages. A 512×486×56 float volume is 13,600 small pages: faulting them in costs as much
// as resampling into them; with 2 MiB pages it is 27 faults. A hint only: no effect where THP is
// off or on other systems.
#pragma once

#include <cstddef>
#include <cstdint>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace tsf::import {

inline void advise_huge_pages(void* buffer, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  const auto begin = reinterpret_cast<std::uintptr_t>(buffer);
  const std::uintptr_t first = (begin + kHuge - 1) & ~(kHuge - 1);
  const std::uintptr_t last = (begin + bytes) & ~(kHuge - 1);
  if (last > first) madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
#else
  (void)buffer;
  (void)bytes;
#endif
}

}  // namespace tsf::import
