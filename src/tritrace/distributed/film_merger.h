// The merge: parts' packed films combined, per tile part in sample order, through the block
// counter a single render uses, into bit for bit the film of the whole render. Memory is the
// whole render's film plus one tile part's stack of layers plus the parts held back.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "tritrace/distributed/part.h"
#include "tritrace/render/film.h"

namespace tritrace {

class FilmMerger {
 public:
  // For the render `render` split into `tiles` tile parts.
  FilmMerger(const RenderIdentity& render, int tiles);

  // Adds a part's packed film (pack_part). A tile part's sample ranges are combined in sample
  // order, because float addition is not associative: a range that comes before the range
  // ending where it starts is held until that one has been added. Throws Error("merge", ...) for
  // a film that does not fit its range or a range that overlaps one already added.
  void add(const PartRange& range, Film packed);

  size_t held() const { return held_; }            // parts received, not yet combined
  size_t most_held() const { return most_held_; }  // the most held at any one time
  bool complete() const { return done_ == static_cast<size_t>(tiles_); }

  // The merged film; Error("merge", ...) naming what is missing when not complete.
  Film finish() &&;

 private:
  struct Group {
    std::vector<size_t> pixels;  // tile_group_pixels
    BlockCounter counter;
    uint32_t next = 0;  // the first sample not yet combined
    size_t depth = 0;
    std::vector<std::vector<glm::vec4>> stack;  // per counter node, the group's pixels
    std::vector<std::vector<AovSums>> aov_stack;
    std::map<uint32_t, Film> held;  // ranges waiting for `next` to reach their first sample
  };
  void combine(Group& group, const Film& packed);
  void push_layer(Group& group, const Film& packed, size_t layer);
  void finish_group(int tile, Group& group);

  RenderIdentity render_;
  int tiles_;
  Film merged_;
  std::map<int, Group> groups_;  // the tile parts begun and not finished
  std::vector<bool> finished_;
  size_t done_ = 0;
  size_t held_ = 0;
  size_t most_held_ = 0;
  size_t parts_ = 0;        // parts added
  size_t splat_parts_ = 0;  // of them, parts with a light image
};

// Reads the parts' headers, plans the merge (merge_plan.h), then reads and adds one part at a
// time in plan order: the film of the whole render.
Film merge_parts(const std::vector<std::string>& paths);

}  // namespace tritrace
