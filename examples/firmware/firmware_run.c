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
    char digits[24];
    size_t n = 0;
    do {
        digits[n++] = (char)('0' + (int)(value % 10u));
        value /= 10u;
    } while (value != 0);
    char text[24];
    for (size_t k = 0; k < n; k++) {
        text[k] = digits[n - 1u - k];
    }
    text[n] = '\0';
    put_text(r, text);
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
    put_text(r, "false loop closures pruned: ");
    put_u64(r, false_pruned);
    put_text(r, " of ");
    put_u64(r, FIRMWARE_FALSE_LOOPS);
    put_text(r, ", true loop closures pruned: ");
    put_u64(r, true_pruned);
    put_text(r, " of ");
    put_u64(r, true_loops);
    end_line(r);
}

int firmware_run(const firmware_io_t *io, void *block, size_t size)
{
    report_t report = {io, {0}, 0};
    report_t *r = &report;
    const pgem_config_t config = {2, FIRMWARE_POSES, FIRMWARE_EDGES, FIRMWARE_FILL};
    put_text(r, "# block: ");
    put_u64(r, pgem_memory_size(&config));
    put_text(r, " bytes needed, ");
    put_u64(r, size);
    put_text(r, " reserved");
    end_line(r);

    pgem_t *graph = NULL;
    int status = pgem_init(&graph, &config, block, size);
    if (status != PGEM_OK) {
        return fail(r, NULL, "pgem_init", status);
    }
    if (load(r, graph) != 0) {
        return 1;
    }
    put_text(r, "graph: ");
    put_u64(r, pgem_pose_count(graph));
    put_text(r, " poses, ");
    put_u64(r, pgem_edge_count(graph));
    put_text(r, " edges, ");
    put_u64(r, FIRMWARE_FALSE_LOOPS);
    put_text(r, " false loop closures among them");
    end_line(r);

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
    put_text(r, "# factor nonzeros: ");
    put_u64(r, stats.factor_nonzeros);
    put_text(r, " of ");
    put_u64(r, stats.factor_budget);
    put_text(r, ", CSparse pool peak ");
    put_u64(r, stats.csparse_pool_peak);
    put_text(r, " of ");
    put_u64(r, stats.csparse_pool_bytes);
    put_text(r, " bytes, block used ");
    put_u64(r, stats.used_bytes);
    end_line(r);

    put_text(r, "EM: ");
    put_u64(r, summary.rounds);
    put_text(r, " rounds, ");
    put_u64(r, summary.em_iterations);
    put_text(r, " E/M iterations, ");
    put_u64(r, summary.gn_iterations);
    put_text(r, " Gauss-Newton iterations, ");
    put_u64(r, summary.pruned);
    put_text(r, " of ");
    put_u64(r, summary.loops);
    put_text(r, " loop closures pruned");
    end_line(r);
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
