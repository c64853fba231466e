// Strict parsing of quantities written as strings in platform and job files:
//   sizes      "8GiB", "210MB", "512KiB", "64B"            -> bytes
//   bandwidth  "150MB/s", "1Gb/s", "12.5MB/s", "100Mb/s"   -> bytes per second
//   durations  "8ms", "100us", "2s", "50ns"               -> seconds
// Decimal prefixes k,M,G,T = 10^3..10^12; binary Ki,Mi,Gi,Ti = 2^10..2^40; "b" = bit,
// "B" = byte. Anything else (missing unit, trailing text, negative, NaN) throws
// std::invalid_argument with a message that says what was expected, and so do values no
// device has, whose derived times would overflow: sizes over 1 EiB, bandwidths under
// 1 B/s, durations over 1e9 s.
#pragma once
#include <string_view>

namespace rayline::units {

double parse_bytes(std::string_view text);      // returns bytes (>= 0)
double parse_bandwidth(std::string_view text);  // returns bytes/s (> 0)
double parse_duration(std::string_view text);   // returns seconds (>= 0)
double parse_rate(std::string_view text);       // "10M/s", "500k/s": items per second (> 0)

}  // namespace rayline::units
