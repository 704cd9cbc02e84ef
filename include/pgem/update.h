/** @file
 * pgem online: the incremental update a front-end calls after adding poses and edges, whose
 * cost follows what the new data touches rather than the size of the map. */
#ifndef PGEM_UPDATE_H
#define PGEM_UPDATE_H

#include <stdint.h>

#include "pgem/core.h"
#include "pgem/robust.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Options of pgem_update; a zeroed struct means the documented defaults. */
typedef struct pgem_update_options {
    double relinearize_threshold; /**< a pose is relinearised when a component of its step
                                       from its linearisation point exceeds this (radians and
                                       the map's units); 0 means 0.1; negative: every update
                                       relinearises every pose that moved */
    double reorder_growth;        /**< the factor is re-ordered, relinearised and refactored
                                       whole once the blocks of its pattern exceed this many
                                       times those of the last such rebuild, plus
                                       reorder_slack; 0 means 1.5 (the room columns keep to
                                       grow in is not counted: when the pool runs out of
                                       room, the update rebuilds to pack it) */
    uint32_t reorder_slack;       /**< blocks added to that bound (0 means 64 per 1000 poses
                                       of capacity, at least 256) */
    double wildfire_threshold;    /**< the back-substitution recomputes a pose's step only when
                                       the update touched its column or a step it depends on
                                       changed by more than this (iSAM2's "wildfire"); 0 means
                                       1e-3 (iSAM2's default); negative: every step, every update */
    uint32_t relinearize_limit;   /**< relinearising refactors the columns it changes (in
                                       place, on the present pattern) instead of applying rank
                                       updates when those would cost more (estimated from the
                                       paths' blocks) or, if not 0, when more than this many
                                       poses are due */
    uint32_t relinearize_skip;    /**< poses are relinearised on every this-many-th update
                                       only (iSAM2's relinearizeSkip), or sooner once this
                                       many poses arrived since they last were (so updates
                                       that each add many poses relinearise every time); in
                                       between, the steps are taken from the same
                                       linearisation points; 0 means 10 (iSAM2's default),
                                       1: every update */
    uint32_t recent_last;         /**< a rebuild's ordering puts this many of the newest poses
                                       last, in arrival order; 0 means 8 */
    int robust;                   /**< 1: a new loop closure enters only if it passes the
                                       consistency gate under the current map (its innovation:
                                       residual against Omega^-1 + inflation J Sigma J^T), else
                                       it is pruned; pruned loops whose poses were
                                       relinearised are tested again and come back when they
                                       pass. 0: every loop enters with its weight. */
    double pending;               /**< robust, > 0: a loop closure that passes the gate only
                                       because the map is uncertain, its error alone (e^T
                                       Omega e, the map taken as certain) above `pending`
                                       times the gate, waits, pruned, for a whole-graph pass
                                       (pgem_update_adopt) or a relinearisation of its poses
                                       to judge it, instead of bending the map now. For hosts
                                       that run such passes (the LCM bridge uses 10: with 1,
                                       true loops of a map still one Gauss-Newton step from
                                       its optimum waited too, and a fast stream left
                                       thousands waiting); without passes a drift-correcting
                                       loop would wait long. 0: none */
    double gate;                  /**< robust: 0 means the 99.9 % chi-square quantile (16.27 in
                                       2D, 22.46 in 3D) */
    double odometry_inflation;    /**< robust: the map's covariance factor in the gate,
                                       graded with the map's variance as in EM's consistency
                                       test (the same test, docs/design/innovation.md); 0
                                       means 1 (the batch consistency test's allowance of 4
                                       let false loops of M3500 + 100 in while the map was
                                       still uncertain: the settle solve re-decides anyway) */
    int rebuild;                  /**< 1: rebuild now (after the estimate was changed by
                                       anything but pgem_update: pgem_set_pose, a solve) */
} pgem_update_options_t;

