/* Oscillation between EM's passes: each pass (consistency test, rounds, polish) ends at a set
 * of accepted loops; when a pass comes back to a set an earlier pass ended at, the passes
 * cycle (the test re-admits what the rounds prune, or two sets alternate) and would go on to
 * the pass limit. The cycle's sets are compared by the robust cost of their polished
 * estimates, the Cauchy cost that EM's weights come from: c^2 log(1 + s / c^2) for every loop
 * (pruned ones included, so that sets of different sizes compare), s for every odometry edge.
 * The passes go on around the cycle to its cheapest set and end there. */
#include "robust/robust.h"

/* FNV-1a, 64 bits, over one more byte. */
static uint64_t pgem_fnv(uint64_t hash, uint8_t byte)
{
    return (hash ^ byte) * 1099511628211ull;
}

void pgem_pass_mark(const pgem_store_t *store, int tangent, double scale, pgem_pass_mark_t *mark)
{
    uint64_t hash = 14695981039346656037ull;
    mark->accepted = 0;
    mark->cost = 0.0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        const double chi2 = pgem_edge_mahalanobis(store, k, tangent);
        if (store->edge_kind[k] != PGEM_EDGE_LOOP) {
            mark->cost += chi2;
            continue;
        }
        mark->cost += pgem_kernel_evaluate(PGEM_KERNEL_EM, chi2, scale).rho;
        /* a loop's state: accepted, pruned, or left out with its run (pruned at weight 0) */
        uint8_t state = store->edge_active[k] != PGEM_EDGE_PRUNED ? 1u
                        : store->edge_weight[k] == 0.0      ? 2u
                                                            : 0u;
        mark->accepted += (uint32_t)(state == 1u);
        for (int b = 0; b < 4; b++) {
            hash = pgem_fnv(hash, (uint8_t)(k >> (8 * b)));
        }
        hash = pgem_fnv(hash, state);
    }
    mark->set = hash;
}

static int pgem_same_set(const pgem_pass_mark_t *a, const pgem_pass_mark_t *b)
{
    return a->set == b->set && a->accepted == b->accepted;
}

int pgem_settle_pass(pgem_settle_t *settle, const pgem_pass_mark_t *mark)
{
    if (settle->cycling) {
        /* around the cycle to its cheapest set; if the passes stray from the cycle (they
         * need not repeat to the bit), they end after as many passes as the cycle has */
        return pgem_same_set(mark, &settle->target) || --settle->remaining == 0u;
    }
    const uint32_t kept = settle->count < PGEM_PASS_MARKS ? settle->count : PGEM_PASS_MARKS;
    for (uint32_t age = 1; age <= kept; age++) {
        const pgem_pass_mark_t *seen = &settle->marks[(settle->count - age) % PGEM_PASS_MARKS];
        if (!pgem_same_set(mark, seen)) {
            continue;
        }
        /* the cycle: the sets of the last `age` passes, this one's among them */
        uint32_t best = age;
        for (uint32_t back = 1; back < age; back++) {
            const pgem_pass_mark_t *other = &settle->marks[(settle->count - back) % PGEM_PASS_MARKS];
            if (other->cost < settle->marks[(settle->count - best) % PGEM_PASS_MARKS].cost) {
                best = back;
            }
        }
        if (best == age) {
            return 1; /* this pass's set is the cycle's cheapest */
        }
        settle->target = settle->marks[(settle->count - best) % PGEM_PASS_MARKS];
        settle->cycling = 1;
        settle->remaining = age;
        return 0;
    }
    settle->marks[settle->count % PGEM_PASS_MARKS] = *mark;
    settle->count++;
    return 0;
}
