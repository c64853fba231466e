// Transparent huge pages for the large, growing memory of a simulation (activities,
// blocks, jobs, copies, ray counts): on a machine whose THP setting is "madvise" (Debian's
// default), memory is backed by 4 KiB pages unless asked for, and a run that grows to
// hundreds of MB spent a sixth of its time in page faults. Once enabled, every
// operator-new allocation of at least 4 MiB, and malloc's main heap as it grows, are
// advised MADV_HUGEPAGE (apps/huge_pages.cpp): 9 k page faults instead of 83 k at the
// museum's Budge peak. The results do not change; the wall time falls by about a quarter,
// and RSS grows by 5-10 %.
#pragma once

namespace rayline::cli {
void use_huge_pages_for_large_allocations();
}
