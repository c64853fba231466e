// Basic identifiers shared by every layer. Times are seconds (double), sizes bytes.
#pragma once
#include <cstdint>
#include <limits>

namespace rayline {

using Time = double;   // seconds since the start of a run
using Bytes = std::uint64_t;

using NodeId = std::int32_t;
using MemId = std::int32_t;       // MemoryDevice index (vertex of the DCG, Sec. 3.2)
using DeviceId = std::int32_t;    // ComputeDevice index
using ChannelId = std::int32_t;   // directed DCG edge
using ResourceId = std::int32_t;  // a contended medium behind one or more channels
using JobTypeId = std::int32_t;
using BlockId = std::int32_t;     // DataBlock index
using JobId = std::int32_t;       // E-job index in a JobPool
using ActivityId = std::int64_t;  // a committed E-job or T-job in a Schedule

inline constexpr Time kNever = std::numeric_limits<Time>::infinity();
inline constexpr std::int32_t kNone = -1;

}  // namespace rayline
