/** @file
 * pgem compaction: a long mission's map in a fixed block. Poses are removed and each removed
 * pose's edges replaced by edges among the poses it was joined to, so the map goes on growing
 * after the block is full. */
#ifndef PGEM_COMPACT_H
#define PGEM_COMPACT_H

#include <stdint.h>

#include "pgem/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Options of pgem_compact; zero-initialise for the defaults. */
typedef struct pgem_compact_options {
    uint32_t tail;        /**< the newest poses (insertion order) never removed: a front-end
                               is still linking them (0: 32) */
    int chain_only;       /**< 1: only poses no accepted or dormant loop closure touches */
    int keep_pruned;      /**< 1: pruned loop closures are carried too, still pruned (a live
                               stream's verdicts are provisional: a later EM pass may admit
                               them again); 0: they go with their pose */
    uint32_t target_edges; /**< 0, or: after target_poses, more poses go (a tenth of those
                               left at a time) until at most this many edges remain or none
                               more can go; for a block whose edges fill before its poses */
    uint32_t *pose_map;   /**< optional: receives, for each pose index before the call, its
                               index after (UINT32_MAX: removed); room for the poses before */
    uint32_t *edge_map;   /**< optional: the same for edge indices (a composed edge keeps the
                               index of one of the two it replaced) */
} pgem_compact_options_t;

/** What pgem_compact did. */
typedef struct pgem_compact_summary {
    uint32_t poses_before;
    uint32_t poses_after;
    uint32_t edges_before;
    uint32_t edges_after;
    uint32_t edges_composed;  /**< pairs of odometry edges through a removed pose made one */
    uint32_t loops_carried;   /**< loop closures moved from a removed pose onto a neighbour (a
                                   loop moved again from there counts again) */
    uint32_t loops_dropped;   /**< pruned loop closures removed with their pose */
    uint32_t loops_fused;     /**< loop closures joining the same two kept poses as another,
                                   fused into it */
} pgem_compact_summary_t;

/**
 * Removes poses until at most target_poses remain, or none more can go, in the block (nothing
 * is allocated). A pose can go when exactly two odometry edges join it to two other poses
 * (a trajectory's chain) and it is neither held (pgem_fix_pose, pgem_hold_gauge, the first
 * pose while none is) nor among the newest `tail`; its two odometry edges become one, their
 * composition, with the information of the pair once the pose is marginalised out
 * about the current estimate, and the measurement moved so that the new edge has the pair's
 * gradient there too (on a solved map the kept poses' optimum does not move; on a dead-reckoned
 * one the measurement is the plain composition). Poses without loop
 * closures go first, spread along the chain; then, unless chain_only, poses with loop
 * closures: each accepted or dormant loop moves onto the neighbour on the chain, composed
 * with the odometry edge to it, keeping its robust weight and state (nothing is decided
 * again); a pruned loop goes with its pose and is counted. The kept poses keep their ids and
 * estimates; indices close up in order (options->pose_map and edge_map say where each went).
 * The next pgem_update rebuilds its factor; a later solve analyses the smaller graph. Errors:
 * INVALID_ARGUMENT (a NULL graph); PGEM_OK with poses_after above target_poses (or edges_after
 * above options->target_edges) when no more poses can go.
 */
int pgem_compact(pgem_t *graph, uint32_t target_poses, const pgem_compact_options_t *options,
                 pgem_compact_summary_t *summary);

#ifdef __cplusplus
}
#endif

#endif /* PGEM_COMPACT_H */
