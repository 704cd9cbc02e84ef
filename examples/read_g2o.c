/* Reading a graph file: pgem_io_read parses a g2o (or TORO) file into a heap-allocated
 * pgem_io_graph_t, pgem_io_config sizes an instance for it, pgem_io_load copies it in, and the
 * file graph can be freed before solving. Usage: example_read_g2o [FILE.g2o]
 * Without an argument it reads a small graph embedded below. Links pgem::pgem (core + I/O). */
#include <stdio.h>

#include <pgem/io.h>
#include <pgem/pgem.h>

/* A 2D square walk with drifting vertex guesses and one loop closure (0 -> 4 is "home"). */
static const char embedded[] =
    "# embedded example: VERTEX_SE2 id x y theta, EDGE_SE2 from to dx dy dtheta + information\n"
    "VERTEX_SE2 0 0 0 0\n"
    "VERTEX_SE2 1 1.05 0.02 1.62\n"
    "VERTEX_SE2 2 1.01 1.09 3.12\n"
    "VERTEX_SE2 3 -0.08 1.05 4.6\n"
    "VERTEX_SE2 4 -0.11 -0.05 6.2\n"
    "FIX 0\n"
    "EDGE_SE2 0 1 1 0 1.5707963267948966 100 0 0 100 0 400\n"
    "EDGE_SE2 1 2 1 0 1.5707963267948966 100 0 0 100 0 400\n"
    "EDGE_SE2 2 3 1 0 1.5707963267948966 100 0 0 100 0 400\n"
    "EDGE_SE2 3 4 1 0 1.5707963267948966 100 0 0 100 0 400\n"
    "EDGE_SE2 4 0 0 0 0 100 0 0 100 0 400\n";

/* Called after every Gauss-Newton iteration (the core never prints by itself). */
static int print_iteration(const pgem_iteration_t *iteration, void *user)
{
    (void)user;
    printf("  iteration %2u  chi2 %.6f  step %.3g\n", iteration->iteration, iteration->chi2,
           iteration->step_norm);
    return 0; /* non-zero would stop the solve */
}

int main(int argc, char **argv)
{
    char message[512];
    pgem_io_graph_t file;
    int status;
    if (argc > 1) {
        status = pgem_io_read(argv[1], PGEM_FORMAT_AUTO, &file, message, sizeof message);
    } else {
        FILE *stream = tmpfile(); /* C99: a temporary file, removed when closed */
        if (stream == NULL || fputs(embedded, stream) == EOF) {
            fprintf(stderr, "cannot write a temporary file\n");
            return 1;
        }
        rewind(stream);
        status = pgem_io_read_stream(stream, "embedded.g2o", PGEM_FORMAT_AUTO, &file, message,
                                     sizeof message);
        fclose(stream);
    }
    if (status != PGEM_OK) {
        fprintf(stderr, "%s\n", message); /* "FILE:LINE: what is wrong" */
        return 1;
    }
    printf("read %s: %dD, %zu poses, %zu edges, %zu fixed\n", file.source, file.dimension,
           file.pose_count, file.edge_count, file.fixed_count);

    pgem_config_t config;
    pgem_io_config(&file, &config); /* capacities that fit the file exactly */
    pgem_t *graph = NULL;
    status = pgem_create(&graph, &config);
    if (status == PGEM_OK) {
        status = pgem_io_load(&file, graph, message, sizeof message);
    } else {
        snprintf(message, sizeof message, "%s", pgem_io_error_description(status));
    }
    pgem_io_graph_free(&file); /* the instance holds its own copy now */
    if (status != PGEM_OK) {
        fprintf(stderr, "%s: %s\n", pgem_io_error_name(status), message);
        pgem_destroy(graph);
        return 1;
    }

    pgem_solve_options_t options = {0}; /* Gauss-Newton, default tolerances */
    options.on_iteration = print_iteration;
    pgem_summary_t summary;
    status = pgem_optimize(graph, &options, &summary);
    if (status != PGEM_OK) {
        fprintf(stderr, "optimize failed: %s\n", pgem_last_error(graph));
        pgem_destroy(graph);
        return 1;
    }
    pgem_memory_stats_t stats;
    pgem_memory_use(graph, &stats);
    printf("initial chi2 %.5f, final chi2 %.5f after %u iterations (%s)\n", summary.initial_chi2,
           summary.final_chi2, summary.iterations, pgem_termination_name(summary.termination));
    printf("memory: block %zu bytes, factor %u of %u nonzeros budgeted\n", stats.block_bytes,
           stats.factor_nonzeros, stats.factor_budget);
    pgem_destroy(graph);
    return 0;
}
