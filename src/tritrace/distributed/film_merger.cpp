// FilmMerger: each tile part's layers go on a stack as a BlockCounter replays the additions of one
// render; a finished tile part's stack is the whole render's layout and is scattered into the
// merged film.
#include "tritrace/distributed/film_merger.h"

#include <utility>

#include "tritrace/distributed/merge_plan.h"
#include "tritrace/distributed/partial_film_codec.h"
#include "tritrace/error.h"

namespace tritrace {

FilmMerger::FilmMerger(const RenderIdentity& render, int tiles)
    : render_(render),
      tiles_(tiles),
      merged_(render.width, render.height, render.aovs),
      finished_(static_cast<size_t>(tiles), false) {
  BlockCounter whole;
  whole.push_blocks(0, render.spp / kSampleBlock);
  merged_.set_layout(0, render.spp,
                     std::vector<BlockNode>(whole.nodes().begin(), whole.nodes().end()));
}

void FilmMerger::add(const PartRange& range, Film packed) {
  const PackedShape shape = packed_shape(render_.width, render_.height, range.tile, range.tiles);
  if (range.tiles != tiles_ || range.tile < 0 || range.tile >= tiles_ ||
      packed.width() != shape.width || packed.height() != shape.height ||
      packed.first_sample() != range.first || packed.end_sample() != range.end ||
      range.end > render_.spp) {
    throw Error("merge", "a part of " + range.describe() + " that does not fit the render (" +
                             std::to_string(packed.width()) + " x " +
                             std::to_string(packed.height()) + " sums of samples [" +
                             std::to_string(packed.first_sample()) + ", " +
                             std::to_string(packed.end_sample()) + "))");
  }
  if (finished_[static_cast<size_t>(range.tile)]) {
    throw Error("merge", range.describe() + " overlaps the tile part's finished samples");
  }
  if (packed.has_splats()) {
    // The light image: integer sums, so the parts add up to the one render's bits in any order.
    if (tiles_ != 1) throw Error("merge", "a tile part with a light image (bdpt's light tracing)");
    merged_.enable_splats();
    merged_.splats().add(packed.splats());
    ++splat_parts_;
  }
  ++parts_;
  Group& g = groups_[range.tile];
  if (g.pixels.empty()) {
    g.pixels = tile_group_pixels(render_.width, render_.height, range.tile, range.tiles);
  }
  if (range.first < g.next || g.held.contains(range.first)) {
    throw Error("merge", range.describe() + " overlaps samples already received");
  }
  if (range.first > g.next) {
    g.held.emplace(range.first, std::move(packed));
    most_held_ = std::max(most_held_, ++held_);
    return;
  }
  combine(g, packed);
  for (auto it = g.held.find(g.next); it != g.held.end(); it = g.held.find(g.next)) {
    const Film next = std::move(it->second);
    g.held.erase(it);
    --held_;
    combine(g, next);
  }
  if (g.next == render_.spp) {
    finish_group(range.tile, g);
    groups_.erase(range.tile);
  }
}

void FilmMerger::push_layer(Group& g, const Film& packed, size_t layer) {
  const size_t n = g.pixels.size();
  if (g.stack.size() <= g.depth) {
    g.stack.emplace_back(n);
    if (render_.aovs.any()) g.aov_stack.emplace_back(n);
  }
  std::copy_n(packed.sums(layer), n, g.stack[g.depth].data());
  if (render_.aovs.any()) std::copy_n(packed.aov_sums(layer), n, g.aov_stack[g.depth].data());
  ++g.depth;
}

void FilmMerger::combine(Group& g, const Film& packed) {
  const size_t n = g.pixels.size();
  for (size_t j = 0; j < packed.nodes().size(); ++j) {
    push_layer(g, packed, j);
    const int merges = g.counter.push(packed.nodes()[j]);
    for (int m = 0; m < merges; ++m, --g.depth) {
      glm::vec4* left = g.stack[g.depth - 2].data();
      const glm::vec4* right = g.stack[g.depth - 1].data();
      for (size_t p = 0; p < n; ++p) left[p] = left[p] + right[p];
      if (render_.aovs.any()) {
        AovSums* aleft = g.aov_stack[g.depth - 2].data();
        const AovSums* aright = g.aov_stack[g.depth - 1].data();
        for (size_t p = 0; p < n; ++p) aleft[p] = aleft[p] + aright[p];
      }
    }
  }
  if (packed.has_partial_block()) push_layer(g, packed, packed.layer_count() - 1);
  g.next = packed.end_sample();
}

void FilmMerger::finish_group(int tile, Group& g) {
  // A covered tile part's stack is the whole render's layout, layer for layer.
  if (g.depth != merged_.layer_count()) {
    throw Error("merge", "internal error: the merged layers do not match the whole render's");
  }
  for (size_t layer = 0; layer < g.depth; ++layer) {
    glm::vec4* dst = merged_.sums(layer);
    const glm::vec4* src = g.stack[layer].data();
    for (size_t j = 0; j < g.pixels.size(); ++j) dst[g.pixels[j]] = src[j];
    if (render_.aovs.any()) {
      AovSums* adst = merged_.aov_sums(layer);
      const AovSums* asrc = g.aov_stack[layer].data();
      for (size_t j = 0; j < g.pixels.size(); ++j) adst[g.pixels[j]] = asrc[j];
    }
  }
  finished_[static_cast<size_t>(tile)] = true;
  ++done_;
}

Film FilmMerger::finish() && {
  if (!complete()) {
    std::string list;
    for (int tile = 0; tile < tiles_; ++tile) {
      if (finished_[static_cast<size_t>(tile)]) continue;
      const auto it = groups_.find(tile);
      const uint32_t from = it == groups_.end() ? 0 : it->second.next;
      if (!list.empty()) list += "; ";
      list += PartRange{from, render_.spp, tile, tiles_}.describe();
    }
    throw Error("merge", "parts missing: " + list);
  }
  if (splat_parts_ != 0 && splat_parts_ != parts_) {
    throw Error("merge", "some parts have a light image (bdpt's light tracing) and some do not");
  }
  return std::move(merged_);
}

Film merge_parts(const std::vector<std::string>& paths) {
  std::vector<PartInfo> infos;
  infos.reserve(paths.size());
  for (const std::string& p : paths) infos.push_back(read_part_info(p));
  const std::vector<size_t> order = plan_merge(paths, infos);
  FilmMerger merger(infos[0].render, infos[0].range.tiles);
  for (size_t i : order) {
    PartialFilm part = read_partial_film(paths[i]);
    if (!(part.info.render == infos[i].render)) {
      throw Error(paths[i], "changed while merging (its render differs now)");
    }
    merger.add(part.info.range, std::move(part.film));
  }
  return std::move(merger).finish();
}

}  // namespace tritrace
