/* The solver thread's side of the live EM pass (pass.c runs it): when the next one starts,
 * and a finished one adopted into the live map or dropped. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <string.h>

#include "bridge_internal.h"

/* The estimate was replaced other than by an update or a pass (a reset, a whole-graph solve):
 * a pass of an older copy stops after its round and is dropped when it ends. */
void bridge_pass_drop(bridge_t *bridge)
{
    bridge->solver.live_em.generation++;
    bridge->solver.live_em.pass.cancel = 1;
}


/* A finished pass into the live map, when the graph it copied is still the live one's prefix:
 * its estimate, weights and verdicts (pgem_update_adopt), then an update at them (a rebuild;
 * loops that arrived since keep the gate's verdicts), published. A pass is adopted even when
 * it finds the live map's verdicts: the gate puts a loop in at weight 1 and EM at its soft
 * weight, so the estimates still differ (7.8 cm on M3500 with 100 false loops after the last
 * pass), and the live map is to end where batch EM does. */
static void adopt_pass(bridge_t *bridge)
{
    bridge_pass_t *pass = &bridge->solver.live_em.pass;
    const double start = bridge_now();
    if (pass->status != PGEM_OK || pass->summary.termination == PGEM_ROBUST_STOPPED ||
        pass->generation != bridge->solver.live_em.generation || bridge->solver.restart_pending) {
        bridge_log(bridge, "live EM pass dropped (%s)",
                   pass->status != PGEM_OK ? pgem_error_name(pass->status)
                   : pass->generation != bridge->solver.live_em.generation
                       ? "the graph was re-solved or reset since its copy"
                   : pass->summary.termination == PGEM_ROBUST_STOPPED ? "stopped"
                                                                      : "a restart is owed");
        return;
    }
    pgem_adopt_summary_t adopted;
    int status = pgem_update_adopt(bridge->solver.core, pass->core, &adopted);
    if (status != PGEM_OK) {
        bridge_note(bridge, "live EM pass not adopted: %s", pgem_last_error(bridge->solver.core));
        return;
    }
    pgem_robust_summary_t summary;
    memset(&summary, 0, sizeof summary);
    const double adopted_at = bridge_now();
    status = bridge_solve_update(bridge, &summary); /* it rebuilds: every loop counted */
    const double updated_at = bridge_now();
    summary.rounds = pass->summary.rounds;
    char why[256] = "";
    bridge_solve_done(bridge, status, &summary, why, sizeof why);
    if (status != PGEM_OK) {
        bridge->solver.restart_pending =
            1; /* the next solve says why, from the front-end's estimates */
    }
    pass->passes++;
    const int64_t micros = (int64_t)((bridge_now() - start) * 1e6);
    bridge_solver_counts(bridge);
    bridge_publish_graph(bridge, "em-pass", &summary, status == PGEM_OK, why, micros);
    if (status == PGEM_OK) {
        bridge_covariance_publish(bridge, 0);
    }
    bridge_log(bridge,
               "live EM pass %llu: EM on %u poses and %u loops (%u pruned, %u rounds) in %.0f ms, "
               "%.0f ms after its copy; adopted: %u verdicts changed, %u later poses carried; "
               "now %u of %u loops pruned (%.1f ms: adopt %.1f, update %.1f)",
               (unsigned long long)pass->passes, adopted.poses_adopted, pass->loops_at_copy,
               pass->summary.pruned, pass->summary.rounds, 1e3 * pass->solve_took,
               1e3 * pass->took, adopted.loops_changed, adopted.poses_carried,
               bridge->solver.pruned_count, bridge->solver.loop_count,
               1e-3 * (double)micros, 1e3 * (adopted_at - start), 1e3 * (updated_at - adopted_at));
    if (status != PGEM_OK) {
        bridge_note(bridge, "the update after live EM pass %llu failed: %s",
                    (unsigned long long)pass->passes, why);
    }
    bridge_publish_status(bridge);
}

double bridge_pass_due(const bridge_t *bridge)
{
    return bridge->solver.live_em.on && bridge->solver.live_em.pass.state == BRIDGE_PASS_IDLE &&
                   bridge->solver.loop_count != bridge->solver.live_em.loops
               ? bridge->solver.live_em.next
               : (double)INFINITY;
}

void bridge_pass_schedule(bridge_t *bridge)
{
    if (!bridge->solver.live_em.on) {
        return;
    }
    const int state = bridge_pass_state(&bridge->solver.live_em.pass);
    if (state == BRIDGE_PASS_RUNNING) {
        return;
    }
    const double now = bridge_now();
    if (state == BRIDGE_PASS_DONE) {
        adopt_pass(bridge);
        bridge->solver.live_em.took = bridge->solver.live_em.pass.took;
        bridge->solver.live_em.next =
            now + bridge->solver.live_em.took; /* at most half the time in passes */
        bridge_pass_release(&bridge->solver.live_em.pass);
    }
    /* The next one: when loop closures arrived since the last copy, the map is up to date (no
     * restart owed), and the last pass's time has passed since it ended. */
    if (now < bridge->solver.live_em.next ||
        bridge->solver.loop_count == bridge->solver.live_em.loops) {
        return;
    }
    (void)bridge_components_hold(bridge); /* the copy holds each part where the live map does */
    if (bridge->solver.restart_pending ||
        bridge->solver.solved_poses != pgem_pose_count(bridge->solver.core)) {
        bridge->solver.live_em.next = now + 0.05; /* not now: look again a little later */
        return;
    }
    if (bridge_pass_start(&bridge->solver.live_em.pass, bridge->solver.core,
                          bridge->solver.compaction.count == 0u ? bridge->solver.raw : NULL,
                          bridge->solver.live_em.generation, now) != 0) {
        bridge_note(bridge, "live EM pass: cannot copy the graph: %s",
                    pgem_last_error(bridge->solver.live_em.pass.core));
        bridge->solver.live_em.on = 0;
        return;
    }
    bridge->solver.live_em.loops = bridge->solver.loop_count;
}
