// Tests of EdgeKeyMap: against std::map under random inserts, erases and lookups.
#include "stream/core/edge_key_map.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <random>

namespace gaussmesh::stream {
namespace {

std::uint64_t key(std::uint32_t u, std::uint32_t v) {
  return (std::uint64_t(std::min(u, v)) << 32) | std::max(u, v);
}

TEST(EdgeKeyMap, AgreesWithStdMapUnderInsertsAndErases) {
  const std::uint64_t seed = 3;
  std::mt19937_64 rng(seed);
  EdgeKeyMap table;
  std::map<std::uint64_t, std::uint32_t> model;
  for (int round = 0; round < 3; ++round) {
    table.reset(round * 100);
    model.clear();
    for (int op = 0; op < 20000; ++op) {
      // Few distinct keys, so inserts, erases and lookups often meet the same ones.
      const std::uint64_t k = key(std::uint32_t(rng() % 60), std::uint32_t(rng() % 60));
      switch (rng() % 3) {
        case 0: {
          bool inserted = false;
          table.emplace(k, std::uint32_t(op), &inserted) += 1;
          auto [it, is_new] = model.emplace(k, std::uint32_t(op));
          it->second += 1;
          ASSERT_EQ(inserted, is_new) << "seed " << seed << " op " << op;
          break;
        }
        case 1:
          ASSERT_EQ(table.erase(k), model.erase(k) == 1) << "seed " << seed << " op " << op;
          break;
        default: {
          const std::uint32_t* found = table.find(k);
          const auto it = model.find(k);
          ASSERT_EQ(found != nullptr, it != model.end()) << "seed " << seed << " op " << op;
          if (found) {
            ASSERT_EQ(*found, it->second);
          }
        }
      }
      ASSERT_EQ(table.size(), model.size());
    }
  }
}

}  // namespace
}  // namespace gaussmesh::stream
