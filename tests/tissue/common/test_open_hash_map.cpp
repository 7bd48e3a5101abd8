// The edit path's hash map: keys that collide in their low bits, growth, erase with tombstones
// and the reuse of their slots, against std::unordered_map as the reference through a random mix
// of the operations a cut performs (add, look up, retire).
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <unordered_map>

#include "tsf/common/open_hash_map.h"

namespace tsf {
namespace {

TEST(OpenHashMap, AgreesWithUnorderedMapThroughInsertsErasesAndClears) {
  OpenHashMap<std::uint32_t> map;
  std::unordered_map<std::uint64_t, std::uint32_t> reference;
  std::mt19937_64 rng(7);
  // Few distinct keys (4 k) whose low 32 bits repeat, so erases and re-inserts hit the same
  // probe paths over and over and tombstones pile up between rebuilds.
  auto key = [&] { return (rng() % 4096) << 32 | (rng() % 3); };
  std::size_t mismatches = 0;
  for (int round = 0; round < 3; ++round) {
    for (int op = 0; op < 200000; ++op) {
      const std::uint64_t k = key();
      switch (rng() % 3) {
        case 0: {
          const auto v = static_cast<std::uint32_t>(rng());
          map[k] = v;
          reference[k] = v;
          break;
        }
        case 1:
          map.erase(k);
          reference.erase(k);
          break;
        default: {
          const std::uint32_t* found = map.find(k);
          const auto it = reference.find(k);
          mismatches += (found == nullptr) != (it == reference.end());
          if (found && it != reference.end()) mismatches += *found != it->second;
        }
      }
    }
    EXPECT_EQ(map.size(), reference.size());
    for (const auto& [k, v] : reference) {
      const std::uint32_t* found = map.find(k);
      mismatches += found == nullptr || *found != v;
    }
    map.clear();
    reference.clear();
    EXPECT_EQ(map.size(), 0u);
    EXPECT_EQ(map.find(0), nullptr);
  }
  EXPECT_EQ(mismatches, 0u);
}

TEST(OpenHashMap, AMissingKeyReadsAsAFreshValueAndIsThenPresent) {
  OpenHashMap<float> weights;
  EXPECT_EQ(weights.find(42), nullptr);
  EXPECT_EQ(weights[42], 0.0f);
  EXPECT_EQ(weights.size(), 1u);
  weights[42] = 0.5f;
  ASSERT_NE(weights.find(42), nullptr);
  EXPECT_EQ(*weights.find(42), 0.5f);
  weights.erase(42);
  EXPECT_EQ(weights.find(42), nullptr);
  EXPECT_EQ(weights[42], 0.0f) << "a key erased and read again starts from Value{}";
}

}  // namespace
}  // namespace tsf
