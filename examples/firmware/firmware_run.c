/* The firmware example's job (see firmware_run.h). No stdio: newlib's formatted output can
 * allocate, so numbers are formatted here, the same way on every machine. */
#include "firmware_run.h"

#include <math.h>
#include <string.h>

typedef struct report {
    const firmware_io_t *io;
    char line[160];
    size_t length;
    int notes; /* lines start with '#': printed, not compared between targets */
} report_t;

static void put_text(report_t *r, const char *text)
{
    if (r->notes && r->length == 0u && text[0] != '#') {
        memcpy(r->line, "# ", 2);
        r->length = 2;
    }
    size_t n = strlen(text);
    if (n > sizeof r->line - 1u - r->length) {
        n = sizeof r->line - 1u - r->length;
    }
    memcpy(r->line + r->length, text, n);
    r->length += n;
}

static void put_u64(report_t *r, uint64_t value)
{
    char text[24]; /* filled from the end: 20 digits at most */
    size_t first = sizeof text - 1u;
    text[first] = '\0';
    do {
        text[--first] = (char)('0' + (int)(value % 10u));
        value /= 10u;
    } while (value != 0);
    put_text(r, text + first);
}

/* value with `decimals` digits after the point, rounded half away from zero. */
static void put_fixed(report_t *r, double value, int decimals)
{
    if (value != value) {
        put_text(r, "nan");
        return;
    }
    double scale = 1.0;
    for (int k = 0; k < decimals; k++) {
        scale *= 10.0;
    }
    double magnitude = (value < 0.0 ? -value : value) * scale + 0.5;
    if (!(magnitude < 9.0e18)) {
        put_text(r, value < 0.0 ? "-huge" : "huge");
        return;
    }
    uint64_t scaled = (uint64_t)magnitude;
    uint64_t unit = (uint64_t)scale;
    if (value < 0.0 && scaled != 0) {
        put_text(r, "-");
    }
    put_u64(r, scaled / unit);
    if (decimals > 0) {
        char fraction[24];
        uint64_t rest = scaled % unit;
        for (int k = decimals - 1; k >= 0; k--) {
            fraction[k] = (char)('0' + (int)(rest % 10u));
            rest /= 10u;
        }
        fraction[decimals] = '\0';
        put_text(r, ".");
        put_text(r, fraction);
    }
}

static void end_line(report_t *r)
{
    r->line[r->length++] = '\n';
    r->io->write(r->line, r->length);
    r->length = 0;
}

/* One line: "LABEL: x X  y Y  theta T", pose id's estimate to 6 decimals. */
static void put_pose_line(report_t *r, const char *label, const pgem_t *graph, pgem_id_t id)
{
    double pose[3];
    (void)pgem_pose(graph, id, pose);
    put_text(r, label);
    put_text(r, ": x ");
    put_fixed(r, pose[0], 6);
    put_text(r, "  y ");
    put_fixed(r, pose[1], 6);
    put_text(r, "  theta ");
    put_fixed(r, pose[2], 6);
    end_line(r);
}

/* One line: texts[0] values[0] texts[1] ... values[count - 1] texts[count]. */
static void put_series(report_t *r, const char *const *texts, const uint64_t *values, int count)
{
    for (int k = 0; k < count; k++) {
        put_text(r, texts[k]);
        put_u64(r, values[k]);
    }
    put_text(r, texts[count]);
    end_line(r);
}

static int fail(report_t *r, const pgem_t *graph, const char *what, int status)
{
    put_text(r, "error: ");
    put_text(r, what);
    put_text(r, ": ");
    put_text(r, pgem_error_name(status));
    if (graph != NULL) {
        put_text(r, ": ");
        put_text(r, pgem_last_error(graph));
    }
    end_line(r);
    return 1;
}

static int load(report_t *r, pgem_t *graph)
{
    const double information[9] = {firmware_information[0], 0, 0, 0, firmware_information[1], 0,
                                   0, 0, firmware_information[2]};
    for (uint32_t k = 0; k < FIRMWARE_POSES; k++) {
        const double pose[3] = {firmware_poses[k].x, firmware_poses[k].y, firmware_poses[k].theta};
        int status = pgem_add_pose(graph, k, pose);
        if (status != PGEM_OK) {
            return fail(r, graph, "pgem_add_pose", status);
        }
    }
    int status = pgem_fix_pose(graph, 0, 1);
    if (status != PGEM_OK) {
        return fail(r, graph, "pgem_fix_pose", status);
    }
    for (uint32_t k = 0; k < FIRMWARE_EDGES; k++) {
        const fw_edge_t *edge = &firmware_edges[k];
        status = pgem_add_edge(graph, edge->from, edge->to, edge->z, information,
                               edge->kind == 0 ? PGEM_EDGE_ODOMETRY : PGEM_EDGE_LOOP, NULL);
        if (status != PGEM_OK) {
            return fail(r, graph, "pgem_add_edge", status);
        }
    }
    return 0;
}

