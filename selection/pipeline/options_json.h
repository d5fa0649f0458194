// The options of each stage as reports record them under "options".
#pragma once

#include "backend/bundle_adjustment.h"
#include "backend/depth_alignment.h"
#include "backend/information_filter.h"
#include "core/dataset.h"
#include "core/json.h"
#include "core/range_cloud.h"
#include "selection/keyframe_selector.h"

namespace ieslam {

struct RunOptions;

Json SelectorOptionsToJson(const SelectorOptions& selector);
Json FilterOptionsToJson(const InformationFilterOptions& filter);
Json BaOptionsToJson(const BundleAdjustmentOptions& options);
Json DepthAlignmentOptionsToJson(const DepthAlignmentOptions& options,
                                 const RangeCloudOptions& cloud);
Json DatasetOptionsToJson(const DatasetOptions& options);
// Every section of a run's options, as given (RunOptions::ToJson passes them resolved).
Json RunOptionsToJson(const RunOptions& options);

}  // namespace ieslam
