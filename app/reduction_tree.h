// The binomial tree over MPI ranks 0..size-1 that a round's sums are added over (mpi_job.cpp),
// rooted at 0: a rank above 0 receives from rank + 1, rank + 2, rank + 4, ... (the powers of
// two below its lowest set bit) and then sends to rank - its lowest set bit; rank 0 receives
// from 1, 2, 4, ... `flat` (render --reduction flat, to measure against): every rank sends
// to rank 0, which adds them in turn. No MPI here: the partition is unit-tested.
#pragma once
#include <algorithm>
#include <vector>

namespace mcpt::wire {

inline int tree_parent(int rank, bool flat) {
    return flat ? 0 : rank - (rank & -rank);
}

inline std::vector<int> tree_children(int rank, int size, bool flat) {
    std::vector<int> children;
    if (flat) {
        for (int r = 1; rank == 0 && r < size; ++r) children.push_back(r);
        return children;
    }
    for (int bit = 1; rank + bit < size && (rank == 0 || bit < (rank & -rank)); bit <<= 1)
        children.push_back(rank + bit);
    return children;
}

// The ranks whose sums `child`'s message holds: [child, tree_end(child, size, flat)).
inline int tree_end(int child, int size, bool flat) {
    return flat ? child + 1 : std::min(size, child + (child & -child));
}

}  // namespace mcpt::wire