/** What one pgem_update did. */
typedef struct pgem_update_summary {
    uint32_t poses_added;         /**< poses that got a block column */
    uint32_t edges_added;         /**< edges that entered the factor */
    uint32_t relinearized;        /**< poses whose linearisation point moved */
    uint32_t columns_touched;     /**< block columns whose values changed (the rest kept
                                       theirs): the work of the update */
    uint32_t rank_updates;        /**< rank-one updates and downdates applied */
    uint32_t columns;             /**< block columns of the factor */
    uint32_t factor_blocks;       /**< b x b blocks of the factor's pool in use */
    int rebuilt;                  /**< 1 if the factor was ordered and factorised from scratch */
    uint32_t loops_accepted;      /**< robust: new loop closures that passed the gate */
    uint32_t loops_rejected;      /**< robust: new loop closures pruned */
    uint32_t loops_readmitted;    /**< robust: pruned loops that passed it again */
    uint32_t loops;               /**< loop closures in the graph after the update */
    uint32_t loops_pruned;        /**< of them pruned (by the gate, or by an earlier robust
                                       solve or adopted pass) */
    pgem_robust_outcome_t outcome; /**< what a robust solve's summary would say of those
                                       loops, by the same rule: NO_LOOPS, LOOPS_ACCEPTED,
                                       MOST_REJECTED (more than 90 % pruned), ALL_REJECTED.
                                       The three are running counts, O(new edges) per update:
                                       counted over every edge when the update rebuilds its
                                       factor (as it does after anything else changed loop
                                       states: a robust solve, pgem_update_adopt,
                                       pgem_compact) or fails, else carried from the last
                                       update with its new loops and re-admissions. Zero
                                       when the update did not run (NULL, CONFIG, an invalid
                                       option) */
} pgem_update_summary_t;

/** Brings the estimate up to date with the poses and edges added since the last call (the
 * first call, or one after options->rebuild, orders and factorises everything). The factor
 * lives in its own part of the block (config.online_fill; an instance without it gets
 * PGEM_ERR_CONFIG). Cost: new poses get block columns at the end of the ordering; each new
 * edge, each weight change and each relinearised pose is a low-rank update of the factor
 * along the elimination-tree path of the columns it touches; then one triangular solve.
 * Nothing is allocated except by a rebuild's ordering (CSparse's AMD, as pgem_analyze). The
 * result is one Gauss-Newton step per update from per-pose linearisation points, not the
 * optimum: call pgem_update_settle (or pgem_optimize) for that, e.g. at the end of a stream.
 * Errors: CONFIG, FILL_BUDGET (the pool cannot hold the factor even packed: the message gives
 * the blocks needed), NOT_POSITIVE_DEFINITE (a pose with no path to a held pose), NUMERIC,
 * OUT_OF_MEMORY. On an error the estimate is left as the last successful update left it and
 * the next call rebuilds. options and summary may be NULL. */
int pgem_update(pgem_t *graph, const pgem_update_options_t *options,
                pgem_update_summary_t *summary);

/** The batch solve from the incremental estimate: with robust, every loop closure back in
 * (pgem_robust_reset: the online gate's decisions are only a start) and pgem_robust_optimize
 * (EM's rounds, pruning and consistency test as offline, from the online estimate); with robust
 * NULL, pgem_optimize to convergence. The next pgem_update rebuilds from its result. Returns
 * the solve's status. */
struct pgem_robust_options;
struct pgem_robust_summary;
int pgem_update_settle(pgem_t *graph, const struct pgem_robust_options *robust,
                       struct pgem_robust_summary *summary);

/** What pgem_update_adopt did. */
typedef struct pgem_adopt_summary {
    uint32_t poses_adopted;   /**< poses that took the pass's estimate */
    uint32_t poses_carried;   /**< poses added since the pass, moved with the correction */
    uint32_t edges_adopted;   /**< edges that took the pass's weight and state */
    uint32_t loops_changed;   /**< of those, loop closures whose verdict the pass changed
                                   (accepted by the updates, pruned by the pass, or back) */
} pgem_adopt_summary_t;

