// std::sort on every OpenMP thread for large arrays (GCC's parallel mode), std::sort otherwise.
#pragma once

#include <algorithm>
#include <iterator>

#if defined(_OPENMP) && defined(__GLIBCXX__)
#include <parallel/algorithm>
#endif

namespace tsf::exporter {

template <typename It, typename Less>
void parallel_sort(It begin, It end, Less less) {
#if defined(_OPENMP) && defined(__GLIBCXX__)
  if (std::distance(begin, end) > 200'000) {
    __gnu_parallel::sort(begin, end, less);
    return;
  }
#endif
  std::sort(begin, end, less);
}

template <typename It>
void parallel_sort(It begin, It end) {
  parallel_sort(begin, end, std::less<>());
}

}  // namespace tsf::exporter
