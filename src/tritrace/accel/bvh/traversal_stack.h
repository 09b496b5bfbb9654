// The traversal stack of the nearest-first searches over the wide BVH: the closest-hit ray
// traversals (bvh_accel.cpp) and the closest-point query (closest_point.cpp).
#pragma once

#include <bit>
#include <cstdint>

#include "tritrace/accel/bvh/wide_bvh.h"

namespace tritrace::bvh {

// A subtree still to visit and how far it starts: the ray's entry t into its box, or the query
// point's squared distance to it. A pop skips the entry when key exceeds the best found so far.
struct StackEntry {
  uint32_t ref;
  float key;
};

// Pushes the children of node named by mask onto the stack whose top is top, with key[i] for
// child slot i: sorted by insertion straight into place, so nothing is copied, with the farthest
// deepest and the nearest last (top[n - 1]). Returns n, how many were pushed; the caller checks
// that they fit.
[[gnu::always_inline]] inline int push_nearest_last(const WideNode& node, uint32_t mask,
                                                    const float* key, StackEntry* top) {
  int n = 0;
  while (mask) {
    const int i = std::countr_zero(mask);
    mask &= mask - 1;
    const StackEntry e{node.child[i], key[i]};
    int j = n++;
    for (; j > 0 && top[j - 1].key < e.key; --j) top[j] = top[j - 1];
    top[j] = e;
  }
  return n;
}

}  // namespace tritrace::bvh
