// The engine's host headers (and the C API) see the shared GPU structs but none of the device
// dialect's expression macros: those stay inside device code (common/gpu/lang.h).
#include <gtest/gtest.h>

#include "common/accel/cpu_trace.h"
#include "common/accel/kdtree.h"
#include "common/render/prepare.h"
#include "common/render/session.h"
#include "mcpt/mcpt.h"

#if defined(V3) || defined(V3S) || defined(F32) || defined(U32) || defined(I32) || \
    defined(ABSF) || defined(MINF) || defined(PARAM) || defined(SCENE_ARGS_) ||    \
    defined(HAS_FEATURE) || defined(SELECT3)
#error "a device dialect macro leaks into host code"
#endif

TEST(HostHeaders, SeeSharedStructsWithoutDialectMacros) {
    EXPECT_EQ(sizeof(mcpt::gpu::KdNode), 8u);
    EXPECT_EQ(sizeof(mcpt::gpu::Hit), 28u);
}
