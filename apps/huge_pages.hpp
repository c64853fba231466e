// Transparent huge pages for the large, growing arrays of a simulation (activities, blocks,
// jobs, copies): on a machine whose THP setting is "madvise" (Debian's default), memory is
// backed by 4 KiB pages unless asked for, and a run that grows to hundreds of MB spends a
// sixth of its time in page faults. Once enabled, every operator-new allocation of at
// least 4 MiB is advised MADV_HUGEPAGE (apps/huge_pages.cpp). The simulator's results do
// not change; only its wall time and its RSS (a few per cent more) do.
#pragma once

namespace rayline::cli {
void use_huge_pages_for_large_allocations();
}
