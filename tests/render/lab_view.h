// Test helper for the default 500 x 500 lab view: which pixels look exactly along an edge where
// two walls of the room meet.
#pragma once

#include <cstdlib>

namespace tritrace::testing_lab {

// The ray through pixel (x, y) of the default view looks along (dx, dy, 500) = (x - 250, y - 250,
// 500) from (0, 0, -3). When |dx| == |dy| it meets a side wall (x = +-1) and the floor or ceiling
// (y = +-1) at the same t; when |dx| or |dy| is 125 it meets x = +-1 or y = +-1 at z = 1, the back
// wall. Such rays pass exactly through an edge where two walls meet: both walls are hit at the
// same t in exact arithmetic, and which one wins the tie is down to the last bit of the
// computation (the kernel, or the scene's scale and position).
inline bool on_room_corner_edge(int x, int y) {
  const int dx = std::abs(x - 250), dy = std::abs(y - 250);
  return dx == dy || dx == 125 || dy == 125;
}

}  // namespace tritrace::testing_lab
