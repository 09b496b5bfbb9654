// plan_merge: one render, one tile split, and per tile part the sample ranges in order with no
// overlap and no gap.
#include "tritrace/distributed/merge_plan.h"

#include <algorithm>
#include <numeric>

#include "tritrace/error.h"

namespace tritrace {

std::vector<size_t> plan_merge(const std::vector<std::string>& names,
                               const std::vector<PartInfo>& parts) {
  if (parts.empty()) throw Error("merge", "no parts given", ExitCode::kUsage);
  const RenderIdentity& ref = parts[0].render;
  const int tiles = parts[0].range.tiles;
  for (size_t i = 1; i < parts.size(); ++i) {
    const RenderIdentity& r = parts[i].render;
    if (!(r == ref)) {
      std::string what;
      if (r.build != ref.build) {
        what = "built by another tritrace: " + r.build + ", not " + ref.build + " of " + names[0];
      } else if (r.hash == ref.hash && r.settings == ref.settings) {
        what = "its AOVs (" + aov_list(r.aovs) + ") differ from " + names[0] + "'s (" +
               aov_list(ref.aovs) + ")";
      } else {
        what = "render " + r.hash + " (" + r.settings + "), not render " + ref.hash + " (" +
               ref.settings + ") of " + names[0];
      }
      throw Error(names[i], "foreign part: " + what);
    }
    if (parts[i].range.tiles != tiles) {
      throw Error(names[i], "split into " + std::to_string(parts[i].range.tiles) +
                                " tile parts, but " + names[0] + " into " + std::to_string(tiles) +
                                " (all parts must use one --tile N)");
    }
  }
  std::vector<size_t> order(parts.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    const PartRange &ra = parts[a].range, &rb = parts[b].range;
    return ra.tile != rb.tile ? ra.tile < rb.tile : ra.first < rb.first;
  });
  std::vector<std::string> missing;
  auto gap = [&](int tile, uint32_t a, uint32_t b) {
    missing.push_back(PartRange{a, b, tile, tiles}.describe());
  };
  size_t k = 0;
  for (int tile = 0; tile < tiles; ++tile) {
    uint32_t covered = 0;
    size_t previous = order.size();
    for (; k < order.size() && parts[order[k]].range.tile == tile; ++k) {
      const PartRange& r = parts[order[k]].range;
      if (r.first < covered) {
        const PartRange& p = parts[order[previous]].range;
        throw Error(names[order[k]],
                    "overlaps " + names[order[previous]] + ": both hold " +
                        PartRange{r.first, std::min(r.end, p.end), tile, tiles}.describe());
      }
      if (r.first > covered) gap(tile, covered, r.first);
      covered = r.end;
      previous = k;
    }
    if (covered < ref.spp) gap(tile, covered, ref.spp);
  }
  if (!missing.empty()) {
    std::string list;
    for (size_t i = 0; i < missing.size() && i < 8; ++i) list += (i ? "; " : "") + missing[i];
    if (missing.size() > 8) list += "; and " + std::to_string(missing.size() - 8) + " more";
    throw Error("merge", "parts missing: " + list + " (render " + ref.hash + ")");
  }
  return order;
}

}  // namespace tritrace
