// Tests for the orders that depend on the geometry alone (stream/core/canonical_order.h).
#include "stream/core/canonical_order.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace gaussmesh::stream {
namespace {

TEST(CanonicalOrder, OrderedBitsFollowTheFloatsAndTakeMinusZeroAsZero) {
  const std::vector<float> ascending = {-std::numeric_limits<float>::infinity(), -1e30f, -1.0f, -1e-30f, 0.0f,
                                        1e-30f, 1.0f, 1e30f, std::numeric_limits<float>::infinity()};
  for (std::size_t i = 1; i < ascending.size(); ++i)
    EXPECT_LT(ordered_bits(ascending[i - 1]), ordered_bits(ascending[i])) << ascending[i - 1] << " " << ascending[i];
  EXPECT_EQ(ordered_bits(-0.0f), ordered_bits(0.0f));
  // A NaN gets a key of its own outside the finite range, so keys still order strictly.
  const std::uint32_t nan = ordered_bits(std::numeric_limits<float>::quiet_NaN());
  EXPECT_TRUE(nan > ordered_bits(std::numeric_limits<float>::infinity()) ||
              nan < ordered_bits(-std::numeric_limits<float>::infinity()));
}

TEST(CanonicalOrder, AFacesKeyIsTheSameFromEveryCornerButNotReversed) {
  const format::Vec3f a{0.5f, 1, 2}, b{-3, 0.25f, 1}, c{0.5f, 1, -2};
  const std::uint64_t key = face_order_key(a, b, c);
  EXPECT_EQ(face_order_key(b, c, a), key);
  EXPECT_EQ(face_order_key(c, a, b), key);
  EXPECT_NE(face_order_key(a, c, b), key) << "the other orientation is another face";
  EXPECT_NE(face_order_key(a, b, {0.5f, 1, -2.0000002f}), key) << "one bit of one coordinate";
  EXPECT_EQ(face_order_key({-0.0f, 1, 2}, b, c), face_order_key({0.0f, 1, 2}, b, c));
}

}  // namespace
}  // namespace gaussmesh::stream