/* The pruned loop closures, several to a line, and how they compare with the truth. */
static void report_loops(report_t *r, const pgem_t *graph)
{
    unsigned false_pruned = 0, true_pruned = 0, true_loops = 0, on_line = 0;
    put_text(r, "pruned:");
    for (uint32_t k = 0; k < FIRMWARE_EDGES; k++) {
        pgem_edge_view_t edge;
        if (firmware_edges[k].kind == 0 || pgem_edge_at(graph, k, &edge) != PGEM_OK) {
            continue;
        }
        const int is_false = firmware_edges[k].kind == 2;
        true_loops += !is_false;
        if (edge.active) {
            continue;
        }
        false_pruned += is_false;
        true_pruned += !is_false;
        if (on_line == 8) {
            end_line(r);
            put_text(r, "pruned:");
            on_line = 0;
        }
        put_text(r, " ");
        put_u64(r, edge.from);
        put_text(r, "-");
        put_u64(r, edge.to);
        on_line++;
    }
    end_line(r);
    const char *const texts[] = {"false loop closures pruned: ", " of ",
                                 ", true loop closures pruned: ", " of ", ""};
    const uint64_t values[] = {false_pruned, FIRMWARE_FALSE_LOOPS, true_pruned, true_loops};
    put_series(r, texts, values, 4);
}

static int batch_run(report_t *r, void *block, size_t size)
{
    const firmware_io_t *io = r->io;
    const pgem_config_t config = {2, FIRMWARE_POSES, FIRMWARE_EDGES, FIRMWARE_FILL, 0, 0};
    const char *const block_texts[] = {"# block: ", " bytes needed, ", " reserved"};
    const uint64_t block_values[] = {pgem_memory_size(&config), size};
    put_series(r, block_texts, block_values, 2);

    pgem_t *graph = NULL;
    int status = pgem_init(&graph, &config, block, size);
    if (status != PGEM_OK) {
        return fail(r, NULL, "pgem_init", status);
    }
    if (load(r, graph) != 0) {
        return 1;
    }
    const char *const graph_texts[] = {"graph: ", " poses, ", " edges, ",
                                       " false loop closures among them"};
    const uint64_t graph_values[] = {pgem_pose_count(graph), pgem_edge_count(graph),
                                     FIRMWARE_FALSE_LOOPS};
    put_series(r, graph_texts, graph_values, 3);

    pgem_robust_options_t options = {0};
    options.kernel = PGEM_KERNEL_EM;
    pgem_robust_summary_t summary;
    if (io->counter_start != NULL) {
        io->counter_start();
    }
    status = pgem_robust_optimize(graph, &options, NULL, &summary);
    uint64_t counted = io->counter_read != NULL ? io->counter_read() : 0;
    if (status != PGEM_OK) {
        return fail(r, graph, "pgem_robust_optimize", status);
    }
    if (io->counter_read != NULL) {
        put_text(r, "# EM solve: ");
        put_u64(r, counted);
        put_text(r, " ");
        put_text(r, io->counter_unit);
        end_line(r);
    }
    pgem_memory_stats_t stats;
    pgem_memory_use(graph, &stats);
    const char *const memory_texts[] = {"# factor nonzeros: ", " of ", ", CSparse pool peak ",
                                        " of ", " bytes, block used ", ""};
    const uint64_t memory_values[] = {stats.factor_nonzeros, stats.factor_budget,
                                      stats.csparse_pool_peak, stats.csparse_pool_bytes,
                                      stats.used_bytes};
    put_series(r, memory_texts, memory_values, 5);
    const char *const em_texts[] = {"EM: ", " rounds, ", " E/M iterations, ",
                                    " Gauss-Newton iterations, ", " of ",
                                    " loop closures pruned"};
    const uint64_t em_values[] = {summary.rounds, summary.em_iterations, summary.gn_iterations,
                                  summary.pruned, summary.loops};
    put_series(r, em_texts, em_values, 5);
    report_loops(r, graph);
    put_text(r, "chi2: ");
    put_fixed(r, summary.initial_chi2, 3);
    put_text(r, " -> ");
    put_fixed(r, summary.final_chi2, 6);
    end_line(r);
    put_pose_line(r, "last pose", graph, FIRMWARE_POSES - 1u);
    return 0;
}

