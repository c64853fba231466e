#include "sched/core/data_block.hpp"

namespace rayline {

bool parse_data_kind(std::string_view name, DataKind& out) {
  for (int i = 0; i < kDataKindCount; ++i)
    if (kDataKindNames[static_cast<std::size_t>(i)] == name) {
      out = static_cast<DataKind>(i);
      return true;
    }
  return false;
}

}  // namespace rayline
