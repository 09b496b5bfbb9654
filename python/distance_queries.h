// QueryScene's queries on points (closest points, distances, signed distances, occupancy), added
// to the class that register_query_scene made.
#pragma once

#include "query_scene.h"

namespace tritrace::python {

void register_distance_queries(QuerySceneClass& cls);

}  // namespace tritrace::python