/* ---- The long mission: a stream of STREAM_POSES poses in a block of STREAM_BLOCK_POSES ---- */

/* A removed pose: pose `id` = pose `anchor` composed with `relative`. */
typedef struct anchor_entry {
    uint32_t id;
    uint32_t anchor;
    double relative[3];
} anchor_entry_t;

typedef struct stream {
    anchor_entry_t anchors[STREAM_ANCHORS]; /* a ring: the oldest entry is overwritten */
    uint32_t anchor_count, anchor_next;
    /* per index of the block, around a compaction */
    pgem_id_t ids[STREAM_BLOCK_POSES];
    double before[STREAM_BLOCK_POSES][3];
    uint32_t pose_map[STREAM_BLOCK_POSES];
    uint32_t edge_map[STREAM_BLOCK_EDGES];
    unsigned char edge_kind[STREAM_BLOCK_EDGES]; /* the table's kind of each edge of the block */
    /* counts for the report */
    uint64_t compactions, removed, composed, carried, dropped_pruned, fused, refused_capacity;
    uint64_t reanchored, reanchor_dropped, refused_forgotten, forgotten;
    uint64_t false_dropped, true_dropped, false_fused, true_fused;
    uint64_t longest_update, longest_compaction;
    uint32_t most_poses, most_edges;
} stream_t;

static stream_t stream_state; /* in .bss: no heap */

static const anchor_entry_t *anchor_find(const stream_t *s, uint32_t id)
{
    for (uint32_t k = 0; k < s->anchor_count; k++) {
        if (s->anchors[k].id == id) {
            return &s->anchors[k];
        }
    }
    return NULL;
}

/* The block index of pose id before the compaction (ids grow with the index), or UINT32_MAX. */
static uint32_t index_before(const stream_t *s, uint32_t count, uint32_t id)
{
    uint32_t low = 0, high = count;
    while (low < high) {
        const uint32_t mid = low + (high - low) / 2u;
        if (s->ids[mid] < id) {
            low = mid + 1u;
        } else {
            high = mid;
        }
    }
    return low < count && s->ids[low] == id ? low : UINT32_MAX;
}

/* The kept pose before index i (the first pose is held, so never removed). */
static uint32_t kept_before(const stream_t *s, uint32_t i)
{
    while (i > 0 && s->pose_map[i] == UINT32_MAX) {
        i--;
    }
    return i;
}

static void stream_compact(const firmware_io_t *io, stream_t *s, pgem_t *graph)
{
    const uint32_t poses = pgem_pose_count(graph), edges = pgem_edge_count(graph);
    for (uint32_t i = 0; i < poses; i++) {
        (void)pgem_pose_at(graph, i, &s->ids[i], s->before[i], NULL);
    }
    unsigned char active[STREAM_BLOCK_EDGES];
    for (uint32_t k = 0; k < edges; k++) {
        pgem_edge_view_t view;
        (void)pgem_edge_at(graph, k, &view);
        active[k] = (unsigned char)view.active;
    }
    pgem_compact_options_t options = {0};
    options.pose_map = s->pose_map;
    options.edge_map = s->edge_map;
    pgem_compact_summary_t summary;
    if (io->counter_start != NULL) {
        io->counter_start();
    }
    (void)pgem_compact(graph, STREAM_LOW, &options, &summary);
    if (io->counter_read != NULL) {
        const uint64_t counted = io->counter_read();
        s->longest_compaction = counted > s->longest_compaction ? counted : s->longest_compaction;
    }
    s->compactions++;
    s->removed += summary.poses_before - summary.poses_after;
    s->composed += summary.edges_composed;
    s->carried += summary.loops_carried;
    s->dropped_pruned += summary.loops_dropped;
    s->fused += summary.loops_fused;
    /* entries anchored on a pose removed now move to that pose's own anchor */
    for (uint32_t k = 0; k < s->anchor_count; k++) {
        anchor_entry_t *entry = &s->anchors[k];
        const uint32_t i = index_before(s, poses, entry->anchor);
        if (i == UINT32_MAX || s->pose_map[i] != UINT32_MAX) {
            continue;
        }
        const uint32_t kept = kept_before(s, i);
        double step[3];
        pgem_se2_between(s->before[kept], s->before[i], step);
        pgem_se2_compose(step, entry->relative, entry->relative);
        entry->anchor = (uint32_t)s->ids[kept];
    }
    /* the poses removed now, each on the kept pose before it */
    for (uint32_t i = 0; i < poses; i++) {
        if (s->pose_map[i] != UINT32_MAX) {
            continue;
        }
        const uint32_t kept = kept_before(s, i);
        anchor_entry_t *entry = &s->anchors[s->anchor_next];
        s->forgotten += s->anchor_count == STREAM_ANCHORS;
        entry->id = (uint32_t)s->ids[i];
        entry->anchor = (uint32_t)s->ids[kept];
        pgem_se2_between(s->before[kept], s->before[i], entry->relative);
        s->anchor_next = (s->anchor_next + 1u) % STREAM_ANCHORS;
        s->anchor_count += s->anchor_count < STREAM_ANCHORS;
    }
    /* the table's kinds follow the edges; loops gone with their pose or fused are counted */
    for (uint32_t k = 0; k < edges; k++) {
        const uint32_t j = s->edge_map[k];
        const unsigned char kind = s->edge_kind[k];
        if (j != UINT32_MAX) {
            s->edge_kind[j] = kind;
        } else if (kind != 0) {
            uint64_t *count = active[k] ? (kind == 2 ? &s->false_fused : &s->true_fused)
                                        : (kind == 2 ? &s->false_dropped : &s->true_dropped);
            (*count)++;
        }
    }
}

