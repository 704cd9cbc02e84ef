/* The firmware example's job (see firmware_run.h). No stdio: newlib's formatted output can
 * allocate, so numbers are formatted here, the same way on every machine. */
#include "firmware_run.h"

#include <string.h>

typedef struct report {
    const firmware_io_t *io;
    char line[160];
    size_t length;
} report_t;

static void put_text(report_t *r, const char *text)
{
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

int firmware_run(const firmware_io_t *io, void *block, size_t size)
{
    report_t report = {io, {0}, 0};
    report_t *r = &report;
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
    pgem_get_memory_stats(graph, &stats);
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
    double last[3];
    (void)pgem_get_pose(graph, FIRMWARE_POSES - 1u, last);
    put_text(r, "last pose: x ");
    put_fixed(r, last[0], 6);
    put_text(r, "  y ");
    put_fixed(r, last[1], 6);
    put_text(r, "  theta ");
    put_fixed(r, last[2], 6);
    end_line(r);
    return 0;
}
