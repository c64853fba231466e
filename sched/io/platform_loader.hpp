// Platform (DCG) files: JSON -> DeviceGraph, strictly validated. Schema: platforms/README.md.
// Every problem is an InputError naming the file and the JSON path of the field.
#pragma once
#include <string>
#include <string_view>

#include "sched/core/device_graph.hpp"

namespace rayline {

DeviceGraph load_platform(const std::string& path);
DeviceGraph parse_platform(std::string_view json_text, const std::string& file_label);

}  // namespace rayline