/* A table edge whose poses may have been removed, on their anchors. 0: add it as *out says;
 * 1: both ends on one pose (dropped); 2: a pose no longer known (refused, *forgotten names it). */
static int stream_reexpress(stream_t *s, const pgem_t *graph, const fw_edge_t *edge,
                            uint32_t ends[2], double z[3], uint32_t *forgotten)
{
    uint32_t index;
    ends[0] = edge->from;
    ends[1] = edge->to;
    z[0] = edge->z[0];
    z[1] = edge->z[1];
    z[2] = edge->z[2];
    int moved = 0;
    for (int end = 0; end < 2; end++) {
        if (pgem_pose_index(graph, ends[end], &index) == PGEM_OK) {
            continue;
        }
        const anchor_entry_t *entry = anchor_find(s, ends[end]);
        if (entry == NULL) {
            *forgotten = ends[end];
            return 2;
        }
        if (end == 0) { /* anchor^-1 to = relative * z */
            pgem_se2_compose(entry->relative, z, z);
        } else { /* from^-1 anchor = z * relative^-1 */
            double inverse[3];
            pgem_se2_inverse(entry->relative, inverse);
            pgem_se2_compose(z, inverse, z);
        }
        ends[end] = entry->anchor;
        moved = 1;
    }
    s->reanchored += (uint64_t)moved;
    return ends[0] == ends[1] ? 1 : 0;
}

/* RMS and largest translation error of the kept poses against the truth (no alignment: the
 * first pose is held where the truth starts). */
static void stream_error(report_t *r, const pgem_t *graph, const char *when)
{
    double sum = 0.0, largest = 0.0;
    const uint32_t poses = pgem_pose_count(graph);
    for (uint32_t i = 0; i < poses; i++) {
        pgem_id_t id;
        double pose[3];
        (void)pgem_pose_at(graph, i, &id, pose, NULL);
        const double dx = pose[0] - stream_truth[id].x, dy = pose[1] - stream_truth[id].y;
        const double squared = dx * dx + dy * dy;
        sum += squared;
        largest = squared > largest ? squared : largest;
    }
    put_text(r, "error of the ");
    put_u64(r, poses);
    put_text(r, " kept poses against the truth ");
    put_text(r, when);
    put_text(r, ": rms ");
    put_fixed(r, poses > 0 ? sqrt(sum / (double)poses) : 0.0, 4);
    put_text(r, " m, max ");
    put_fixed(r, sqrt(largest), 4);
    put_text(r, " m");
    end_line(r);
}

