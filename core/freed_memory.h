// Handing freed heap memory back to the system between stages.
#pragma once

#include <cstdlib>  // defines __GLIBC__ with glibc

#ifdef __GLIBC__
#include <malloc.h>
#endif

namespace ieslam {

// Returns the allocator's free pages, in every thread's arena, to the system. The ieslam
// binary has the allocator keep what is freed (apps/main.cc raises glibc's trim threshold, so
// that per-frame buffers are not faulted in anew each frame); a stage that has freed much
// calls this before the next allocates its own, so that peak memory is the larger stage's,
// not their sum. Does nothing with other C libraries.
inline void ReturnFreedMemory() {
#ifdef __GLIBC__
  malloc_trim(0);
#endif
}

}  // namespace ieslam
