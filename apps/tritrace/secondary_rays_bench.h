// `tritrace bench --integrator path --secondary-rays`: the path tracer's bounce and shadow rays on
// their own. One frame is rendered through a RecordingAccel over the first accel asked for, which
// keeps the rays of every incoherent query; those rays are then traced again, in the batches the
// path tracer made and on the same threads, through each accel's intersect_incoherent (closest
// hit) and occluded_incoherent (any hit), accels alternated round by round; the answers are
// checked against the recorded ones.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "tritrace/accel/make_accel.h"
#include "tritrace/job/job_settings.h"

namespace tritrace::cli {

struct SecondaryRaysOptions {
  std::vector<std::pair<std::string, std::string>> sources;  // (row name, file or "")
  std::vector<AccelKind> accels;  // the first records the frame; ratios to embree-single
  JobSettings settings;           // integrator, spp, size and threads of the frame
  int threads = 1;
  int reps = 5;
  std::string json;  // empty: no JSON file
  bool quiet = false;
};

int run_secondary_rays(const SecondaryRaysOptions& options);

}  // namespace tritrace::cli