/* The loop closures the block still holds, pruned or not, with those gone before. */
static void stream_loops(report_t *r, const stream_t *s, const pgem_t *graph)
{
    uint64_t false_pruned = s->false_dropped, true_pruned = s->true_dropped;
    uint64_t false_kept = 0, true_kept = 0;
    for (uint32_t k = 0; k < pgem_edge_count(graph); k++) {
        pgem_edge_view_t view;
        if (s->edge_kind[k] == 0 || pgem_edge_at(graph, k, &view) != PGEM_OK) {
            continue;
        }
        const int is_false = s->edge_kind[k] == 2;
        if (view.active) {
            false_kept += (uint64_t)is_false;
            true_kept += (uint64_t)!is_false;
        } else {
            false_pruned += (uint64_t)is_false;
            true_pruned += (uint64_t)!is_false;
        }
    }
    const char *const texts[] = {"loop closures in the block: ", " true and ",
                                 " false accepted, ", " true and ", " false pruned", ""};
    const uint64_t values[] = {true_kept, false_kept, true_pruned - s->true_dropped,
                               false_pruned - s->false_dropped};
    put_series(r, texts, values, 4);
    const char *const gone_texts[] = {"loop closures gone with their poses: pruned ", " true, ",
                                      " false, fused into another ", " true, ", " false", ""};
    const uint64_t gone_values[] = {s->true_dropped, s->false_dropped, s->true_fused,
                                    s->false_fused};
    put_series(r, gone_texts, gone_values, 4);
}