/** Takes a whole-graph robust pass into the incremental graph while the updates go on: the
 * live map gets batch EM's decisions without waiting for the stream to pause. The host copies
 * the graph into a second instance (pgem_init of a block of its own, sized up front, then
 * pgem_copy), solves the copy there (pgem_robust_reset and pgem_robust_optimize, on another
 * thread, or a lower-priority task on firmware) while pgem_update goes on with new poses and
 * edges on `graph`, then calls this on the thread that owns `graph`. `pass` must hold a prefix
 * of graph: its poses and edges are graph's first ones, in the same order (ids, ends, kinds;
 * the pass may hold poses that graph leaves free, such as poses no edge reached yet at the
 * copy). Then: the poses the pass holds take its estimate, and every pose added since
 * is carried along with the correction (placed as the updates had it relative to the first
 * pose an edge joins it to, odometry first); the edges the pass holds take its weights and
 * verdicts; loop closures added since keep the updates' verdicts (the next pass judges them).
 * The next pgem_update rebuilds the factor at that estimate. Nothing is allocated; pass
 * is only read. Errors: INVALID_ARGUMENT (NULL, or pass is not a prefix of graph: the message
 * names the pose or edge index; nothing changes), DIMENSION, CONFIG (graph has no
 * config.online_fill). summary may be NULL. */
int pgem_update_adopt(pgem_t *graph, const pgem_t *pass, pgem_adopt_summary_t *summary);

/** Bytes pgem_update_save needs at the instance's capacity: a header of 24 bytes, per pose
 * its value and held flag (25 bytes in 2D, 57 in 3D), per edge 18 bytes (weight, state, the
 * robust layer's last distance and check). 0 for NULL. */
size_t pgem_update_save_size(const pgem_t *graph);

/** Copies the estimate, every pose's held flag, every edge's robust weight and state and
 * whether the incremental factor is current into buffer (size bytes, at least
 * pgem_update_save_size; byte-packed, any alignment). With pgem_update_restore it undoes a
 * batch solve that was stopped midway: a settle solve asked to give way to new data (the
 * robust solve's on_round, or its solve options' on_iteration, returning non-zero ends it
 * with PGEM_ROBUST_STOPPED). Nothing is allocated. Errors: INVALID_ARGUMENT (NULL, or size too
 * small: the message says so). */
int pgem_update_save(pgem_t *graph, void *buffer, size_t size);

/** Puts back what pgem_update_save kept, when the graph still has the poses and edges it had
 * then (else INVALID_ARGUMENT, naming both counts, and nothing changes): the estimate, held
 * flags, weights and states are the saved ones to the bit, and since a batch solve leaves the
 * incremental factor alone, the next pgem_update goes on from it without a rebuild if it was
 * current at the save. The next batch solve analyses anew. Everything is checked before
 * anything is put back: a buffer that is not such a save (a pose NaN, beyond
 * PGEM_TRANSLATION_LIMIT or with a quaternion off unit norm: NOT_FINITE, OUT_OF_RANGE,
 * ROTATION; a held flag that is no hold (above 4: free, fixed, a gauge, a part's gauge held by
 * a robust solve), fixed flags not as many as the header counts, a weight
 * outside [0, 1], an unknown state, an impossible header: INVALID_ARGUMENT) is refused, the
 * message naming the pose (index and id) or edge (index and ids) and the field ("the save's
 * pose 17 (id 17): field y is beyond the translation limit (1e8 m): not a save of this graph,
 * nothing restored"), and nothing changes. */
int pgem_update_restore(pgem_t *graph, const void *buffer, size_t size);

/** Bytes config.online_fill scalar nonzeros add to pgem_memory_size (an upper bound) for
 * max_poses poses and max_edges edges: per pose 14 ints and a pose, two steps and a b x b
 * block of doubles, per edge 4 ints and a double, per nonzero 8 bytes and an int per b x b
 * block, and alignment. */
#define PGEM_ONLINE_BYTES(dimension, max_poses, max_edges, online_fill)                       \
    ((online_fill) == 0u ? (size_t)0u                                                        \
                         : (size_t)(max_poses) * ((dimension) == 3 ? 520u : 224u) +            \
                               (size_t)(max_edges) * 24u + (size_t)(online_fill) * 8u +        \
                               (size_t)(online_fill) / ((dimension) == 3 ? 36u : 9u) * 4u + 512u)

#ifdef __cplusplus
}
#endif

#endif /* PGEM_UPDATE_H */