static int stream_run(report_t *r, void *block, size_t size)
{
    const firmware_io_t *io = r->io;
    stream_t *s = &stream_state;
    memset(s, 0, sizeof *s);
    pgem_config_t config = {2, STREAM_BLOCK_POSES, STREAM_BLOCK_EDGES, STREAM_FILL, 0,
                            STREAM_ONLINE_FILL};
    const char *const block_texts[] = {"# stream block: ", " bytes needed, ", " reserved, ",
                                       " bytes of anchor table"};
    const uint64_t block_values[] = {pgem_memory_size(&config), size, sizeof s->anchors};
    put_series(r, block_texts, block_values, 3);
    pgem_t *graph = NULL;
    int status = pgem_init(&graph, &config, block, size);
    if (status != PGEM_OK) {
        return fail(r, NULL, "pgem_init", status);
    }
    const double information[9] = {stream_information[0], 0, 0, 0, stream_information[1], 0,
                                   0, 0, stream_information[2]};
    const double origin[3] = {stream_poses[0].x, stream_poses[0].y, stream_poses[0].theta};
    status = pgem_add_pose(graph, 0, origin);
    if (status == PGEM_OK) {
        status = pgem_fix_pose(graph, 0, 1);
    }
    if (status != PGEM_OK) {
        return fail(r, graph, "pgem_add_pose", status);
    }
    pgem_update_options_t update = {0};
    update.robust = 1;
    uint32_t next = 0;
    for (uint32_t pose = 1; pose < STREAM_POSES; pose++) {
        for (; next < STREAM_EDGES; next++) {
            const fw_edge_t *edge = &stream_edges[next];
            if ((edge->from > edge->to ? edge->from : edge->to) != pose) {
                break;
            }
            if (edge->kind == 0) { /* the new pose where the odometry from the last one puts it */
                double from[3], guess[3];
                (void)pgem_pose(graph, edge->from, from);
                pgem_se2_compose(from, edge->z, guess);
                status = pgem_add_pose(graph, pose, guess);
                if (status != PGEM_OK) {
                    s->refused_capacity += status == PGEM_ERR_CAPACITY;
                    return fail(r, graph, "pgem_add_pose", status);
                }
            }
            uint32_t ends[2], forgotten = 0;
            double z[3];
            const int how = stream_reexpress(s, graph, edge, ends, z, &forgotten);
            if (how == 1) {
                s->reanchor_dropped++;
                continue;
            }
            if (how == 2) {
                s->refused_forgotten++;
                put_text(r, "refused: edge ");
                put_u64(r, edge->from);
                put_text(r, "-");
                put_u64(r, edge->to);
                put_text(r, ": pose ");
                put_u64(r, forgotten);
                put_text(r, " is no longer in the anchor table");
                end_line(r);
                continue;
            }
            const uint32_t index = pgem_edge_count(graph);
            status = pgem_add_edge(graph, ends[0], ends[1], z, information,
                                   edge->kind == 0 ? PGEM_EDGE_ODOMETRY : PGEM_EDGE_LOOP, NULL);
            if (status != PGEM_OK) {
                return fail(r, graph, "pgem_add_edge", status);
            }
            s->edge_kind[index] = edge->kind;
        }
        if (io->counter_start != NULL) {
            io->counter_start();
        }
        pgem_update_summary_t summary;
        status = pgem_update(graph, &update, &summary);
        if (io->counter_read != NULL) {
            const uint64_t counted = io->counter_read();
            s->longest_update = counted > s->longest_update ? counted : s->longest_update;
        }
        if (status != PGEM_OK) {
            return fail(r, graph, "pgem_update", status);
        }
        const uint32_t poses = pgem_pose_count(graph), edges = pgem_edge_count(graph);
        s->most_poses = poses > s->most_poses ? poses : s->most_poses;
        s->most_edges = edges > s->most_edges ? edges : s->most_edges;
        if (poses >= STREAM_HIGH ||
            (uint64_t)edges * STREAM_BLOCK_POSES >= (uint64_t)STREAM_HIGH * STREAM_BLOCK_EDGES) {
            stream_compact(io, s, graph);
        }
    }
    const char *const stream_texts[] = {"stream: ", " poses, ", " edges (",
                                        " false loop closures) into a block of ", " poses and ",
                                        " edges, ", " times its poses"};
    const uint64_t stream_values[] = {STREAM_POSES, STREAM_EDGES, STREAM_FALSE_LOOPS,
                                      STREAM_BLOCK_POSES, STREAM_BLOCK_EDGES,
                                      STREAM_POSES / STREAM_BLOCK_POSES};
    put_series(r, stream_texts, stream_values, 6);
    /* (No ';' in these lines: the comparison reads a report as a CMake list.)
     * What follows hangs on every estimate the stream went through, and a compaction's edges
     * are quadratic forms about the estimate: the last bits newlib's and glibc's sin and cos
     * round differently grow into other compaction and gate decisions. So the stream's figures
     * are notes; each target checks its own (firmware_qemu_stream, example_firmware_stream). */
    r->notes = 1;
    const char *const compact_texts[] = {"compactions: ", " at ", " poses to ", ", ",
                                         " poses removed, ", " odometry pairs composed, ",
                                         " loop closures carried, ", " fused, ",
                                         " pruned ones dropped", ""};
    const uint64_t compact_values[] = {s->compactions, STREAM_HIGH, STREAM_LOW, s->removed,
                                       s->composed, s->carried, s->fused, s->dropped_pruned};
    put_series(r, compact_texts, compact_values, 8);
    const char *const anchor_texts[] = {"edges to removed poses: ", " re-anchored, ",
                                        " dropped (both ends on one kept pose), ",
                                        " refused (forgotten), anchors forgotten: ", ""};
    const uint64_t anchor_values[] = {s->reanchored, s->reanchor_dropped, s->refused_forgotten,
                                      s->forgotten};
    put_series(r, anchor_texts, anchor_values, 4);
    const char *const most_texts[] = {"block: at most ", " poses and ", " edges held, ",
                                      " refused for capacity", ""};
    const uint64_t most_values[] = {s->most_poses, s->most_edges, s->refused_capacity};
    put_series(r, most_texts, most_values, 3);
    if (io->counter_read != NULL) {
        const char *const time_texts[] = {"# stream: longest pgem_update ",
                                          ", longest pgem_compact ", ""};
        const uint64_t time_values[] = {s->longest_update, s->longest_compaction};
        put_series(r, time_texts, time_values, 2);
        put_text(r, "#   (");
        put_text(r, io->counter_unit);
        put_text(r, ")");
        end_line(r);
    }
    stream_error(r, graph, "after the updates");
    pgem_robust_options_t robust = {0};
    robust.kernel = PGEM_KERNEL_EM;
    pgem_robust_summary_t settled;
    status = pgem_update_settle(graph, &robust, &settled);
    if (status != PGEM_OK) {
        return fail(r, graph, "pgem_update_settle", status);
    }
    stream_error(r, graph, "after EM on the block");
    stream_loops(r, s, graph);
    pgem_memory_stats_t stats;
    pgem_memory_use(graph, &stats);
    const char *const memory_texts[] = {"# stream factor nonzeros: ", " of ", ", block used ", ""};
    const uint64_t memory_values[] = {stats.factor_nonzeros, stats.factor_budget,
                                      stats.used_bytes};
    put_series(r, memory_texts, memory_values, 3);
    put_pose_line(r, "stream last pose", graph, STREAM_POSES - 1u);
    return 0;
}

int firmware_run(const firmware_io_t *io, void *block, size_t size)
{
    report_t report = {io, {0}, 0, 0};
    if (batch_run(&report, block, size) != 0) {
        return 1;
    }
    return stream_run(&report, block, size);
}
